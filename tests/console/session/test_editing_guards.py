"""Guards on the operator's edits: an object is never moved onto the robot, junk in an object's Centre
fields refuses the whole move (named), Save as never takes a file the session folder keeps for itself,
and a capture counts the pinned objects it saw again and says when one is pinned far from where it is seen.

Everything waits on state (the capture jobs run in this thread), never on time.
"""

from __future__ import annotations

import math
from pathlib import Path
from types import SimpleNamespace
from typing import Iterator

import pytest
import viser

from console.link.sim import SimRobot
from console.session.edit_rules import box_overlaps_body
from console.session.mapping_job import GROUND_TRUTH_LABEL, MapperPerceiver, MappingJob, ground_truth_bundle_for
from console.session.session import NOTICE, RobotSnapshot, Session, SessionError
from console.views import objects_view
from console.views.objects_view import ObjectsView
from pipeline.camera.geometry import Pose
from pipeline.scene import Scene, SceneObject

START = (2.5, 0.7, 0.0)
DESK = SceneObject("desk-1", "desk", (1.0, 3.3, 0.375), (1.4, 0.75, 0.7))


@pytest.fixture()
def session(tmp_path: Path) -> Session:
    s = Session(tmp_path / "s", start=START, autosave=False)
    s.spawn(Scene(objects=(DESK,)))
    return s


# --- 1. an object is never moved onto the robot ------------------------------------------------------
def test_moving_an_object_onto_the_robot_is_refused_and_changes_nothing(session: Session) -> None:
    scene, grid = session.scene, session.grid
    with pytest.raises(SessionError) as refused:
        session.move_object("desk-1", (2.5, 0.7, 0.37))
    assert str(refused.value) == ("cannot move desk-1 there: it would overlap the robot at (2.50, 0.70) (0.35 m "
                                  "radius): move the robot first or choose another place")
    assert session.scene is scene and session.grid is grid
    # the desk is 1.4 m wide across its yaw (+x here): its long side 0.2 m from the robot's centre
    with pytest.raises(SessionError, match="overlap the robot"):
        session.move_object("desk-1", (2.5, 0.7 + 0.7 + 0.2, 0.37))
    session.move_object("desk-1", (2.5, 0.7 + 0.7 + 0.4, 0.37))  # 0.05 m clear of the body: allowed
    assert session.scene.object("desk-1").position == pytest.approx((2.5, 1.8, 0.37))


def test_the_rule_follows_the_robot_where_it_stands_now(session: Session) -> None:
    session.set_robot(RobotSnapshot(pose=Pose.from_xyz_yaw(1.0, 1.5, 0.0, 0.3), mode="idle"))
    with pytest.raises(SessionError, match=r"overlap the robot at \(1\.00, 1\.50\)"):
        session.move_object("desk-1", (1.2, 1.6, 0.375), 0.5)
    session.move_object("desk-1", (2.5, 0.7, 0.375))  # where the robot started: free now
    assert session.scene.object("desk-1").position == pytest.approx((2.5, 0.7, 0.375))


def test_body_overlap_is_the_cylinder_against_the_turned_box() -> None:
    robot = (0.0, 0.0, 0.0)
    size = (0.4, 0.5, 2.0)  # w, h, l: 2 m long along its yaw
    assert box_overlaps_body((1.2, 0.0, 0.25), size, 0.0, robot)  # its end 0.2 m from the robot
    assert not box_overlaps_body((1.2, 0.0, 0.25), size, math.pi / 2, robot)  # turned: 1.0 m clear
    assert not box_overlaps_body((0.0, 0.0, 0.25 + 0.45 + 0.01), size, 0.0, robot)  # above the 0.45 m body
    assert not box_overlaps_body((0.0, 0.6, 0.25), size, 0.0, robot)  # beside it: 0.4 m clear
    assert box_overlaps_body((0.0, 0.5, 0.25), size, 0.0, robot)  # 0.3 m from its side


# --- 2. junk in the Centre fields refuses the whole move, named ---------------------------------------
@pytest.fixture()
def server() -> Iterator[viser.ViserServer]:
    srv = viser.ViserServer(host="127.0.0.1", port=0, verbose=False)
    yield srv
    srv.stop()


