"""The critical-battery landing in the paper's room (Session + SimRobot + mission manager + vehicle
commands, wired like the console): a robot hovering over the sports mat lands ON it; a landing that
stops on a surface too small to stand on is not resumed silently and the empty battery brings the robot
down and disarmed; Return is off at critical charge with the reason. Every wait is on state."""

from __future__ import annotations

import math
import time
from pathlib import Path
from typing import Any, Callable

import pytest

from console.link.sim import SimConfig, SimRobot
from console.link.world import paper_room
from console.session import button_rules
from console.session import operator_state as rules
from console.session.session import RobotSnapshot, RunStatus, Session
from console.session.session_types import robot_snapshot
from console.session.vehicle_commands import VehicleCommands
from console.views.mission_view import make_runner
from pipeline.camera.geometry import Pose
from pipeline.scene import Scene
from planner.grid import Workspace

OVER_MAT = (0.38, 7.38, 0.62)  # the operator's robot: over sports_mat-1 (top 0.05 m) when the battery went critical
OVER_DOG = (2.5, 6.3, 1.2)  # over the robot dog: a top 0.28 m wide, too small to stand on
FAST = dict(walk_speed=0.8, fly_speed=1.2, climb_rate=1.0, descent_rate=1.0, spool_time=0.3, settle_time=0.2)


def wait_for(predicate: Callable[[], Any], timeout: float = 90.0, what: str = "") -> None:
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        if predicate():
            return
        time.sleep(0.02)
    assert predicate(), f"timed out waiting for {what or predicate}"


class Stack:
    """The console's stack on the simulator in the paper's room, the robot hovering at ``at``."""

    def __init__(self, folder: Path, at: tuple[float, float, float], config: SimConfig) -> None:
        self.robot = SimRobot(world=paper_room(), start=Pose.from_xyz_yaw(*at, yaw=math.pi / 2), config=config)
        self.session = Session(folder, start=(at[0], at[1], 0.0), autosave=False)
        self.session.spawn(Scene())
        self.notices: list[Any] = []
        self.session.subscribe(lambda t, p: self.notices.append(p) if t == "notice" else None)
        self.unsubscribe = self.robot.subscribe(lambda st: self.session.set_robot(robot_snapshot(st)))
        self.robot.connect()
        self.runner = make_runner(self.robot, self.session, failsafe_after=3.0, failsafe_hold=5.0)
        self.commands = VehicleCommands(self.session, self.robot, self.runner)
        wait_for(lambda: self.session.robot is not None, what="first state")

    def bodies(self) -> list[str]:
        return [f"{n.title}: {n.body}" for n in list(self.notices)]

    def messages(self) -> list[str]:
        return [m for _, m in self.robot.latest_state().messages]

    def on_the_ground(self) -> bool:
        st = self.robot.latest_state()
        return st.landed and not st.armed

    def close(self) -> None:
        self.runner.close()
        self.unsubscribe()
        self.robot.close()


@pytest.fixture
def stacks(tmp_path: Path):
    made: list[Stack] = []

    def make(at: tuple[float, float, float], **cfg: float) -> Stack:
        made.append(Stack(tmp_path / f"s{len(made)}", at, SimConfig(time_scale=3.0, **{**FAST, **cfg})))
        return made[-1]

    yield make
    for s in made:
        s.close()


def test_the_consoles_critical_landing_over_the_mat_touches_down_on_it(stacks) -> None:
    st = stacks(OVER_MAT, battery_critical=0.0)  # the vehicle's own failsafe off: the console's Land here acts
    st.robot.set_battery(0.09)
    wait_for(lambda: any("land here: landing at (0.38, 7.38)" in b for b in st.bodies()), what="the console lands")
    wait_for(lambda: st.on_the_ground() and not st.session.run.active, what="landed and disarmed")
    assert st.robot.latest_state().position == pytest.approx((0.38, 7.38, 0.05), abs=1e-6)  # ON the mat
    assert st.session.run.state == "done", st.session.run
    assert not any("contact" in t for t in st.bodies() + st.messages()), st.bodies() + st.messages()
    from console.views.robot_view import status_text
    assert "battery 9% CRITICAL: on the ground" in status_text(st.session.robot, "sim")


def test_the_vehicles_own_critical_failsafe_lands_on_the_mat(stacks) -> None:
    st = stacks(OVER_MAT)  # the simulator's battery failsafe at 10 %
    st.robot.set_battery(0.09)
    wait_for(st.on_the_ground, what="landed by itself")
    assert st.robot.latest_state().position[2] == pytest.approx(0.05)
    assert "CRITICAL: battery critical: landing" in st.messages()
    assert not any("contact" in m for m in st.messages())


def test_a_critical_landing_onto_a_top_too_small_is_not_resumed_and_the_empty_battery_lands(stacks) -> None:
    st = stacks(OVER_DOG, battery_critical=0.0, drain_fly=0.0)
    st.robot.set_battery(0.09)
    wait_for(lambda: st.session.run.state == "paused" and "contact below" in st.session.run.message,
             what="the console's landing stopped on the dog's top")
    assert "too small to stand on" in st.session.run.message
    view = st.session.operator_state()
    assert view.resume_blocker is not None and "Resume would repeat the same descent" in view.resume_blocker
    assert not st.robot.latest_state().landed
    st.robot.set_battery(0.0)  # nothing left: the vehicle comes down whatever the console wanted
    wait_for(lambda: st.on_the_ground() and not st.session.run.active, what="down, disarmed, the run ended")
    assert "CRITICAL: battery empty: coming down where it is, motors off on touchdown" in st.messages()
    assert st.session.run.state == "aborted"
    refused = st.session.operator_state().commands["return"]
    assert not refused.enabled  # no Return from the ground at 0 %


def _hover(battery: float) -> RobotSnapshot:
    return RobotSnapshot(Pose.from_xyz_yaw(*OVER_MAT), mode="holding", armed=True, landed=False, battery=battery)


def test_return_is_off_at_critical_charge_with_the_reason() -> None:
    launch, ws, idle = (4.62, 1.88, 0.0), Workspace(), RunStatus()
    assert button_rules.return_home(_hover(0.30), idle, ws, launch).enabled
    state = button_rules.return_home(_hover(0.0), idle, ws, launch)
    assert not state.enabled and state.reason == ("battery 0 %: critical (below 10 %), the robot must land here, "
                                                  "not fly back")
    text = button_rules.hover_text("return", "Return", state, launch)
    assert text == ("Return: lands at the take-off spot (4.62, 1.88) · Return is off: battery 0 %: critical "
                    "(below 10 %), the robot must land here, not fly back")
    assert rules.battery_level(_hover(0.0)) == "critical"
