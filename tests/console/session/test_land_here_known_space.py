"""Land here respects the known space: over floor no capture has seen free the button is off with
the reason and the session refuses; over seen floor, and on a fully known map, it lands; the
critical-battery landing (a forced landing) still lands over unseen floor."""

from __future__ import annotations

import math
import time
from pathlib import Path
from typing import Any

import pytest

from console.link.base import Mode, RobotState
from console.link.world import paper_room
from console.session import operator_state as rules
from console.session.session import Session, SessionError
from console.session.session_types import robot_snapshot
from pipeline.camera.geometry import CameraMount, Intrinsics, Pose, camera_pose_in_world

START = (2.5, 1.0, 0.0)
BEHIND = (2.62, 5.62, 1.5)  # behind the line of boxes, beside the hidden robot dog: never seen
FRONT = (2.5, 1.8, 0.6)  # in front of the line, low: the floor and the air below seen by the capture


def _hover(p: tuple[float, float, float]) -> Any:
    return robot_snapshot(RobotState(time=time.time(), position=p, mode=Mode.HOLDING, landed=False, armed=True))


def _session(tmp_path: Path, capture: bool = True) -> Session:
    s = Session(tmp_path / "s", start=START, autosave=False)
    s.spawn(paper_room(), origin="test")
    s.set_robot(robot_snapshot(RobotState(time=time.time(), position=START, mode=Mode.IDLE, landed=True)))
    if capture:  # one capture from the start, looking +y down the room (the mapped boxes bound the rays)
        robot = Pose.from_xyz_yaw(*START, math.pi / 2)
        camera = camera_pose_in_world(robot, CameraMount())
        intr = Intrinsics(320.0, 320.0, 320.0, 240.0, 640, 480)
        s.observe_capture("0001", None, intr, camera, robot)
    return s


def test_land_here_is_off_over_floor_not_seen(tmp_path: Path) -> None:
    s = _session(tmp_path)
    assert s.grid.rule == "closed"
    assert rules.unseen_floor(BEHIND, s.grid) and not rules.unseen_floor(FRONT, s.grid)
    s.set_robot(_hover(BEHIND))
    land = s.operator_state().commands["land"]
    assert land.shown and not land.enabled
    assert land.reason == ("Land here is off: the floor below (2.62, 5.62) has not been seen: "
                           "look down there first, or Return")
    with pytest.raises(SessionError, match="floor below \\(2.62, 5.62\\) has not been seen"):
        s.land_mission()
    forced = s.land_mission(forced=True)  # the critical-battery landing: a forced landing beats a crash
    assert forced.segments[-1].end[:2] == pytest.approx(BEHIND[:2])


def test_land_here_lands_over_seen_floor(tmp_path: Path) -> None:
    s = _session(tmp_path)
    s.set_robot(_hover(FRONT))
    land = s.operator_state().commands["land"]
    assert land.enabled and land.reason == ""
    m = s.land_mission()
    assert m.segments[-1].end == pytest.approx((FRONT[0], FRONT[1], s.workspace.floor))


def test_unknown_space_allowed_still_keeps_land_here_off_over_unseen_floor(tmp_path: Path) -> None:
    s = _session(tmp_path)
    s.set_plan_unknown(True)
    assert s.grid.rule == "allow"
    s.set_robot(_hover(BEHIND))
    assert "has not been seen" in s.operator_state().commands["land"].reason
    with pytest.raises(SessionError, match="has not been seen"):
        s.land_mission()
    s.set_robot(_hover(FRONT))
    assert s.operator_state().commands["land"].enabled


def test_fully_known_map_lands_anywhere_free(tmp_path: Path) -> None:
    s = _session(tmp_path, capture=False)
    assert s.grid.rule == "fully_known"
    s.set_robot(_hover(BEHIND))
    assert s.operator_state().commands["land"].enabled
    assert s.land_mission().segments[-1].end[:2] == pytest.approx(BEHIND[:2])


class _Runner:
    """Records the missions it is asked to fly."""

    def __init__(self) -> None:
        self.flown: list[tuple[Any, str]] = []

    def execute(self, mission: Any, command: str = "") -> None:
        self.flown.append((mission, command))

    def abort(self) -> None: ...


def test_the_operator_is_refused_but_the_critical_battery_landing_lands_over_unseen_floor(tmp_path: Path) -> None:
    from console.session.vehicle_commands import VehicleCommands

    s = _session(tmp_path)
    runner = _Runner()
    commands = VehicleCommands(s, None, runner)
    s.set_robot(_hover(BEHIND))
    with pytest.raises(SessionError, match="Land here is off: the floor below \\(2.62, 5.62\\) has not been seen"):
        commands.run("land")
    assert runner.flown == []
    commands.battery_land(timeout=1.0)  # no run under way: lands where it is
    assert len(runner.flown) == 1
    mission, label = runner.flown[0]
    assert label == "Land here" and mission.segments[-1].end[:2] == pytest.approx(BEHIND[:2])


def test_a_landing_is_not_added_on_floor_not_seen(tmp_path: Path) -> None:
    s = _session(tmp_path)
    s.set_plan_unknown(True)  # the flight may cross unseen space; its landing may not end on unseen floor
    assert s.add_goal(BEHIND).ok
    s.register()
    assert s.build_mission().kinds()[-1] == "fly"
    with pytest.raises(SessionError, match="cannot land below the last goal: the floor below .* has not been seen"):
        s.add_landing()
