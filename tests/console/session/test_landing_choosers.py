"""Every way the console chooses where to land keeps the robot's whole footprint off a 5 cm sports mat
beside the natural spot, mapped or not (an unmapped mat the simulator's exact depth saw is an unlabelled
obstacle): Land here straight down (and the critical-battery landing), Land here during a search (the
nearest seen-free floor), a planned route's landing (a mission's goal, Go look, the search's move) and
Return. One rule decides: :func:`planner.landing_spot.landing_problem`."""

from __future__ import annotations

import math
import time
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from console.link.base import Mode, RobotState
from console.session.session import Session, SessionError
from console.session.session_types import robot_snapshot
from pipeline.camera.geometry import CameraMount, Intrinsics, Pose, camera_pose_in_world
from pipeline.mapping.known_space_update import box_depth
from pipeline.scene import Scene, SceneObject
from planner.cspace import box_distance
from planner.landing_spot import landing_problem

START = (2.5, 1.0, 0.0)
MAT = SceneObject("sports_mat-1", "sports_mat", (2.5, 4.0, 0.025), (1.0, 0.05, 1.0), 0.0)  # x 2.0-3.0, y 3.5-4.5
BESIDE = (3.12, 4.0, 1.0)  # hovering 0.12 m beside the mat's edge: its footprint reaches onto the mat
OVER = (2.5, 4.0, 1.0)  # hovering over the mat's middle
INTR = Intrinsics(320.0, 320.0, 320.0, 240.0, 640, 480)


def _state(p: tuple[float, float, float], flying: bool) -> Any:
    mode = Mode.HOLDING if flying else Mode.IDLE
    return robot_snapshot(RobotState(time=time.time(), position=p, mode=mode, landed=not flying, armed=flying))


def _session(tmp_path: Path, mapped: bool) -> Session:
    """The robot stood at START and captured facing +y (exact depth): the floor ahead and the mat seen; the
    mat mapped (``mapped``) or only in the depth (an unlabelled obstacle)."""
    s = Session(tmp_path / "s", start=START, autosave=False)
    s.spawn(Scene(objects=(MAT,) if mapped else ()), origin="test", replaces=[MAT.id] if not mapped else ())
    s.set_robot(_state(START, False))
    robot = Pose.from_xyz_yaw(*START, math.pi / 2)
    camera = camera_pose_in_world(robot, CameraMount())
    s.observe_capture("0001", box_depth([MAT], INTR, camera), INTR, camera, robot, exact=True)
    assert s.grid.rule == "closed"
    if not mapped:
        assert s.grid.unlabelled > 0 and not s.scene.objects
    return s


def _off_the_mat(spot: Any, s: Session) -> None:
    """The landing spot is fit by the one rule and the robot's footprint (its radius) clears the mat."""
    assert landing_problem(s.grid, spot) is None, landing_problem(s.grid, spot)
    gap = float(box_distance(MAT, np.array([[spot[0], spot[1], 0.0]]), horizontal=True)[0])
    assert gap > s.grid.robot.radius, (spot, gap)


@pytest.mark.parametrize("mapped", [True, False], ids=["mapped mat", "unmapped mat"])
def test_land_here_straight_down_is_refused_beside_the_mat_even_forced(tmp_path: Path, mapped: bool) -> None:
    s = _session(tmp_path, mapped)
    s.set_robot(_state(BESIDE, True))
    land = s.operator_state().commands["land"]
    assert land.shown and not land.enabled
    assert land.reason.startswith("cannot land here: ") and "below the robot at (3.12, 4.00)" in land.reason, land.reason
    if mapped:
        assert "sports_mat-1" in land.reason
    with pytest.raises(SessionError):
        s.land_mission()
    # critical battery: not on the mat either, but on the nearest spot the rule fits (before the vehicle's own
    # failsafe would land where it hovers)
    m = s.land_mission(forced=True)
    assert m.kinds()[-1] == "land"
    _off_the_mat(m.segments[-1].end, s)
    assert math.dist(m.segments[-1].end[:2], BESIDE[:2]) < 1.5


@pytest.mark.parametrize("mapped", [True, False], ids=["mapped mat", "unmapped mat"])
def test_land_here_during_a_search_lands_on_the_nearest_spot_off_the_mat(tmp_path: Path, mapped: bool) -> None:
    s = _session(tmp_path, mapped)
    s.set_land_nearest(True)
    s.set_robot(_state(OVER, True))
    assert s.operator_state().commands["land"].enabled
    m = s.land_mission()
    assert m.kinds()[-1] == "land"
    _off_the_mat(m.segments[-1].end, s)
    assert math.dist(m.segments[-1].end[:2], OVER[:2]) < 1.5  # the nearest fit spot, not somewhere far


@pytest.mark.parametrize("mapped", [True, False], ids=["mapped mat", "unmapped mat"])
def test_a_planned_route_and_return_land_off_the_mat(tmp_path: Path, mapped: bool) -> None:
    s = _session(tmp_path, mapped)
    s.set_robot(_state(OVER, True))
    res = s.add_goal((3.62, 4.0, 0.0))  # a floor goal 0.62 m beside the mat (a mission's goal, Go look, a search move)
    assert res.ok, res.message
    s.register()
    m = s.build_mission()
    lands = [seg for seg in m.segments if seg.kind.value == "land"]
    assert lands, m.kinds()
    for seg in lands:
        _off_the_mat(seg.end, s)
    home = s.return_mission()  # Return from over the mat to the launch spot
    for seg in home.segments:
        if seg.kind.value == "land":
            _off_the_mat(seg.end, s)
