"""Land here during a search, the rule itself (console/session/search_landing.py) on small known spaces: the
nearest landing spot is seen free under the whole footprint; Land here is on over unseen floor when such a
spot exists and off with both reasons when none does; the mission flies there over seen space and lands."""

from __future__ import annotations

import math

import numpy as np

from pipeline.camera.geometry import Pose
from pipeline.scene import Scene
from planner.grid import Workspace
from planner.route import Route

from console.session.known_space_state import empty_known, grid_for
from console.session.operator_state import unseen_floor, vehicle_commands
from console.session.search_landing import land_elsewhere_mission, land_elsewhere_state, nearest_landing_spots
from console.session.session_types import RobotSnapshot, RunStatus

WS = Workspace((0.0, 0.0, 0.0), (5.0, 8.0, 3.0))
MARGIN = 0.35


def _robot(x: float, y: float, z: float) -> RobotSnapshot:
    return RobotSnapshot(pose=Pose.from_xyz_yaw(x, y, z, 0.0), mode="holding", armed=True, battery=0.9, landed=False)


def _known(*free_boxes: tuple[tuple[float, float, float], tuple[float, float, float]]):
    """All unknown, except the cells whose centres lie in one of ``free_boxes`` (seen free)."""
    k = empty_known(WS)
    idx = np.argwhere(np.ones(k.shape, dtype=bool))
    c = k.centers(idx)
    free = np.zeros(k.shape, dtype=bool)
    for lo, hi in free_boxes:
        inside = np.all((c >= np.asarray(lo)) & (c <= np.asarray(hi)), axis=1)
        free[tuple(idx[inside].T)] = True
    return k.updated(free, np.zeros(k.shape, dtype=bool))


def test_nearest_spot_is_seen_free_under_the_whole_footprint_and_land_here_flies_there() -> None:
    # the near part of the room seen free floor to ceiling, the far part only above 1 m (as from the air)
    known = _known(((0.0, 0.0, 0.0), (5.0, 3.0, 3.0)), ((0.0, 0.0, 1.0), (5.0, 8.0, 3.0)))
    grid = grid_for(Scene(), WS, MARGIN, known, "closed")
    robot = _robot(2.5, 5.0, 1.5)  # hovering over floor no capture saw
    assert unseen_floor(robot.pose.translation, grid)
    spots = nearest_landing_spots(grid, robot.pose.translation)
    assert spots and all(not unseen_floor(p, grid) for p in spots)
    assert spots[0][1] < 3.0 and math.dist(spots[0][:2], (2.5, 5.0)) < 3.0, spots[0]  # just short of the unseen floor
    before = vehicle_commands(robot, RunStatus(), WS, (2.5, 0.7, 0.0), grid)
    assert not before["land"].enabled and "has not been seen" in before["land"].reason  # outside a search: off
    after = land_elsewhere_state(before, robot, RunStatus(), WS, (2.5, 0.7, 0.0), grid)
    assert after["land"].enabled and after["hold"] == before["hold"]  # during a search: on
    mission = land_elsewhere_mission(robot, grid, Route(grid, (2.5, 5.0, 1.5)), WS, "land-test")
    assert mission is not None and "land" in mission.kinds()
    end = mission.segments[-1].waypoints[-1]
    assert end[2] == WS.floor and not unseen_floor(end, grid), end


def test_no_seen_free_floor_keeps_land_here_off_with_both_reasons() -> None:
    grid = grid_for(Scene(), WS, MARGIN, _known(((0.0, 0.0, 1.0), (5.0, 8.0, 3.0))), "closed")  # only air seen
    robot = _robot(2.5, 4.0, 1.5)
    assert nearest_landing_spots(grid, robot.pose.translation) == []
    before = vehicle_commands(robot, RunStatus(), WS, (2.5, 0.7, 0.0), grid)
    after = land_elsewhere_state(before, robot, RunStatus(), WS, (2.5, 0.7, 0.0), grid)
    assert not after["land"].enabled
    assert "has not been seen" in after["land"].reason and "no floor was seen free to land on instead" in after["land"].reason


def test_over_seen_floor_land_here_is_the_usual_straight_down() -> None:
    grid = grid_for(Scene(), WS, MARGIN, _known(((0.0, 0.0, 0.0), (5.0, 8.0, 3.0))), "closed")
    robot = _robot(2.5, 4.0, 1.5)
    assert land_elsewhere_mission(robot, grid, Route(grid, (2.5, 4.0, 1.5)), WS, "land-test") is None
