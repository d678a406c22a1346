"""Objects that come into the map over the robot's body, by each path (console/session/edit_rules.py).

A capture cannot see the robot it is on: what it maps over the robot is dropped, with a notice naming it
(through the real mapping job). A scene file or a loaded session is the operator's word: opened as it is,
warned about by name, and Execute stays off until the object is moved away (the reason names it).
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np

from console.link.base import CaptureResult, Mode, RobotState
from console.session.mapping_job import MappingJob, Perception
from console.session.session import NOTICE, Session
from console.session.session_types import robot_snapshot
from pipeline.camera.geometry import CameraMount, Intrinsics, Pose, camera_pose_in_world
from pipeline.scene import Scene, SceneObject, Source

START = (2.5, 0.7, 0.0)
ON_ROBOT = SceneObject("desk-9", "desk", (2.6, 0.9, 0.375), (1.4, 0.75, 0.7))  # its box covers the robot's origin
FAR = SceneObject("crate-2", "cardboard_box", (2.5, 4.0, 0.3), (0.5, 0.6, 0.5))


def _standing(xyz: tuple[float, float, float] = START) -> object:
    return robot_snapshot(RobotState(time=time.time(), position=xyz, mode=Mode.IDLE, armed=False, landed=True))


def _session(tmp_path: Path, name: str = "s") -> tuple[Session, list]:
    s = Session(tmp_path / name, start=START, autosave=False)
    told: list = []
    s.subscribe(lambda topic, payload: told.append(payload) if topic == NOTICE else None)
    s.set_robot(_standing())
    return s, told


class _Perceiver:
    """Maps the desk over the robot and a crate in front of it (what a wrong depth or pose could give)."""

    label = "test"

    def perceive(self, shot, capture_id, progress):  # type: ignore[no-untyped-def]
        objs = tuple(SceneObject(f"{o.label}-{n + 1}", o.label, o.position, o.size,
                                 source=Source(capture=capture_id, method="fused")) for n, o in enumerate((ON_ROBOT, FAR)))
        return Perception(Scene(objects=objs), (), None, {})


def _shot() -> CaptureResult:
    robot = Pose.from_xyz_yaw(*START)
    return CaptureResult(np.zeros((24, 32, 3), np.uint8), Intrinsics(30.0, 30.0, 16.0, 12.0, 32, 24),
                         camera_pose_in_world(robot, CameraMount()), robot)


def test_a_capture_never_maps_an_object_over_the_robot(tmp_path: Path) -> None:
    s, told = _session(tmp_path)
    assert MappingJob(s, _shot, _Perceiver()).run()
    labels = sorted(o.label for o in s.scene.objects)
    assert labels == ["cardboard_box"], labels  # the crate is mapped; the desk over the robot is not
    dropped = [n.body for n in told if n.title == "Mapped object dropped"]
    assert len(dropped) == 1 and "desk 'desk-1' mapped over the robot's own body at (2.50, 0.70)" in dropped[0]
    assert "a camera cannot see the robot it is on" in dropped[0]


def test_without_a_reported_pose_a_capture_keeps_its_objects(tmp_path: Path) -> None:
    s = Session(tmp_path / "s", start=START, autosave=False)  # no robot report: nothing to judge by
    s.spawn(Scene(objects=(ON_ROBOT,)), origin="capture c1")
    assert [o.id for o in s.scene.objects] == ["desk-9"]


def _plan(s: Session) -> None:
    res = s.add_goal((2.5, 3.0, 0.0))
    assert res.ok, res.message
    s.register()
    s.build_mission()


def test_a_scene_file_over_the_robot_opens_warns_and_keeps_execute_off_until_moved(tmp_path: Path) -> None:
    s, told = _session(tmp_path)
    s.spawn(Scene(objects=(ON_ROBOT, FAR)), origin="file room.json")
    assert {o.id for o in s.scene.objects} == {"desk-9", "crate-2"}  # opened as it is: the operator's word
    assert s.warn_objects_over_robot("scene file room.json")  # the console warns naming it (app._spawn_file)
    assert "desk 'desk-9' lies over the robot" in told[-1].body
    _plan(s)
    why = s.operator_state().execute_blocker
    assert why == ("desk 'desk-9' overlaps the robot at (2.50, 0.70) (0.35 m radius): move or delete it (or correct "
                   "the robot's position) before running a mission")
    s.move_object("desk-9", (2.6, 2.0, 0.375))  # away from the robot (and off the route, which is re-planned)
    if s.mission is None:  # the move retired it: built again
        _plan(s)
    assert s.operator_state().execute_blocker is None


def test_loading_a_session_with_an_object_over_the_robot_warns_and_names_it(tmp_path: Path) -> None:
    a, _ = _session(tmp_path, "a")
    a.spawn(Scene(objects=(ON_ROBOT,)), origin="file room.json")
    saved = a.save("with-desk")
    b, told = _session(tmp_path, "b")
    (b.folder / saved.name).write_bytes(saved.read_bytes())  # the snapshot, in the other session's folder
    notes = b.load("with-desk")
    assert any("session with-desk" in n and "desk 'desk-9' lies over the robot" in n for n in notes), notes
    assert [n.title for n in told if n.title == "Object over the robot"] == ["Object over the robot"]
