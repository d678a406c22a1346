"""TURN segments (yaw in place) on the simulated robot, through the mission manager, and over MAVLink."""

from __future__ import annotations

import math
import time
from dataclasses import replace
from typing import Iterator

import pytest

from console.link.base import Mode, RobotState, RunStatus
from console.link.manager import MissionManager, MissionStatus
from console.link.manager_resume import segment_parts
from console.link.mavlink import GroundMotion, MavlinkConfig, MavlinkLink
from console.link.ned import NedFrame
from console.link.sim import SimConfig, SimRobot
from console.link.world import DEFAULT_START
from mav_emulator import ArduCopterEmulator
from planner.mission import Mission, MissionSegment, SegmentKind, turn_segment

WALK, TAKEOFF, LAND, TURN = SegmentKind.WALK, SegmentKind.TAKEOFF, SegmentKind.LAND, SegmentKind.TURN


def _manual() -> SimRobot:
    robot = SimRobot(start=DEFAULT_START, config=SimConfig(spool_time=0.2, settle_time=0.1), manual_clock=True)
    robot.connect()
    return robot


def _until_done(robot: SimRobot, run, limit: float = 30.0) -> float:
    t0 = robot.sim_time
    while not run.done and robot.sim_time - t0 < limit:
        robot.step(0.01)
    return robot.sim_time - t0


def test_sim_turns_in_place_on_the_ground_at_its_yaw_rate() -> None:
    robot = _manual()
    here = robot.latest_state().position
    seen: list[RobotState] = []
    robot.subscribe(seen.append)
    run = robot.run_segment(turn_segment(here, 0.0))  # from +y (pi/2) to +x: 90 degrees clockwise
    took = _until_done(robot, run)
    assert run.status is RunStatus.DONE, run.error
    assert took == pytest.approx(math.radians(90) / robot.config.yaw_rate, abs=0.03)
    st = robot.latest_state()
    assert st.yaw == pytest.approx(0.0, abs=1e-6) and st.position == pytest.approx(here) and st.landed
    assert any(s.mode is Mode.WALKING for s in seen)  # turning is ground motion
    # the camera looks the new way
    assert robot.capture().camera_pose.rotation.as_matrix()[:, 2] == pytest.approx((1.0, 0.0, 0.0), abs=1e-6)


def test_sim_turns_while_hovering_and_a_turn_elsewhere_is_refused() -> None:
    robot = _manual()
    x, y, _ = robot.latest_state().position
    _until_done(robot, robot.run_segment(MissionSegment(TAKEOFF, ((x, y, 0.0), (x, y, 1.5)))))
    run = robot.run_segment(turn_segment((x, y, 1.5), -math.pi / 2))
    _until_done(robot, run)
    st = robot.latest_state()
    assert run.status is RunStatus.DONE and st.yaw == pytest.approx(-math.pi / 2, abs=1e-6)
    assert st.position == pytest.approx((x, y, 1.5), abs=1e-6) and not st.landed
    far = robot.run_segment(turn_segment((x + 2.0, y, 1.5), 0.0))
    assert far.status is RunStatus.FAILED and "turn segment starts at" in far.error


def test_manager_runs_a_turn_between_walks_and_resume_turns_where_the_robot_is() -> None:
    robot = SimRobot(config=SimConfig(time_scale=8.0, walk_speed=1.0))
    robot.connect()
    manager = MissionManager(robot)
    try:
        mission = Mission((MissionSegment(WALK, ((2.5, 0.7, 0.0), (2.5, 1.2, 0.0))),
                           turn_segment((2.5, 1.2, 0.0), math.pi),
                           MissionSegment(WALK, ((2.5, 1.2, 0.0), (2.0, 1.2, 0.0)))))
        manager.start(mission)
        assert manager.wait(60.0) is MissionStatus.DONE, [e.message for e in manager.events]
        assert robot.latest_state().position == pytest.approx((2.0, 1.2, 0.0), abs=0.02)
        assert "segment 2/3: turn" in [e.message for e in manager.events]
    finally:
        manager.close()
        robot.close()
    st = RobotState(time=0.0, position=(2.6, 1.25, 0.0), yaw=0.0, velocity=(0, 0, 0), mode=Mode.IDLE,
                    armed=False, landed=True, battery=1.0, link_ok=True, link_age=0.0, health="ok")
    parts = segment_parts(turn_segment((2.5, 1.2, 0.0), 1.0), st, 0.0, None, True, 0.6)
    assert len(parts) == 1 and parts[0][1] and parts[0][0].kind is TURN
    assert parts[0][0].start == (2.6, 1.25, 0.0) and parts[0][0].yaw == pytest.approx(1.0)


ORIGIN = (2.5, 0.7, 0.0)
CFG = MavlinkConfig(ned=NedFrame(origin=ORIGIN), ack_timeout=0.25, retries=4, heartbeat_timeout=1.0,
                    setpoint_rate=10.0, fly_speed=4.0, climb_rate=3.0, descent_rate=3.0, timeout_slack=5.0,
                    ground=GroundMotion(speed=2.0))


@pytest.fixture
def vehicle() -> Iterator[tuple[MavlinkLink, ArduCopterEmulator]]:
    link = MavlinkLink("udpin:127.0.0.1:0", CFG)
    link.open()
    emu = ArduCopterEmulator(link.local_port)
    emu.start()
    try:
        link.connect(timeout=20.0)
        deadline = time.monotonic() + 30.0
        while (link.latest_state() is None or link.latest_state().health != "ok") and time.monotonic() < deadline:
            time.sleep(0.02)
        yield link, emu
    finally:
        link.close()
        emu.stop()


def test_mavlink_turn_sends_the_yaw_in_a_position_target_at_the_robot(vehicle) -> None:
    link, emu = vehicle
    manager = MissionManager(link, failsafe_after=1.5, failsafe_hold=0.5)
    modes: list[Mode] = []
    link.subscribe(lambda st: modes.append(st.mode))
    try:
        here = link.latest_state().position
        manager.start(Mission((turn_segment((here[0], here[1], 0.0), 0.0),)))  # face world +x = east
        assert manager.wait(60.0) is MissionStatus.DONE, [e.message for e in manager.events]
        deadline = time.monotonic() + 30.0
        while abs(link.latest_state().yaw) > math.radians(5) and time.monotonic() < deadline:
            time.sleep(0.02)
        assert link.latest_state().yaw == pytest.approx(0.0, abs=math.radians(5))
        # ArduPilot: yaw clockwise from north; world +x is east = pi/2 in NED; the target holds the robot's place
        assert emu.yaw == pytest.approx(math.pi / 2, abs=1e-4)
        x, y, z, mask = emu.record.targets[-1]
        assert (x, y, z) == pytest.approx((here[1] - ORIGIN[1], here[0] - ORIGIN[0], 0.0), abs=0.05)
        from console.link.mavlink import POSITION_YAW_MASK
        assert mask == POSITION_YAW_MASK
        assert Mode.WALKING in modes  # the state stream says the landed robot turns as ground motion
    finally:
        manager.close()
