"""The console's Capture & map job calls the map fusion: rejection reasons reach the operator, a capture
of another room is held back until the operator merges, replaces or discards it (issue 12)."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Iterator

import pytest

from console.link.sim import SimRobot
from console.session.mapping_job import GROUND_TRUTH_LABEL, MapperPerceiver, MappingJob, ground_truth_bundle_for
from console.session.session import NOTICE, Session, SessionError
from pipeline.camera.geometry import Pose
from pipeline.scene import Scene, SceneObject, Source


def _robot(x: float, y: float, yaw: float, world: Scene | None = None) -> SimRobot:
    robot = SimRobot(world=world, start=Pose.from_xyz_yaw(x, y, 0.0, yaw), manual_clock=True)
    robot.connect()
    return robot


@pytest.fixture()
def robots() -> Iterator[list[SimRobot]]:
    made: list[SimRobot] = []
    yield made
    for r in made:
        r.close()


def _other_room() -> Scene:
    def obj(oid: str, label: str, x: float, y: float, size) -> SceneObject:
        return SceneObject(oid, label, (x, y, size[1] / 2), size, source=Source(method="ground_truth"))

    return Scene(objects=(
        obj("sofa-1", "sofa", 1.2, 3.3, (2.0, 0.85, 0.9)),
        obj("office_cabinet-1", "office_cabinet", 3.0, 2.4, (0.8, 1.85, 0.42)),
        obj("trash_bin-1", "trash_bin", 2.2, 2.0, (0.4, 0.65, 0.4)),
        obj("suitcase-1", "suitcase", 0.6, 1.9, (0.45, 0.68, 0.27)),
        obj("plant-1", "plant", 3.8, 1.9, (0.4, 0.8, 0.4)),
    ))


def test_capture_job_reports_rejections_and_holds_back_another_room(tmp_path: Path, robots: list[SimRobot]) -> None:
    session = Session(tmp_path / "s", autosave=False)
    notices = []
    session.subscribe(lambda t, p: notices.append(p) if t == NOTICE else None)
    perceiver = MapperPerceiver(GROUND_TRUTH_LABEL, ground_truth_bundle_for)

    def job_for(robot: SimRobot) -> MappingJob:
        robots.append(robot)
        return MappingJob(session, robot.capture, perceiver)

    assert job_for(_robot(2.5, 0.7, math.pi / 2 + 0.55)).run()
    first = session.scene
    assert first.objects and notices[-1].title == "Mapped"

    # the camera 0.07 m in front of desk-1: the desk's view is rejected, the reason told
    assert job_for(_robot(0.8, 2.38, math.pi / 2)).run()
    assert notices[-1].title == "Mapped" and "camera too close" in notices[-1].body
    assert "not used" in session.job.message
    desks = [o for o in session.scene.objects if o.label == "desk"]
    assert [d.position for d in desks] == [o.position for o in first.objects if o.label == "desk"]

    # the same pose in another room: held back, the map unchanged, the operator decides
    job = job_for(_robot(2.5, 0.7, math.pi / 2 + 0.55, world=_other_room()))
    before = session.scene
    assert job.run()
    assert job.held is not None and notices[-1].title == "Capture held back" and notices[-1].level == "warning"
    assert session.scene is before and "held back" in session.job.message
    with pytest.raises(SessionError, match="merge, replace or discard"):
        job.resolve_held("keep")
    assert "merge" in job.resolve_held("merge")
    assert job.held is None and len(session.scene.objects) > len(before.objects)
    with pytest.raises(SessionError, match="no capture is held back"):
        job.resolve_held("discard")


def test_object_details_list_the_observations_the_pin_and_the_corrections() -> None:
    from console.views.objects_view import describe
    from pipeline.mapping.map_fusion import fuse
    from pipeline.scene import Capture

    cam = {"fx": 320.0, "fy": 320.0, "cx": 320.0, "cy": 240.0, "width": 640.0, "height": 480.0}

    def seen(cid: str, x: float, z: float, bbox) -> Scene:
        o = SceneObject("d", "desk", (x, 3.0, z), (1.4, 0.75, 0.7), source=Source(cid, "depth", bbox=bbox))
        return Scene(objects=(o,), captures=(Capture(cid, intrinsics=cam, camera_position=(2.0, 0.5, 0.35)),))

    scene, _ = fuse(Scene(), seen("c1", 2.0, 0.675, (200.0, 150.0, 420.0, 330.0)))  # floats 0.3 m
    scene, _ = fuse(scene, seen("c2", 2.3, 0.375, (0.0, 0.0, 640.0, 480.0)))  # the camera too close
    text = describe(scene.objects[0])
    assert "floating 0.30 m above the floor" in text
    assert "Observations** (1 of 2 used)" in text
    assert "| c1 | 2.52 m | 0.20 m / 20° | yes |" in text  # 0.05 + 0.06 m per metre; yaw 0.35 rad
    assert "| c2 |" in text and "no: camera too close: the box covers the whole image" in text
    assert "pinned" not in text
    pinned = scene.objects[0].moved((2.0, 3.0, 0.375))
    assert "**Pinned**" in describe(pinned)


def test_held_capture_buttons_show_while_a_capture_is_held_and_resolve_it(tmp_path: Path,
                                                                          robots: list[SimRobot]) -> None:
    import viser

    from console.views.held_capture import HeldCaptureControls

    server = viser.ViserServer(host="127.0.0.1", port=0, verbose=False)
    try:
        session = Session(tmp_path / "s", autosave=False)
        perceiver = MapperPerceiver(GROUND_TRUTH_LABEL, ground_truth_bundle_for)
        robots.append(_robot(2.5, 0.7, math.pi / 2 + 0.55))
        robots.append(_robot(2.5, 0.7, math.pi / 2 + 0.55, world=_other_room()))
        room_a, room_b = (MappingJob(session, r.capture, perceiver) for r in robots)
        controls = HeldCaptureControls(server, session, room_b)
        assert room_a.run() and not controls.buttons.visible
        assert room_b.run() and room_b.held is not None
        assert controls.buttons.visible
        assert "cardboard_box" in {o.label for o in session.scene.objects}
        kept = {o.id for o in session.scene.objects if o.label == "desk"}
        pinned = next(iter(kept))
        session.move_object(pinned, session.scene.object(pinned).position)  # the operator confirms one desk
        done = controls.choose("Replace")
        assert done is not None and "replace" in done and not controls.buttons.visible
        labels = {o.label for o in session.scene.objects}
        assert "sofa" in labels and "cardboard_box" not in labels  # room A's objects are gone ...
        assert pinned in {o.id for o in session.scene.objects}  # ... but the pinned desk stays
        assert controls.choose("Discard") is None  # nothing held any more: refused, told
    finally:
        server.stop()
