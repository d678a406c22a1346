"""The flying robot planned with its whole height (``RobotModel.flying_height``): a sphere round its origin and
the 0.45 m body above it; the default robot keeps the sphere alone."""

from __future__ import annotations

import numpy as np
import pytest

from pipeline.scene import SceneObject
from planner.flight_body import body_gap, flight_dilate, flight_gaps
from planner.grid import CellState, Closed, Workspace, build_grid
from planner.robot_model import MORPHOGEAR, RobotModel
from planner.route import Route

WS = Workspace((0.0, 0.0, 0.0), (5.0, 5.0, 3.0), 0.25)
HOVER = (2.625, 2.625, 1.125)  # a flight cell's centre (layer 4)
FLY = RobotModel(flying_height=0.45)  # the simulator's body height above the origin


def _shelf(underside_above: float, x: float = HOVER[0]) -> SceneObject:
    """A 1 x 1 m board 0.1 m thick whose underside is ``underside_above`` [m] above the hover cell's centre."""
    bottom = HOVER[2] + underside_above
    return SceneObject("shelf-1", "shelf", (x, HOVER[1], bottom + 0.05), (1.0, 0.1, 1.0))


@pytest.mark.parametrize("above, closed", [(0.40, True), (0.50, False)])
def test_an_object_above_a_hover_cell_closes_it_within_the_bodys_height(above: float, closed: bool) -> None:
    grid = build_grid([_shelf(above)], WS, robot=FLY)
    cell = WS.cell_of(HOVER)
    assert (grid.state_at(cell) is CellState.OCCUPIED) is closed
    if closed:  # 0.40 m is beyond the 0.35 m flying radius: only the body's height reaches it
        assert grid.reason_at(cell) == Closed.CLEARANCE and grid.owner_of(cell) == "shelf-1"
        assert body_gap(_shelf(above), HOVER, FLY) == 0.0
        assert [o.id for o in grid.objects_at(HOVER)] == ["shelf-1"]
        res = Route(grid, (0.5, 0.5, 0.0)).plan((0.5, 0.5, 0.0), HOVER)
        assert not res.ok and "shelf 'shelf-1'" in res.message and "0.45 m body above that cell" in res.message
    else:
        assert body_gap(_shelf(above), HOVER, FLY) == pytest.approx(0.05)


def test_the_body_is_round_below_and_as_wide_as_the_flying_radius_above() -> None:
    # below the cell the sphere: a board 0.30 m under the centre closes it, 0.40 m does not
    for below, closed in ((0.30, True), (0.40, False)):
        top = HOVER[2] - below
        board = SceneObject("b", "box", (HOVER[0], HOVER[1], top - 0.05), (1.0, 0.1, 1.0))
        assert (build_grid([board], WS, robot=FLY).state_at(WS.cell_of(HOVER)) is CellState.OCCUPIED) is closed
    # beside and above: the shelf's edge 0.30 m away in plan closes it, 0.45 m does not
    for edge, closed in ((0.30, True), (0.45, False)):
        grid = build_grid([_shelf(0.40, x=HOVER[0] + 0.5 + edge)], WS, robot=FLY)
        assert (grid.state_at(WS.cell_of(HOVER)) is CellState.OCCUPIED) is closed


def test_obstacle_cells_close_the_cells_whose_body_reaches_them() -> None:
    mask = np.zeros(WS.shape, dtype=bool)
    i, j, k = WS.cell_of(HOVER)
    mask[i, j, k + 2] = True  # an unlabelled surface cell 2 layers up: its cube from 0.375 m above the centre
    near = flight_dilate(mask, FLY, WS.resolution)
    assert near[i, j, k] and near[i, j, k + 1] and near[i, j, k + 2]
    assert not near[i, j, k - 1]  # 0.625 m below it: neither the sphere nor the body reaches
    mask[:] = False
    mask[i, j, k + 3] = True  # from 0.625 m above: beyond the 0.45 m body
    assert not flight_dilate(mask, FLY, WS.resolution)[i, j, k]
    mask[:] = False
    mask[i, j, k - 2] = True  # 0.375 m below the centre: beyond the 0.35 m sphere
    assert not flight_dilate(mask, FLY, WS.resolution)[i, j, k]
    assert flight_dilate(mask, FLY, WS.resolution)[i, j, k - 1]


def test_gaps_agree_with_the_one_point_gap_and_reach() -> None:
    shelf = _shelf(0.60)
    g = flight_gaps([shelf], WS.axes(), FLY, 0.25)
    i, j, k = WS.cell_of(HOVER)
    assert g[i, j, k] == pytest.approx(body_gap(shelf, HOVER, FLY)) == pytest.approx(0.15)
    assert np.isinf(g[i, j, 0])  # beyond the reach
    with pytest.raises(ValueError, match="pads"):
        flight_gaps([shelf], WS.axes(), FLY, 0.25, pads=[0.1, 0.2])


def test_the_hovering_robots_own_cells_hold_its_whole_body() -> None:
    ws = Workspace((0.0, 0.0, 0.0), (3.0, 3.0, 3.0), 0.1)
    grid = build_grid([], ws, robot=FLY)
    own = grid.own_cells((1.55, 1.55, 1.05))
    i, j, k = ws.cell_of((1.55, 1.55, 1.05))
    assert own[i, j, k + 4] and not own[i, j, k + 5]  # 0.40 m above: the body; 0.50 m: beyond its 0.45 m
    assert own[i, j, k - 3] and not own[i, j, k - 4]  # below: the 0.35 m sphere
    assert own[i + 3, j, k + 4] and not own[i + 4, j, k + 4]  # as wide as the flying radius


def test_the_default_robot_flies_as_the_sphere_alone() -> None:
    assert MORPHOGEAR.flying_height == 0.0
    assert build_grid([_shelf(0.40)], WS).state_at(WS.cell_of(HOVER)) is not CellState.OCCUPIED
    assert body_gap(_shelf(0.40), HOVER, MORPHOGEAR) == pytest.approx(0.05)
