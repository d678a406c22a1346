"""Search viewpoints: gain by ray casting in the known space (occlusion, floor worth more than
ceiling), cost by the planner's own costs (walking cheaper than flying), field-named errors."""

from __future__ import annotations

import math

import numpy as np
import pytest

from pipeline.mapping.known_space import KnownSpace
from pipeline.scene import Scene, SceneObject
from planner.grid import Workspace, build_grid
from planner.route import Route
from planner.search_viewpoints import (
    OCCUPIED, UNKNOWN, SearchViewpointError, cells_in_view, path_costs, score_viewpoints, view_gain,
)

WS = Workspace((0.0, 0.0, 0.0), (5.0, 8.0, 3.0), 0.25)


def _known(free: np.ndarray, occupied: np.ndarray | None = None) -> KnownSpace:
    k = KnownSpace.empty(WS.min, WS.max, WS.resolution)
    return k.updated(free, np.zeros(WS.shape, bool) if occupied is None else occupied)


def _front_seen() -> KnownSpace:
    """Everything in front of y = 4 m seen free; behind it unknown."""
    free = np.zeros(WS.shape, bool)
    free[:, :16, :] = True
    return _known(free)


def test_gain_looks_towards_unknown_space_and_stops_at_occupied_cells() -> None:
    known = _front_seen()
    grid = build_grid(Scene(), WS, 0.35, known=known)
    st = known.state()
    eye = np.array([[2.5, 3.0, 0.35]])
    blocking = st == OCCUPIED
    gain, yaw, _ = view_gain(st, blocking, grid, eye, 0.6)
    assert gain[0] > 1.0
    assert math.degrees(yaw[0]) % 360 == pytest.approx(90.0, abs=15.0)  # faces the unknown half (+y)
    # a wall of occupied cells at y = 4.0 .. 4.25 m, full height: nothing behind it counts
    wall = np.zeros(WS.shape, bool)
    wall[:, 16, :] = True
    walled = st.copy()
    walled[wall] = OCCUPIED
    g2, _, _ = view_gain(walled, wall, grid, eye, 0.6)
    assert g2[0] < 0.05 * gain[0], (g2, gain)


def test_unknown_floor_counts_more_than_unknown_ceiling() -> None:
    st = np.full(WS.shape, 1, np.uint8)
    grid = build_grid(Scene(), WS, 0.35)
    eye = np.array([[2.5, 2.0, 1.5]])  # level camera at 1.5 m: as much below as above in view
    low, high = st.copy(), st.copy()
    low[:, 20:, :4] = UNKNOWN   # up to 1 m
    high[:, 20:, 8:] = UNKNOWN  # 2 .. 3 m
    none = np.zeros(WS.shape, bool)
    g_low, _, _ = view_gain(low, none, grid, eye, 0.6)
    g_high, _, _ = view_gain(high, none, grid, eye, 0.6)
    assert g_low[0] > 3 * g_high[0] > 0


def test_viewpoints_walk_when_walking_sees_it_and_costs_are_the_planners() -> None:
    known = _front_seen()
    grid = build_grid(Scene(), WS, 0.35, known=known)
    start = (2.5, 0.7, 0.0)
    route = Route(grid, start)
    cost = route.cost_array
    cell = WS.cell_of(start)
    d = path_costs(grid, cost, cell)
    assert d[cell] == 0.0
    # walking 1 m costs 1 per metre on the ground layer, flying is dearer
    one = WS.cell_of((2.5, 1.7, 0.0))
    assert d[one] == pytest.approx(1.0, abs=0.01)
    air = WS.cell_of((2.5, 0.7, 1.6))
    assert d[air] > 5.0
    vps = score_viewpoints(known.state(), grid, cost, cell, 0.4, limit=3)  # its time: bench/search.py
    assert vps and vps[0].mode == "walk" and vps[0].goal[1] > 2.5  # walks up to the frontier
    assert math.sin(vps[0].yaw) > 0.5  # faces into the unknown half (+y), straight or across it
    assert "m³ of unknown space" in vps[0].why and "path cost" in vps[0].why
    assert [v.score for v in vps] == sorted((v.score for v in vps), reverse=True)


