"""The next look towards a goal not seen yet (planner/goal_look.py): the level camera's floor rule,
occlusion, hover spots, the chain's cells to open, never a repeat, why a goal stayed hidden."""

from __future__ import annotations

import math

import numpy as np
import pytest

from pipeline.mapping.known_space import KnownSpace
from pipeline.scene import SceneObject
from planner.goal_look import (GoalLookError, in_view, known_state, line_of_sight, needed_cells, next_look,
                               hidden_by)
from planner.grid import Workspace, build_grid
from planner.robot_model import MORPHOGEAR
from planner.route import Route

WS = Workspace(resolution=0.25)
WALL = SceneObject("wall", "office_cabinet", (2.5, 4.0, 0.6), (0.4, 1.2, 5.0))  # 1.2 m high, wall to wall at y = 4
GOAL = (2.5, 5.0, 0.0)


def _known(free: np.ndarray) -> KnownSpace:
    ks = KnownSpace.empty(WS.min, WS.max, WS.resolution)
    return ks.updated(free, np.zeros_like(free))


def _first_capture() -> np.ndarray:
    """What one level capture from the start shows: the room in front of the wall, and the air over and
    behind it from 1.5 m up (the floor behind it stays unknown)."""
    _, ys, zs = WS.axes()
    free = np.zeros(WS.shape, bool)
    free[:, ys < 3.75, :] = True
    free[:, :, zs > 1.5] = True
    return free


def test_a_level_camera_sees_the_floor_only_beyond_its_height_over_tan_half_vfov() -> None:
    h = 1.2
    eye = np.array([[0.0, 0.0, h]])
    edge = h / math.tan(0.92 * MORPHOGEAR.camera_half_vfov)  # the counted share of the half field of view
    pts = np.array([[0.0, edge - 0.1, 0.0], [0.0, edge + 0.1, 0.0], [2.0, edge + 0.1, 0.0]])
    seen = in_view(eye, np.array([math.pi / 2]), pts, MORPHOGEAR.camera_half_vfov)[0]
    assert seen.tolist() == [False, True, False]  # too close below; in view; outside the 62° width


def test_needed_cells_are_the_goal_column_up_to_the_landing_height_and_unknown_only() -> None:
    st = np.zeros(WS.shape, np.uint8)
    grid = build_grid([], WS, known=_known(np.zeros(WS.shape, bool)))
    cells = needed_cells(grid, st, GOAL)
    pts = WS.centers(cells)
    assert len(cells) > 0 and np.all(np.hypot(pts[:, 0] - 2.5, pts[:, 1] - 5.0) <= 0.35 + 0.25 + 0.125 + 1e-9)
    assert pts[:, 2].max() <= 1.125 + 1e-9 and pts[:, 2].min() == pytest.approx(0.125)
    st[:] = 1
    assert len(needed_cells(grid, st, GOAL)) == 0  # all seen: nothing needed


def test_line_of_sight_stops_at_objects_not_at_unknown_space() -> None:
    grid = build_grid([WALL], WS, known=_known(_first_capture()))
    st = known_state(grid)
    from planner.search_viewpoints import blocking_cells

    blocking = blocking_cells(st, grid)
    cell = np.array([WS.cell_of((2.5, 5.0, 0.1))])
    low = np.array([[2.5, 2.0, 0.35]])  # behind the wall from here
    high = np.array([[2.5, 7.5, 1.0]])  # behind the goal: only unknown space between
    assert not line_of_sight(grid, blocking, low, cell)[0, 0]
    assert line_of_sight(grid, blocking, high, cell)[0, 0]


