"""A walking robot follows the ground under its body (the simulator's contact rule): it steps down off
the sports mat it landed on, up onto a low ledge, and walks into the side of a taller box ("contact
ahead"). Manual clock: every wait is on the robot's state, bounded in simulated time."""

from __future__ import annotations

import math

import pytest

from console.link.base import Mode, RunStatus
from console.link.sim import SimConfig, SimRobot
from console.link.sim_contact import STEP_UP, BodyContact
from console.link.world import paper_room
from pipeline.camera.geometry import Pose
from pipeline.scene import Scene, SceneObject
from planner.mission import MissionSegment, SegmentKind

MAT = SceneObject("m", "sports_mat", (0.8, 7.3, 0.025), (1.0, 0.05, 1.0), 0.0, "world")  # paper's room
ON_MAT = (0.38, 7.38)  # where the operator's robot landed on the mat
FAST = dict(spool_time=0.1, settle_time=0.1, descent_rate=0.8)


def step_until(robot: SimRobot, done, limit: float = 60.0) -> None:
    t0 = robot.sim_time
    while not done() and robot.sim_time - t0 < limit:
        robot.step(0.02)
    assert done(), f"not reached in {limit} s of simulated time: {robot.latest_state()}"


def robot_in(world: Scene | None, at: tuple[float, float, float]) -> SimRobot:
    robot = SimRobot(world=world or paper_room(), start=Pose.from_xyz_yaw(*at, yaw=math.pi / 2),
                     config=SimConfig(**FAST), manual_clock=True)
    robot.connect()
    return robot


def walk(robot: SimRobot, *to: tuple[float, float]) -> object:
    x, y, _ = robot.latest_state().position
    run = robot.run_segment(MissionSegment(SegmentKind.WALK, ((x, y, 0.0),) + tuple((a, b, 0.0) for a, b in to)))
    step_until(robot, lambda: run.done)
    return run


def box(height: float, at: tuple[float, float] = (1.0, 2.0)) -> SceneObject:
    return SceneObject("b", "box", (at[0], at[1], height / 2), (0.4, height, 0.4), 0.0, "world")


def test_ground_under_the_footprint_steps_down_any_drop_and_up_a_low_ledge_only() -> None:
    body = BodyContact([MAT, box(0.3)], radius=0.25, height=0.45)
    assert body.ground_under((0.38, 7.38, 0.05), 0.0) == pytest.approx(0.05)  # on the mat
    assert body.ground_under((0.1, 7.38, 0.05), 0.0) == pytest.approx(0.05)  # centre off, a foot still on
    assert body.ground_under((0.0, 7.38, 0.05), 0.0) == 0.0  # footprint off the mat: steps down
    assert body.ground_under((0.1, 7.38, 0.0), 0.0) == pytest.approx(0.05)  # from the floor: steps up
    assert body.ground_under((1.0, 1.6, 0.0), 0.0) == 0.0  # 0.3 m box: not climbed (contact ahead)
    assert body.ground_under((1.0, 1.6, 0.25), 0.0) == pytest.approx(0.3)  # within STEP_UP of its top
    assert STEP_UP == pytest.approx(0.10)


def test_a_robot_landed_on_the_mat_walks_off_it_to_the_floor() -> None:
    robot = robot_in(None, (*ON_MAT, 0.62))
    try:
        x, y, z = robot.latest_state().position
        down = robot.run_segment(MissionSegment(SegmentKind.LAND, ((x, y, z), (x, y, 0.0))))
        step_until(robot, lambda: down.done and not robot.latest_state().armed)
        assert down.status is RunStatus.DONE and robot.latest_state().position[2] == pytest.approx(0.05)
        run = walk(robot, (0.38, 6.2))  # south off the mat's edge (y = 6.8) onto the floor
        assert run.status is RunStatus.DONE, run.error
        st = robot.latest_state()
        assert st.position == pytest.approx((0.38, 6.2, 0.0)) and st.landed and st.mode is Mode.IDLE
        assert not any("contact" in m for _, m in st.messages)
        back = walk(robot, ON_MAT)  # and back up the 0.05 m ledge onto it
        assert back.status is RunStatus.DONE, back.error
        st = robot.latest_state()
        assert st.position == pytest.approx((*ON_MAT, 0.05)) and st.landed
    finally:
        robot.close()


@pytest.mark.parametrize("height, stands_at", [(0.08, 0.08), (0.3, None)])
def test_a_walk_steps_onto_a_low_box_and_stops_at_a_taller_one(height: float, stands_at: float | None) -> None:
    robot = robot_in(Scene(objects=(box(height),)), (1.0, 0.8, 0.0))
    try:
        run = walk(robot, (1.0, 2.0))
        st = robot.latest_state()
        if stands_at is not None:
            assert run.status is RunStatus.DONE, run.error
            assert st.position == pytest.approx((1.0, 2.0, stands_at)) and st.landed
        else:  # the body touches the box's side 0.25 m before its face at y = 1.8
            assert run.status is RunStatus.FAILED
            assert run.error == "walking stopped: contact with an unmapped obstacle ahead at (1.00, 1.80, 0.23)"
            assert st.position[1] == pytest.approx(1.55, abs=0.03) and st.position[2] == 0.0 and st.landed
    finally:
        robot.close()