def test_cells_looked_at_count_no_more() -> None:
    known = _front_seen()
    grid = build_grid(Scene(), WS, 0.35, known=known)
    st = known.state()
    eye = (2.5, 3.5, 0.35)
    seen = cells_in_view(st, grid, eye, math.pi / 2, 0.4)
    assert seen.any() and not (seen & (st != UNKNOWN)).any()
    g0, _, _ = view_gain(st, st == OCCUPIED, grid, np.array([eye]), 0.4)
    g1, _, _ = view_gain(st, st == OCCUPIED, grid, np.array([eye]), 0.4, looked=seen)
    assert g1[0] < 0.5 * g0[0]


def test_bad_inputs_name_the_field() -> None:
    grid = build_grid(Scene(), WS, 0.35)
    cost = Route(grid, (2.5, 0.7, 0.0)).cost_array
    with pytest.raises(SearchViewpointError, match="state: must have the grid's shape"):
        score_viewpoints(np.zeros((3, 3, 3), np.uint8), grid, cost, (10, 2, 0), 0.4)
    with pytest.raises(SearchViewpointError, match="target_height: must be finite"):
        score_viewpoints(np.zeros(WS.shape, np.uint8), grid, cost, (10, 2, 0), float("nan"))
    with pytest.raises(SearchViewpointError, match="start_cell: must be a cell"):
        path_costs(grid, cost, (99, 0, 0))


def test_a_box_hides_the_floor_behind_it() -> None:
    box = SceneObject("b", "cardboard_box", (2.5, 4.0, 0.6), (2.0, 1.2, 0.4))
    free = np.zeros(WS.shape, bool)
    free[:, :15, :] = True
    known = _known(free)
    grid = build_grid(Scene(objects=(box,)), WS, 0.35, known=known)
    st = known.state()
    from planner.search_viewpoints import blocking_cells

    b = blocking_cells(st, grid)
    assert b[WS.cell_of((2.5, 4.0, 0.6))]
    low = np.array([[2.5, 3.0, 0.35]])  # behind the box, at its height: little of the floor beyond
    g_low, _, _ = view_gain(st, b, grid, low, 0.4)
    g_open, _, _ = view_gain(st, st == OCCUPIED, grid, low, 0.4)
    assert g_low[0] < g_open[0]


def test_confirm_viewpoint_sees_the_target_past_a_wall_and_not_from_where_it_was_confirmed() -> None:
    from planner.search_viewpoints import confirm_viewpoint

    dog = SceneObject("robot_dog-1", "robot_dog", (2.5, 6.0, 0.2), (0.28, 0.4, 0.645))
    wall = np.zeros(WS.shape, bool)
    wall[6:14, 16, :] = True  # x 1.5 .. 3.5 m at y 4.0 .. 4.25 m, floor to ceiling
    free = ~wall
    known = _known(free, wall)
    grid = build_grid(Scene(objects=(dog,)), WS, 0.35, known=known)
    start = (2.5, 1.0, 0.0)
    cost = Route(grid, start).cost_array
    vp = confirm_viewpoint(known.state(), grid, cost, WS.cell_of(start), dog, avoid=[start])
    assert vp is not None
    assert math.hypot(vp.eye[0] - 2.5, vp.eye[1] - 1.0) > 0.5  # not where the missed confirmation was taken
    d = math.dist(vp.eye, dog.position)
    assert 0.5 <= d <= 5.0
    assert abs(math.remainder(vp.yaw - math.atan2(6.0 - vp.eye[1], 2.5 - vp.eye[0]), math.tau)) < 1e-6  # faces it
    for f in np.linspace(0.0, 1.0, 200):  # the line of sight passes the wall
        x = vp.eye[0] + f * (2.5 - vp.eye[0])
        y = vp.eye[1] + f * (6.0 - vp.eye[1])
        assert not (1.5 <= x <= 3.5 and 4.0 <= y <= 4.25), (vp.why, x, y)
    # every reachable spot within 0.5 m .. excluded: none left
    assert confirm_viewpoint(known.state(), grid, cost, WS.cell_of(start), dog, avoid=[start], away=20.0) is None
