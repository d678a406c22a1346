"""Battery rules (console.session.operator_state, the session, the simulator's own failsafe).

Below 25 % Execute is off with the reason and every tab is warned once per crossing; below 10 % a
running mission is ended and the robot lands where it is (Land here); the simulated robot lands by
itself at critical charge with no console; an unknown charge never blocks. Live tests run the real
stack (session fed by the simulator's state stream, mission manager, vehicle commands) and wait on
state, never on time.
"""

from __future__ import annotations

import time
from pathlib import Path
from typing import Any, Callable

import pytest

from console.session import operator_state as rules
from console.link.base import Mode
from console.link.sim import SimConfig, SimRobot
from console.views.mission_view import make_runner
from console.session.session import RobotSnapshot, RunStatus, Session
from console.session.session_types import robot_snapshot
from console.session.vehicle_commands import VehicleCommands
from pipeline.camera.geometry import Pose
from pipeline.scene import Scene

START = (2.5, 0.7, 0.0)
FAST = dict(walk_speed=0.8, fly_speed=1.2, climb_rate=1.0, descent_rate=1.0, spool_time=0.3, settle_time=0.2)


def wait_for(predicate: Callable[[], Any], timeout: float = 90.0, what: str = "") -> None:
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        if predicate():
            return
        time.sleep(0.02)
    assert predicate(), f"timed out waiting for {what or predicate}"


class Stack:
    """Session + simulated robot + mission manager + vehicle commands, wired like the console."""

    def __init__(self, folder: Path, config: SimConfig) -> None:
        self.robot = SimRobot(world=Scene(), config=config, room=None)
        self.session = Session(folder, start=START, autosave=False)
        self.session.spawn(Scene())
        self.notices: list[Any] = []
        self.session.subscribe(lambda t, p: self.notices.append(p) if t == "notice" else None)
        self.unsubscribe = self.robot.subscribe(lambda st: self.session.set_robot(robot_snapshot(st)))
        self.robot.connect()
        self.runner = make_runner(self.robot, self.session, failsafe_after=3.0, failsafe_hold=5.0)
        self.commands = VehicleCommands(self.session, self.robot, self.runner)

    def battery_notices(self) -> list[Any]:
        return [n for n in list(self.notices) if n.title.startswith("Battery")]

    def close(self) -> None:
        self.runner.close()
        self.unsubscribe()
        self.robot.close()


def _hover(battery: float | None, mode: str = "holding") -> RobotSnapshot:
    return RobotSnapshot(Pose.from_xyz_yaw(2.5, 2.0, 1.2), mode=mode, armed=True, landed=False, battery=battery)


# --- the rule ---------------------------------------------------------------------------------------
def test_thresholds_and_unknown_charge() -> None:
    assert rules.BATTERY_LOW == 0.25 and rules.BATTERY_CRITICAL == 0.10
    assert rules.battery_blocker(_hover(0.18)) == "battery 18 %: below 25 %, land or Return"
    assert "critical" in (rules.battery_blocker(_hover(0.05)) or "")
    assert rules.battery_blocker(_hover(0.30)) is None
    assert rules.battery_blocker(_hover(None)) is None  # unknown never blocks
    assert rules.battery_level(_hover(float("nan"))) == "ok"


def test_battery_none_does_not_block_execute(tmp_path: Path) -> None:
    s = Session(tmp_path / "s", start=START, autosave=False)
    s.spawn(Scene())
    s.set_robot(RobotSnapshot(Pose.from_xyz_yaw(*START), mode="idle", armed=False, landed=True, battery=None))
    assert s.add_goal((2.5, 2.5, 0.0)).ok
    s.register()
    s.build_mission()
    assert s.operator_state().execute_blocker is None
    s.set_robot(RobotSnapshot(Pose.from_xyz_yaw(*START), mode="idle", armed=False, landed=True, battery=0.18))
    assert s.operator_state().execute_blocker == "battery 18 %: below 25 %, land or Return"
    assert rules.battery_action(_hover(None), RunStatus(), s.workspace) is None
    assert rules.battery_action(_hover(0.05), RunStatus(), s.workspace) == "land"
    assert rules.battery_action(_hover(0.05, mode="failsafe"), RunStatus(), s.workspace) is None  # its own failsafe
    on_floor = RobotSnapshot(Pose.from_xyz_yaw(*START), mode="idle", armed=False, landed=True, battery=0.05)
    assert rules.battery_action(on_floor, RunStatus(), s.workspace) is None
    assert rules.battery_action(on_floor, RunStatus(state="paused"), s.workspace) == "end"


