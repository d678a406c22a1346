"""Robot-sized configuration space and known-space planning policy: gaps, unknown space, viewpoints,
unseen metres, floating objects, unlabelled obstacles, snapped goals, the robot's own cells."""

from __future__ import annotations

import math

import numpy as np
import pytest

from pipeline.mapping.known_space import KnownSpace
from pipeline.scene import SceneObject
from planner.grid import CellState, Closed, GridError, Workspace, build_grid
from planner.robot_model import MORPHOGEAR, RobotModel, RobotModelError
from planner.route import Route

WS = Workspace(resolution=0.25)


def _box(oid, x, y, size=(0.45, 0.4, 0.45), z0=0.0, yaw=0.0):
    return SceneObject(oid, "cardboard_box", (x, y, z0 + size[1] / 2), size, yaw)


def line_with_gap(gap: float, y: float = 4.0, gap_x: float = 2.5, height: float = 1.2) -> list[SceneObject]:
    """Columns of boxes (0.45 m wide, ``height`` tall) along x at ``y``, wall to wall, with one gap of
    ``gap`` [m] centred at ``gap_x``."""
    out = []
    w = 0.45
    left = gap_x - gap / 2
    x = left - w / 2
    n = 0
    while x - w / 2 > -1e-9:
        out.append(_box(f"l{n}", x, y, (w, height, w)))
        x -= w
        n += 1
    x = gap_x + gap / 2 + w / 2
    n = 0
    while x + w / 2 < 5.0 + 1e-9:
        out.append(_box(f"r{n}", x, y, (w, height, w)))
        x += w
        n += 1
    return out


def _walk_only(grid):
    return Route(grid, (2.5, 1.0, 0.0))


@pytest.mark.parametrize("gap, through", [(0.25, False), (0.5, False), (0.7, False), (1.0, True), (1.2, True)])
def test_a_route_never_passes_through_a_gap_narrower_than_the_robot(gap: float, through: bool) -> None:
    grid = build_grid(line_with_gap(gap), WS, margin=0.35)
    route = _walk_only(grid)
    res = route.propose((2.5, 6.0, 0.0))
    assert res.ok, res.message
    pts = res.points(grid)
    walked_through = bool(np.any((np.abs(pts[:, 1] - 4.0) < 0.3) & (pts[:, 2] == 0.0)))
    assert walked_through is through
    if not through:  # over the line instead
        assert pts[:, 2].max() > 1.2 + 0.35
    # no route cell centre comes closer than the radius to any box (walking: horizontally; flying: 3D)
    for o in grid.objects:
        c, s = math.cos(o.yaw), math.sin(o.yaw)
        d = pts - np.asarray(o.position)
        along = np.maximum(np.abs(c * d[:, 0] + s * d[:, 1]) - o.size[2] / 2, 0)
        across = np.maximum(np.abs(-s * d[:, 0] + c * d[:, 1]) - o.size[0] / 2, 0)
        up = np.maximum(np.abs(d[:, 2] - 0.0) - o.size[1] / 2, 0)
        on_floor = res.cells[:, 2] == 0
        assert np.all(np.hypot(along, across)[on_floor] > 0.35 - 1e-9)
        air = res.cells[:, 2] > 0
        centres = grid.workspace.centers(res.cells[air])
        if len(centres):
            assert np.all(np.array([float(np.min(np.hypot(np.hypot(
                np.maximum(np.abs(c * (p[0] - o.position[0]) + s * (p[1] - o.position[1])) - o.size[2] / 2, 0),
                np.maximum(np.abs(-s * (p[0] - o.position[0]) + c * (p[1] - o.position[1])) - o.size[0] / 2, 0)),
                np.maximum(abs(p[2] - o.position[2]) - o.size[1] / 2, 0)))) for p in centres]) > 0.35 - 1e-9)


def test_goal_check_route_and_snapped_goal_follow_one_rule() -> None:
    box = _box("b", 2.5, 3.0, (0.5, 0.5, 0.5))
    grid = build_grid([box], WS, margin=0.35)
    route = Route(grid, (2.5, 1.0, 0.0))
    # 0.36 m from the box, but its cell centre (2.625, 3.625) is only 0.375 from it... and (2.5, 2.36)
    # lies in cell (10, 9) whose centre (2.625, 2.375) is 0.375 m from the box: allowed, snapped
    res = route.propose((2.5, 2.36, 0.0))
    assert res.ok and res.goal == pytest.approx((2.625, 2.375, 0.0)) and "goal snapped to (2.62, 2.38, 0.00)" in res.message
    # 0.15 m from the box, its cell centre (2.375, 2.625) 0.125 m: refused, naming the object and both distances
    bad = route.propose((2.45, 2.6, 0.0))
    assert not bad.ok and "0.15 m from cardboard_box 'b' (its cell centre (2.38, 2.62, 0.00): 0.12 m)" in bad.message and "needs 0.35 m around it" in bad.message


