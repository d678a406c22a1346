"""Look around / Look at: the robot turns in place and captures & maps at each heading; Pause holds it."""

from __future__ import annotations

import math
import time
from pathlib import Path

import pytest

from console.link.sim import SimConfig, SimRobot
from console.session.look import LookJob, headings_around
from console.session.mapping_job import GROUND_TRUTH_LABEL, MapperPerceiver, MappingJob, ground_truth_bundle_for
from console.session.session import JOB, Session, SessionError


def _until(cond, what: str, timeout: float = 120.0) -> None:
    deadline = time.monotonic() + timeout
    while not cond():
        if time.monotonic() > deadline:
            raise AssertionError(f"timed out waiting for {what}")
        time.sleep(0.01)


@pytest.fixture
def rig(tmp_path: Path):
    robot = SimRobot(config=SimConfig(time_scale=4.0))
    robot.connect()
    session = Session(tmp_path / "session", autosave=False)
    mapping = MappingJob(session, robot.capture, MapperPerceiver(GROUND_TRUTH_LABEL, ground_truth_bundle_for))
    look = LookJob(session, robot, mapping)
    try:
        yield robot, session, mapping, look
    finally:
        look.stop()
        look.wait(30)
        robot.close()


def test_headings_cover_the_circle_from_where_the_robot_faces() -> None:
    h = headings_around(math.pi / 2, 6)
    assert len(h) == 6 and h[0] == pytest.approx(math.pi / 2)
    assert [round(math.degrees(a)) % 360 for a in h] == [90, 150, 210, 270, 330, 30]
    with pytest.raises(SessionError, match="headings: must be a whole number within 2..36"):
        headings_around(0.0, 1)


def test_look_around_maps_more_than_one_capture_with_progress_per_heading(rig) -> None:
    robot, session, mapping, look = rig
    messages: list[str] = []
    session.subscribe(lambda t, p: messages.append(f"{p.name}: {p.message}") if t == JOB else None)
    assert mapping.run()  # one capture from the start pose, facing the line of boxes
    one = len(session.scene.objects)
    look.look_around(6)
    with pytest.raises(SessionError, match="a look is already running"):
        look.look_around(6)
    assert look.wait(300)
    assert session.job.message.startswith("done: 6 headings captured"), session.job
    assert len(look.last_mapped) == 6
    assert len(session.scene.objects) > one, (one, len(session.scene.objects))
    for i, deg in enumerate((90, 150, 210, 270, 330, 30)):  # every heading said it turned, then mapped
        assert f"Look around: heading {i + 1}/6 ({deg}°): turning" in messages
        assert f"Look around: heading {i + 1}/6 ({deg}°): capturing and mapping" in messages
    assert robot.latest_state().yaw == pytest.approx(math.radians(30), abs=1e-3)  # the last heading
    assert robot.latest_state().position == pytest.approx((2.5, 0.7, 0.0), abs=1e-6)  # turned in place


def test_pause_holds_the_robot_and_resume_finishes_the_look(rig) -> None:
    robot, session, mapping, look = rig
    look.look_around(4)
    _until(lambda: "heading 2/4" in session.job.message and "turning" in session.job.message, "the second turn")
    look.pause()
    _until(lambda: "paused at heading" in session.job.message, "the pause")
    yaw = robot.latest_state().yaw
    time.sleep(0.3)
    assert robot.latest_state().yaw == pytest.approx(yaw, abs=1e-9)  # held: not turning
    assert look.paused and look.running
    look.resume()
    assert look.wait(300)
    assert session.job.message.startswith("done: 4 headings captured"), session.job
    assert len(look.last_mapped) == 4


def test_look_at_faces_the_point_and_captures_and_refusals_say_why(rig) -> None:
    robot, session, mapping, look = rig
    yaw = look.look_at((4.5, 0.7, 0.0))  # straight along +x from (2.5, 0.7)
    assert yaw == pytest.approx(0.0)
    assert look.wait(120)
    assert robot.latest_state().yaw == pytest.approx(0.0, abs=1e-3)
    assert session.job.name == "Look at (4.50, 0.70)" and session.job.message.startswith("done: 1 heading captured")
    assert session.capture is not None and session.capture.camera_pose.rotation.as_matrix()[:, 2] == pytest.approx(
        (1.0, 0.0, 0.0), abs=1e-3)
    with pytest.raises(SessionError, match="right at the robot"):
        look.look_at((2.5, 0.7))
    with pytest.raises(SessionError, match="must be finite numbers"):
        look.look_at((float("nan"), 1.0))
