"""Planning grid: oriented boxes -> occupied cells, margin -> dangerous cells, layer costs."""

from __future__ import annotations

import math

import numpy as np
import pytest

from pipeline.scene import SceneObject
from planner.grid import CellState, Closed, CostWeights, GridError, Workspace, build_grid


def _box(x, y, w, h, l, yaw=0.0, oid="b"):
    return SceneObject(oid, "cardboard_box", (x, y, h / 2), (w, h, l), yaw=yaw)


def test_default_workspace_is_the_papers_room() -> None:
    ws = Workspace()
    assert ws.shape == (20, 32, 12)
    assert ws.cell_of((0.1, 0.1, 0.1)) == (0, 0, 0)
    assert ws.cell_of((5.0, 8.0, 3.0)) == (19, 31, 11)
    assert ws.cell_of((5.1, 1, 1)) is None


def test_axis_aligned_box_marks_exact_cells() -> None:
    ws = Workspace(resolution=0.25)
    # box spans x 1.0..2.0 (l along x), y 3.0..3.5, z 0..0.75 -> 4 x 2 x 3 cells
    g = build_grid([_box(1.5, 3.25, 0.5, 0.75, 1.0)], ws, margin=0.0)
    # away from the workspace's edge (its top: the robot's 0.45 m height even for a point robot)
    occ = np.argwhere((g.state == CellState.OCCUPIED) & (g.reason != Closed.EDGE))
    assert len(occ) == 4 * 2 * 3
    assert occ[:, 0].min() == 4 and occ[:, 0].max() == 7
    assert occ[:, 1].min() == 12 and occ[:, 1].max() == 13
    assert occ[:, 2].max() == 2
    assert g.owner_of(tuple(occ[0])) == "b"


def test_yaw_rotates_the_footprint() -> None:
    ws = Workspace(resolution=0.1)
    long_x = build_grid([_box(2.5, 4.0, 0.2, 0.5, 2.0, yaw=0.0)], ws, margin=0.0)
    long_y = build_grid([_box(2.5, 4.0, 0.2, 0.5, 2.0, yaw=math.pi / 2)], ws, margin=0.0)
    ex = np.argwhere(long_x.state[:, :, 0] == CellState.OCCUPIED)
    ey = np.argwhere(long_y.state[:, :, 0] == CellState.OCCUPIED)
    assert np.ptp(ex[:, 0]) > 5 * np.ptp(ex[:, 1])
    assert np.ptp(ey[:, 1]) > 5 * np.ptp(ey[:, 0])
    diag = build_grid([_box(2.5, 4.0, 0.2, 0.5, 2.0, yaw=math.pi / 4)], ws, margin=0.0)
    ed = np.argwhere(diag.state[:, :, 0] == CellState.OCCUPIED)
    # cells along the diagonal: x and y spread equally
    assert abs(np.ptp(ed[:, 0]) - np.ptp(ed[:, 1])) <= 1


def test_radius_closes_a_shell_and_the_danger_band_lies_beyond() -> None:
    # the robot's radius is a hard limit (configuration space), the danger band beyond it a cost;
    # until the known-space rules this shell was only "dangerous" (passable): a robot of radius 0.3 m
    # could be routed 0.125 m from the box
    ws = Workspace(resolution=0.25)
    g = build_grid([_box(2.5, 4.0, 0.5, 0.5, 0.5)], ws, margin=0.3, danger_band=0.25)
    occ = (g.state == CellState.OCCUPIED) & (g.reason != Closed.EDGE)  # the box is 2 m from any edge
    assert int((g.reason == Closed.OBJECT).sum()) == 2 * 2 * 2
    # the box spans cells i 9..10, j 15..16, k 0..1; every cell centre within 0.3 m is closed:
    # 4 x 4 on the floor (walking cylinder), on the box's layer and on the layer above (0.125 m up)
    assert occ.sum() == 3 * 16
    assert int((g.reason == Closed.CLEARANCE).sum()) == 3 * 16 - 8
    assert g.state_at((12, 15, 0)) is CellState.DANGEROUS  # 0.375 m from the box: beyond the radius
    assert g.state_at((13, 15, 0)) is CellState.FREE  # 0.625 m: beyond radius + band
    assert g.state_at((11, 15, 0)) is CellState.OCCUPIED and g.reason_at((11, 15, 0)) is Closed.CLEARANCE


def test_counts_and_costs() -> None:
    ws = Workspace(resolution=0.5)
    g = build_grid([_box(2.5, 4.0, 1.0, 1.0, 1.0)], ws, margin=0.5)
    w = CostWeights(ground=1.0, takeoff=10.0, flight=3.0, danger=4.0, forbid_low_danger=False)
    c = g.cost(w)
    assert sum(g.counts().values()) == np.prod(ws.shape)
    free = g.state == CellState.FREE
    assert np.all(c[:, :, 0][free[:, :, 0]] == 1.0)
    assert np.all(c[:, :, 1][free[:, :, 1]] == 10.0)
    assert np.all(c[:, :, 2:][free[:, :, 2:]] == 3.0)
    dan = g.state == CellState.DANGEROUS
    assert np.all(c[:, :, 0][dan[:, :, 0]] == 4.0)
    assert np.all(np.isinf(c[g.state == CellState.OCCUPIED]))
    c2 = g.cost(CostWeights(forbid_low_danger=True))
    assert np.all(np.isinf(c2[:, :, 1][dan[:, :, 1]]))


def test_empty_scene_is_free_but_for_the_robots_size_from_the_edge() -> None:
    # space outside the workspace is closed: the robot (0.35 m radius, 0.45 m high) keeps its size
    # from the walls x = 0 / 5, y = 0 / 8 and, flying, from the top z = 3 (cell centres 0.125 m in:
    # closed; 0.375 m in: open)
    g = build_grid([], Workspace())
    assert g.counts()["free"] == 18 * 30 * 10  # 18 x 30 columns: the floor and air layers 1..9
    assert np.all(g.reason[g.state == CellState.OCCUPIED] == Closed.EDGE)
    assert np.all(g.edge == (g.state == CellState.OCCUPIED))
    assert g.state_at((0, 5, 0)) is CellState.OCCUPIED and g.state_at((1, 5, 0)) is CellState.FREE
    assert g.state_at((19, 5, 4)) is CellState.OCCUPIED and g.state_at((18, 5, 4)) is CellState.FREE
    assert g.state_at((5, 0, 4)) is CellState.OCCUPIED and g.state_at((5, 31, 0)) is CellState.OCCUPIED
    # the top: centre 2.625 m is 0.375 m below 3 m, less than the 0.45 m height; 2.375 m is clear
    assert g.state_at((5, 5, 10)) is CellState.OCCUPIED and g.state_at((5, 5, 9)) is CellState.FREE
    # a point robot keeps nothing from the walls (its height still from the top)
    p = build_grid([], Workspace(), margin=0.0)
    assert p.state_at((0, 0, 0)) is CellState.FREE and p.state_at((0, 0, 9)) is CellState.FREE


@pytest.mark.parametrize("kw", [dict(resolution=0.0), dict(max=(0.0, 8.0, 3.0)), dict(resolution=float("nan")),
                                dict(resolution=6.5)])
def test_bad_workspace(kw) -> None:
    with pytest.raises(GridError):
        Workspace(**kw)


def test_object_in_camera_frame_rejected() -> None:
    o = SceneObject("c", "chair", (0, 0, 2), (0.5, 0.9, 0.5), frame="camera")
    with pytest.raises(GridError, match="world"):
        build_grid([o], Workspace())