def test_unknown_space_is_closed_with_a_viewpoint_or_allowed_with_unseen_metres() -> None:
    ks = KnownSpace.empty(WS.min, WS.max, WS.resolution)
    free = np.zeros(ks.shape, bool)
    free[:, :18, :] = True  # y < 4.5 m seen free, beyond unknown
    ks = ks.updated(free, np.zeros_like(free))
    closed = build_grid([], WS, known=ks)
    assert closed.rule == "closed"
    route = Route(closed, (2.5, 1.0, 0.0))
    res = route.propose((2.5, 6.0, 0.0))
    assert not res.ok and "not seen yet: look from (" in res.message and res.viewpoint is not None
    vx, vy, vz = res.viewpoint
    assert vy < 4.5 and math.dist((vx, vy), (2.5, 6.0)) <= 5.0
    assert route.propose((2.5, 3.0, 0.0)).ok  # seen free: fine
    # behind a wall taller than the camera no reachable spot sees the floor: the edge of what was seen
    wall = [SceneObject("wall", "office_cabinet", (2.5, 4.2, 1.0), (0.3, 2.0, 5.0))]
    walled = build_grid(wall, WS, known=ks)
    far = Route(walled, (2.5, 1.0, 0.0)).propose((2.5, 5.0, 0.0))
    assert not far.ok and far.viewpoint is None and far.frontier is not None
    assert "Look around there" in far.message and far.frontier[1] < 4.2
    allowed = build_grid([], WS, known=ks, unknown="allow")
    r2 = Route(allowed, (2.5, 1.0, 0.0))
    ok = r2.propose((2.5, 6.0, 0.0))
    assert ok.ok and ok.unseen is not None and ok.unseen[-1] and not ok.unseen[0]
    assert 1.5 <= ok.unseen_m <= 2.0 and "m of it through unseen space" in ok.message
    # the walking column must be seen free up to the robot's height, not only the floor cell
    low = np.zeros(ks.shape, bool)
    low[:, :, 0] = True
    floor_only = build_grid([], WS, known=KnownSpace.empty(WS.min, WS.max, WS.resolution).updated(low, ~low & False))
    assert np.all(floor_only.state[:, :, 0] == CellState.OCCUPIED)


def test_a_scene_without_known_space_is_fully_known() -> None:
    g = build_grid([_box("b", 2.5, 3.0)], WS)
    assert g.rule == "fully_known" and g.unseen is None
    assert Route(g, (2.5, 1.0, 0.0)).propose((2.5, 6.0, 0.0)).ok


def test_a_floating_object_closes_the_floor_beneath_unless_seen_free() -> None:
    shelf = _box("shelf", 2.5, 4.0, (1.0, 0.3, 1.0), z0=1.04)
    ks = KnownSpace.empty(WS.min, WS.max, WS.resolution)
    everywhere = np.ones(ks.shape, bool)
    seen = ks.updated(everywhere, np.zeros_like(everywhere))
    grid = build_grid([shelf], WS, known=seen)
    assert grid.floating == ()  # seen free beneath: open
    assert grid.state_at(WS.cell_of((2.5, 4.0, 0.1))) is not CellState.OCCUPIED
    under = everywhere.copy()
    under[8:12, 14:18, :4] = False  # the column under it never seen
    grid = build_grid([shelf], WS, known=ks.updated(under, np.zeros_like(under)))
    assert grid.floating == ("shelf",)
    c = WS.cell_of((2.5, 4.0, 0.1))
    assert grid.reason_at(c) is Closed.BENEATH
    res = Route(grid, (2.5, 1.0, 0.0)).propose((2.5, 4.0, 0.0))
    assert not res.ok and "mapped floating (shelf)" in res.message
    # a box standing on another is not floating
    stack = [_box("lo", 1.0, 1.0), _box("hi", 1.01, 1.0, z0=0.4)]
    assert build_grid(stack, WS, known=seen).floating == ()


def test_unlabelled_obstacles_are_avoided_like_objects_and_counted() -> None:
    ks = KnownSpace.empty(WS.min, WS.max, WS.resolution)
    free = np.ones(ks.shape, bool)
    occ = np.zeros(ks.shape, bool)
    occ[:, 16, :5] = True  # a wall no detector named, y 4.0..4.25, 1.25 m tall, wall to wall
    ks = ks.updated(free, occ)
    grid = build_grid([], WS, known=ks)
    assert grid.unlabelled == 20 * 5
    route = Route(grid, (2.5, 1.0, 0.0))
    res = route.propose((2.5, 6.0, 0.0))
    assert res.ok and res.points(grid)[:, 2].max() > 1.25  # over it
    inside = route.propose((2.5, 4.1, 0.5))
    assert not inside.ok and "unlabelled obstacle" in inside.message
    # explained by a mapped object: not unlabelled (and still avoided as that object)
    wall = SceneObject("wall", "office_cabinet", (2.5, 4.125, 0.625), (0.25, 1.25, 5.0))
    assert build_grid([wall], WS, known=ks).unlabelled == 0
    # mapped 0.33 m off (within the tolerance and half a cell, so explained): the seen surface still closes its cells
    off = SceneObject("wall", "office_cabinet", (2.5, 4.45, 0.625), (0.25, 1.25, 5.0))
    g_off = build_grid([off], WS, known=ks)
    assert g_off.unlabelled == 0 and g_off.reason_at((10, 16, 0)) is Closed.SURFACE
    assert g_off.state_at((10, 15, 0)) is CellState.OCCUPIED  # 0.125 m from the seen surface


def test_the_robot_under_an_object_can_plan_and_is_warned() -> None:
    table = SceneObject("table-1", "table", (2.5, 2.0, 0.2), (1.0, 0.4, 1.0))  # mapped over the robot
    grid = build_grid([table], WS)
    route = Route(grid, (2.5, 2.0, 0.0))
    assert "table 'table-1'" in route.start_warning
    res = route.propose((2.5, 5.0, 0.0))
    assert res.ok, res.message
    assert Route(grid, (2.5, 5.0, 0.0)).start_warning == ""


def test_robot_model_is_validated_and_names_the_field() -> None:
    assert MORPHOGEAR.radius == 0.35 and MORPHOGEAR.height == 0.45
    with pytest.raises(RobotModelError, match="robot.height"):
        RobotModel(height=float("nan"))
    with pytest.raises(GridError, match="unknown must be one of"):
        build_grid([], WS, unknown="maybe")
    with pytest.raises(GridError, match="margin"):
        build_grid([], WS, margin=-1.0)