def test_low_battery_refuses_return_from_the_ground_but_not_in_the_air(tmp_path: Path) -> None:
    s = Session(tmp_path / "s", start=START, autosave=False)
    s.spawn(Scene())
    launch = (2.5, 0.7, 0.0)
    ground = RobotSnapshot(Pose.from_xyz_yaw(2.5, 2.5, 0.0), mode="idle", armed=True, landed=True, battery=0.18)
    ret = rules.vehicle_commands(ground, RunStatus(), s.workspace, launch)["return"]
    assert not ret.enabled and ret.reason == "battery 18 %: below 25 %, land or Return"
    air = rules.vehicle_commands(_hover(0.18), RunStatus(), s.workspace, launch)
    assert air["return"].enabled and air["land"].enabled  # in the air the operator can always bring it down


def test_one_warning_per_crossing(tmp_path: Path) -> None:
    s = Session(tmp_path / "s", start=START, autosave=False)
    s.spawn(Scene())
    seen: list[Any] = []
    s.subscribe(lambda t, p: seen.append(p) if t == "notice" else None)

    def feed(b: float) -> None:
        s.set_robot(RobotSnapshot(Pose.from_xyz_yaw(*START), mode="idle", armed=False, landed=True, battery=b))

    def warnings() -> list[str]:
        return [n.title for n in seen if n.title.startswith("Battery")]

    for b in (0.40, 0.30, 0.26):
        feed(b)
    assert warnings() == []
    for b in (0.24, 0.22, 0.249, 0.251, 0.24, 0.20):  # noise around the threshold: one warning
        feed(b)
    assert warnings() == ["Battery low"]
    assert "below 25 %" in seen[-1].body
    feed(0.09)
    feed(0.08)
    assert warnings() == ["Battery low", "Battery critical"]
    feed(0.90)  # a new battery re-arms the warning
    feed(0.20)
    assert warnings() == ["Battery low", "Battery critical", "Battery low"]


# --- live ----------------------------------------------------------------------------------------
def test_sim_lands_by_itself_at_critical_charge_without_a_console() -> None:
    robot = SimRobot(world=Scene(), config=SimConfig(**FAST), room=None, manual_clock=True)
    from planner.mission import MissionSegment, SegmentKind

    robot.connect()
    try:
        run = robot.run_segment(MissionSegment(SegmentKind.TAKEOFF, ((2.5, 0.7, 0.0), (2.5, 0.7, 1.2))))
        for _ in range(2000):
            if run.done:
                break
            robot.step(0.02)
        assert not robot.latest_state().landed
        robot.set_battery(0.30)
        robot.step(0.02)
        assert not robot.latest_state().landed and robot.latest_state().mode is Mode.HOLDING
        robot.set_battery(0.09)
        robot.step(0.02)
        st = robot.latest_state()
        assert st.mode is Mode.FAILSAFE
        assert any("battery critical: landing" in m for _, m in st.messages)
        for _ in range(5000):
            if robot.latest_state().landed and not robot.latest_state().armed:
                break
            robot.step(0.02)
        st = robot.latest_state()
        assert st.landed and not st.armed and st.position[2] == pytest.approx(0.0)
        assert st.position[:2] == pytest.approx((2.5, 0.7))
    finally:
        robot.close()


def test_sim_config_rejects_a_bad_critical_level() -> None:
    with pytest.raises(ValueError, match="battery_critical"):
        SimConfig(battery_critical=1.5)