def test_after_one_capture_the_next_look_opens_space_and_never_repeats() -> None:
    grid = build_grid([WALL], WS, known=_known(_first_capture()))
    route = Route(grid, (2.5, 1.0, 0.0))
    res = route.propose(GOAL)
    assert not res.ok and "not seen yet" in res.message and "Go look" in res.message
    look = route.look_for(GOAL)
    assert look is not None and look.needed > 0
    assert math.isfinite(route.cost_array[WS.cell_of(look.goal)])  # reachable now
    assert look.eye[2] == pytest.approx(look.goal[2] + MORPHOGEAR.camera_height)  # the camera rides on the robot
    # from in front of the wall no floor cell of the goal shows: at most its upper column, over the wall
    assert look.sees < 0.5 and (look.sees > 0 or look.gain > 0)
    assert look.mode == "fly" and look.eye[1] < 4.5
    # never the same spot and heading twice
    again = route.look_for(GOAL, avoid=[(look.eye, look.yaw)])
    assert again is not None
    turned = abs((again.yaw - look.yaw + math.pi) % (2 * math.pi) - math.pi)
    assert math.dist(again.eye, look.eye) > 0.75 or turned > math.radians(45)


def test_when_the_low_air_behind_the_goal_is_seen_a_low_hover_behind_it_sees_the_floor() -> None:
    _, ys, zs = WS.axes()
    f2 = _first_capture()
    f2[:, ys > 6.4, 2:] = True  # the air behind the goal from 0.5 m up, seen by an earlier look
    f2[:, ys > 4.5, 5:] = True  # and over the wall down to 1.25 m
    grid = build_grid([WALL], WS, known=_known(f2))
    route = Route(grid, (2.5, 1.0, 0.0))
    look = route.look_for(GOAL)
    assert look is not None and look.sees > 0.3, look
    assert look.mode == "fly" and look.eye[1] > 6.0 and look.eye[2] < 1.6  # behind the goal, low
    towards = math.atan2(GOAL[1] - look.eye[1], GOAL[0] - look.eye[0])
    assert look.yaw < 0 and abs((look.yaw - towards + math.pi) % (2 * math.pi) - math.pi) < 1e-6  # faces the goal
    res = route.propose(GOAL)
    assert "look from (" in res.message and res.viewpoint == pytest.approx(look.eye)


def test_hidden_by_names_the_object_or_the_field_of_view() -> None:
    grid = build_grid([WALL], WS, known=_known(_first_capture()))
    st = known_state(grid)
    assert hidden_by(grid, st, (2.5, 2.5, 0.35), math.pi / 2, GOAL) == "hidden by wall"
    assert hidden_by(grid, st, (2.5, 4.6, 2.2), math.pi / 2, GOAL).startswith("below the camera's view")


def test_bad_targets_are_refused_naming_the_field() -> None:
    grid = build_grid([WALL], WS, known=_known(_first_capture()))
    route = Route(grid, (2.5, 1.0, 0.0))
    with pytest.raises(GoalLookError, match="target"):
        next_look(grid, route.cost_array, WS.cell_of((2.5, 1.0, 0.0)), (float("nan"), 5.0, 0.0))
    with pytest.raises(GoalLookError, match="state"):
        next_look(grid, route.cost_array, WS.cell_of((2.5, 1.0, 0.0)), GOAL, state=np.zeros((2, 2, 2)))


def test_when_every_look_towards_the_goal_was_had_the_edge_of_the_seen_patch_is_looked_at() -> None:
    """A robot that can only walk a small seen patch (no take-off: the air above is unseen), whose looks
    towards the goal and towards the space to open were all had, is offered a look in another heading at
    the edge of the patch (more room for the next look), never a repeat; before, no look at all."""
    xs, ys, zs = WS.axes()
    free = np.zeros(WS.shape, bool)
    free[np.ix_((xs > 2.0) & (xs < 3.0), (ys > 0.25) & (ys < 1.75), zs < 0.5)] = True
    route = Route(build_grid([WALL], WS, known=_known(free)), (2.5, 1.0, 0.0))
    eye = (2.5, 1.0, 0.35)
    avoid = [(eye, math.radians(a)) for a in (58.0, 90.0, 124.0)]
    look = route.look_for(GOAL, avoid=avoid)
    assert look is not None and look.mode == "walk" and look.sees == 0.0 and look.gain > 0
    assert "at the edge of where the robot can go" in look.why
    for pos, yaw in avoid:
        turned = abs((look.yaw - yaw + math.pi) % (2 * math.pi) - math.pi)
        assert math.dist(look.eye, pos) > 0.75 or turned > math.radians(45)