@pytest.mark.parametrize(("centre", "yaw", "said"), [
    (("abc", 2.5, "nan"), 0.0, "centre.x: must be a number [m], got 'abc'"),
    ((1.0, 2.5, "nan"), 0.0, "centre.z: must be a finite number [m], got 'nan'"),
    ((1.0, "inf", 0.4), 0.0, "centre.y: must be a finite number [m], got 'inf'"),
    ((1.0, 2.5, 0.4), "nan", "yaw: must be a finite number [deg], got 'nan'"),
])
def test_junk_in_a_centre_field_refuses_the_whole_move(server: viser.ViserServer, session: Session,
                                                      monkeypatch: pytest.MonkeyPatch, centre, yaw, said) -> None:
    told: list[tuple[str, str]] = []
    monkeypatch.setattr(objects_view, "tell", lambda client, title, body, *a, **k: told.append((title, body)))
    view = ObjectsView(server, session)
    session.select("desk-1")
    scene = session.scene
    for handle, text in zip(view._pose.centre, centre):  # what the tab sent (text fields)
        handle.value = str(text)
    view._pose.yaw.value = str(yaw)
    view._on_move(SimpleNamespace(client=None))
    assert told == [("Cannot move", said)]
    assert session.scene is scene and session.scene.object("desk-1").position == DESK.position


# --- 3. Save as never takes the session's own files ----------------------------------------------------
@pytest.mark.parametrize("name", ["session", "Session", "SESSION.json", " session ", "History", "captures/photo"])
def test_save_as_refuses_the_files_the_session_keeps_for_itself(tmp_path: Path, name: str) -> None:
    s = Session(tmp_path / "s", start=START)
    s.spawn(Scene(objects=(DESK,)))
    live = (s.folder / "session.json").read_text()
    with pytest.raises(SessionError, match="session itself|undo history|keeps its photos"):
        s.save(name, overwrite=True)
    assert (s.folder / "session.json").read_text() == live
    assert not any(p.name.lower() == "session.json" and p.name != "session.json" for p in s.folder.iterdir())
    assert s.save("sessions") == s.folder / "sessions.json"  # a name merely like it is fine


# --- 4. the capture counts the pinned objects it saw again ---------------------------------------------
@pytest.fixture()
def robot() -> Iterator[SimRobot]:
    r = SimRobot(start=Pose.from_xyz_yaw(2.5, 0.7, 0.0, math.pi / 2 + 0.55), manual_clock=True)
    r.connect()
    yield r
    r.close()


def test_a_capture_counts_pinned_objects_and_names_one_pinned_far_away(tmp_path: Path, robot: SimRobot) -> None:
    session = Session(tmp_path / "s", autosave=False)
    notices = []
    session.subscribe(lambda t, p: notices.append(p) if t == NOTICE else None)
    job = MappingJob(session, robot.capture, MapperPerceiver(GROUND_TRUTH_LABEL, ground_truth_bundle_for))
    assert job.run()
    x, y, z = session.scene.object("desk-1").position
    session.move_object("desk-1", (x, y, z))  # pinned where it is
    assert job.run()
    assert ", 1 kept pinned," in notices[-1].body and "desk-1 is pinned" not in notices[-1].body.split(";")[0]
    assert "from where this capture sees it" not in notices[-1].body
    session.move_object("desk-1", (x - 0.4, y, z))  # the operator pinned it 0.4 m off
    assert job.run()
    far = "desk-1 is pinned 0.4 m from where this capture sees it: move it there, or delete it to let the map follow"
    assert (notices[-1].title, notices[-1].body, notices[-1].level) == ("Pinned object seen elsewhere", far, "warning")
    mapped = next(n for n in reversed(notices) if n.title == "Mapped")
    head = mapped.body.split("; ")
    assert ", 1 kept pinned," in head[0] and head[1] == far and mapped.level == "warning"
    assert session.job.message.startswith(head[0] + "; " + far)
    seen = int(head[0].split(" object")[0])  # "16 objects seen (0 new, 11 updated, 1 kept pinned, 4 not used)"
    counts = [int(w) for w in head[0].split("(")[1].split(")")[0].replace(",", "").split() if w.isdigit()]
    assert len(counts) == 4 and sum(counts) == seen  # every object the capture saw is counted once
