"""A vertical descent onto an object's top face touches down on it (the simulator's contact rule), and
the battery failsafes bring the robot down: critical lands, empty comes down and disarms whatever was
commanded. Manual clock: every wait is on the robot's state, bounded in simulated time."""

from __future__ import annotations

import math

import pytest

from console.link.base import Mode, RunStatus
from console.link.sim import SimConfig, SimRobot
from console.link.sim_contact import BodyContact
from console.link.world import paper_room
from pipeline.camera.geometry import Pose
from pipeline.scene import SceneObject
from planner.mission import MissionSegment, SegmentKind

MAT = SceneObject("m", "sports_mat", (0.8, 7.3, 0.025), (1.0, 0.05, 1.0), 0.0, "world")  # paper's room
OVER_MAT = (0.38, 7.38, 0.62)  # where the operator's robot hovered when the battery went critical
DOG_TOP = 0.40  # the robot dog (2.5, 6.3), 0.28 x 0.645 m in plan: too small to stand on
FAST = dict(spool_time=0.1, settle_time=0.1, descent_rate=0.8)


def hovering(at: tuple[float, float, float], **cfg: float) -> SimRobot:
    robot = SimRobot(world=paper_room(), start=Pose.from_xyz_yaw(*at, yaw=math.pi / 2),
                     config=SimConfig(**{**FAST, **cfg}), manual_clock=True)
    robot.connect()
    assert not robot.latest_state().landed and robot.latest_state().armed
    return robot


def step_until(robot: SimRobot, done, limit: float = 60.0) -> None:
    t0 = robot.sim_time
    while not done() and robot.sim_time - t0 < limit:
        robot.step(0.02)
    assert done(), f"not reached in {limit} s of simulated time: {robot.latest_state()}"


def land(robot: SimRobot) -> object:
    x, y, z = robot.latest_state().position
    run = robot.run_segment(MissionSegment(SegmentKind.LAND, ((x, y, z), (x, y, 0.0))))
    step_until(robot, lambda: run.done)
    return run


def messages(robot: SimRobot) -> list[str]:
    return [m for _, m in robot.latest_state().messages]


def test_top_face_geometry_stands_on_a_wide_face_only() -> None:
    body = BodyContact([MAT], radius=0.25, height=0.45)
    td = body.top_below(OVER_MAT, 0.0)
    assert td is not None and td.height == pytest.approx(0.05) and td.why == ""
    assert td.point == pytest.approx((0.38, 7.38, 0.05))
    assert body.top_below((0.38, 7.38, 0.04), 0.0) is None  # below the top already: not a face under it
    assert body.top_below((2.0, 7.38, 0.6), 0.0) is None  # nothing under the body
    edge = body.top_below((0.2, 7.3, 0.6), 0.0)  # the centre 0.1 m beyond the mat's edge
    assert edge is not None and "beyond the edge" in edge.why
    narrow = BodyContact([SceneObject("d", "robot_dog", (2.5, 6.3, 0.2), (0.28, 0.40, 0.645), 0.0, "world")],
                         radius=0.25, height=0.45)
    small = narrow.top_below((2.5, 6.3, 1.0), 0.0)
    assert small is not None and small.height == pytest.approx(DOG_TOP)
    assert small.why == "the surface under the robot is too small to stand on (0.28 m wide)"


def test_a_landing_over_the_sports_mat_touches_down_on_it_and_takes_off_again() -> None:
    robot = hovering(OVER_MAT)
    try:
        run = land(robot)
        assert run.status is RunStatus.DONE, run.error
        step_until(robot, lambda: not robot.latest_state().armed)
        st = robot.latest_state()
        assert st.landed and st.position == pytest.approx((0.38, 7.38, 0.05)) and st.mode is Mode.IDLE
        assert not any("contact" in m for m in messages(robot))
        up = robot.run_segment(MissionSegment(SegmentKind.TAKEOFF, ((0.38, 7.38, 0.0), (0.38, 7.38, 0.8))))
        step_until(robot, lambda: up.done)
        assert up.status is RunStatus.DONE and not robot.latest_state().landed
    finally:
        robot.close()


def test_a_landing_onto_a_top_too_small_stops_on_it_and_says_why() -> None:
    robot = hovering((2.5, 6.3, 1.2))
    try:
        run = land(robot)
        assert run.status is RunStatus.FAILED
        assert run.error == ("landing stopped: contact below at (2.50, 6.30, 0.40): the surface under the robot "
                             "is too small to stand on (0.28 m wide)")
        st = robot.latest_state()
        assert not st.landed and st.armed and st.position[2] == pytest.approx(DOG_TOP)
    finally:
        robot.close()


def test_the_critical_failsafe_lands_on_the_mat_by_itself() -> None:
    robot = hovering(OVER_MAT)
    try:
        robot.set_battery(0.09)
        step_until(robot, lambda: robot.latest_state().landed and not robot.latest_state().armed)
        assert robot.latest_state().position[2] == pytest.approx(0.05)
        assert "CRITICAL: battery critical: landing" in messages(robot)
    finally:
        robot.close()


def test_an_empty_battery_comes_down_and_disarms_whatever_was_commanded() -> None:
    robot = hovering((2.5, 6.3, 1.2), drain_fly=0.0)
    try:
        robot.set_battery(0.09)  # the critical failsafe's landing stops on the dog's top: said, not retried
        step_until(robot, lambda: any("failsafe landing stopped: contact below" in m for m in messages(robot)))
        st = robot.latest_state()
        assert not st.landed and st.mode is Mode.HOLDING and st.position[2] == pytest.approx(DOG_TOP)
        robot.set_battery(0.0)
        robot.step(0.02)
        assert robot.latest_state().mode is Mode.FAILSAFE
        assert "CRITICAL: battery empty: coming down where it is, motors off on touchdown" in messages(robot)
        robot.hold()  # the operator's Hold does not stop it
        fly = robot.run_segment(MissionSegment(SegmentKind.FLY, ((2.5, 6.3, DOG_TOP), (2.5, 5.0, 1.0))))
        assert fly.status is RunStatus.FAILED and "battery empty (0 %): the robot cannot move" in (fly.error or "")
        step_until(robot, lambda: robot.latest_state().landed and not robot.latest_state().armed)
        assert robot.latest_state().position[2] == pytest.approx(DOG_TOP)  # resting on it, disarmed
        assert any("came down on a surface it cannot stand on" in m for m in messages(robot))
        up = robot.run_segment(MissionSegment(SegmentKind.TAKEOFF, ((2.5, 6.3, 0.0), (2.5, 6.3, 1.0))))
        assert up.status is RunStatus.FAILED and "battery empty (0 %)" in (up.error or "")
    finally:
        robot.close()


def test_an_empty_battery_in_the_air_ends_the_running_segment() -> None:
    robot = hovering((2.5, 5.0, 1.2))
    try:
        fly = robot.run_segment(MissionSegment(SegmentKind.FLY, ((2.5, 5.0, 1.2), (2.5, 4.0, 1.2))))
        robot.step(0.1)
        robot.set_battery(0.0)
        step_until(robot, lambda: fly.done)
        assert fly.status is RunStatus.FAILED and "battery empty" in (fly.error or "")
        step_until(robot, lambda: robot.latest_state().landed and not robot.latest_state().armed)
        assert robot.latest_state().position[2] == pytest.approx(0.0)
    finally:
        robot.close()