def test_critical_charge_ends_a_running_mission_and_lands(tmp_path: Path) -> None:
    # the robot's own failsafe off: the console's rule must bring it down
    st = Stack(tmp_path / "s", SimConfig(time_scale=3.0, battery_critical=0.0, **FAST))
    try:
        wait_for(lambda: st.session.robot is not None, what="first state")
        for g in ((2.5, 3.5, 1.2), (2.5, 6.5, 1.2)):
            assert st.session.add_goal(g).ok
            st.session.register()
        mission = st.session.build_mission()
        assert st.session.operator_state().execute_blocker is None
        st.runner.execute(mission)
        wait_for(lambda: not st.robot.latest_state().landed and st.session.run.state == "running",
                 what="the mission flying")
        st.robot.set_battery(0.20)
        wait_for(lambda: [n.title for n in st.battery_notices()] == ["Battery low"], what="low warning")
        assert st.session.run.state == "running"  # low: a running mission goes on
        st.robot.set_battery(0.08)
        wait_for(lambda: st.session.run.state in ("aborted", "done", "failed") or
                 st.session.operator_state().running == "Land here", what="the mission ended")
        wait_for(lambda: st.robot.latest_state().landed and st.session.run.state == "done"
                 and not st.session.run.active, what="landed")
        state = st.robot.latest_state()
        assert state.position[2] == pytest.approx(0.0)
        titles = [n.title for n in st.battery_notices()]
        assert titles.count("Battery low") == 1 and titles.count("Battery critical") >= 1
        assert any("land here: landing at" in n.body for n in st.battery_notices())  # the Land here path
        assert st.robot.latest_state().battery == pytest.approx(0.08, abs=0.01)
    finally:
        st.close()


def test_robot_panel_says_low_and_critical() -> None:
    from console.views.robot_view import status_text

    assert "battery 50%" in status_text(_hover(0.5), "sim") and "CRITICAL" not in status_text(_hover(0.5), "sim")
    assert "battery 18% low: land or Return" in status_text(_hover(0.18), "sim")
    assert "battery 8% CRITICAL: landing" in status_text(_hover(0.08), "sim")
    assert "battery ?" in status_text(_hover(None), "sim")


def test_the_vehicles_own_failsafe_lands_and_the_console_does_not_interfere(tmp_path: Path) -> None:
    st = Stack(tmp_path / "s", SimConfig(time_scale=3.0, **FAST))  # the sim's failsafe at 10 %
    try:
        wait_for(lambda: st.session.robot is not None, what="first state")
        assert st.session.add_goal((2.5, 3.5, 1.2)).ok
        st.session.register()
        st.runner.execute(st.session.build_mission())
        wait_for(lambda: not st.robot.latest_state().landed and st.session.run.state == "running",
                 what="the mission flying")
        st.robot.set_battery(0.08)
        wait_for(lambda: st.robot.latest_state().landed and not st.robot.latest_state().armed
                 and not st.session.run.active, what="landed by itself")
        assert any("battery critical: landing" in m for _, m in st.robot.latest_state().messages)
        assert st.session.run.state == "aborted"  # the manager's paused mission was ended on the ground
        # the console warned but did not fly its own Land here over the vehicle's failsafe
        bodies = [n.body for n in st.battery_notices()]
        assert bodies and not any("land here: landing at" in b for b in bodies), bodies
        assert st.session.operator_state().execute_blocker is not None
    finally:
        st.close()


def test_low_battery_blocks_resuming_the_operators_mission(tmp_path: Path) -> None:
    st = Stack(tmp_path / "s", SimConfig(time_scale=2.0, **FAST))
    try:
        wait_for(lambda: st.session.robot is not None, what="first state")
        assert st.session.add_goal((2.5, 6.5, 0.0)).ok
        st.session.register()
        st.runner.execute(st.session.build_mission())
        wait_for(lambda: st.session.run.state == "running", what="the walk running")
        st.runner.pause()
        wait_for(lambda: st.session.run.state == "paused", what="paused")
        assert st.session.operator_state().resume_blocker is None
        st.robot.set_battery(0.20)
        wait_for(lambda: st.session.operator_state().resume_blocker == "battery 20 %: below 25 %, land or Return",
                 what="Resume off at low battery")
    finally:
        st.close()
