"""Space outside the workspace is closed: routes, goals, viewpoints and hover spots keep the robot's
size from the workspace's edge (its radius from the walls, in the air its height from the top)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from pipeline.mapping.known_space import KnownSpace
from pipeline.scene import SceneObject
from planner.cspace import edge_blockers, edge_closed
from planner.goal_look import next_look
from planner.grid import Closed, Workspace, build_grid
from planner.robot_model import MORPHOGEAR, RobotModel
from planner.route import Route, path_points
from planner.search_viewpoints import score_viewpoints
from planner.viewpoint import suggest_viewpoint

WS = Workspace()  # the paper's room: 5 x 8 x 3 m at 0.25 m; its walls are x = 0 and x = 5
START = (2.5, 0.7, 0.0)


def _gaps(pts: np.ndarray, ws: Workspace = WS) -> tuple[float, float]:
    """Least distance [m] of the points to the walls in plan, and to the top."""
    lo, hi = np.asarray(ws.min), np.asarray(ws.max)
    plan = np.minimum(pts[:, :2] - lo[:2], hi[:2] - pts[:, :2]).min()
    return float(plan), float((hi[2] - pts[:, 2]).min())


def _dense(pts: np.ndarray, step: float = 0.02) -> np.ndarray:
    out = [pts[:1]]
    for a, b in zip(pts[:-1], pts[1:]):
        n = max(1, int(math.ceil(float(np.linalg.norm(b - a)) / step)))
        out.append(a + (b - a) * (np.arange(1, n + 1) / n)[:, None])
    return np.concatenate(out)


@pytest.mark.parametrize("resolution", [0.25, 0.1])
@pytest.mark.parametrize("goal", [
    (0.4, 4.0, 0.0), (4.6, 4.0, 0.0), (2.5, 0.4, 0.0), (2.5, 7.6, 0.0),  # beside each wall
    (0.4, 7.6, 0.0), (4.6, 0.4, 0.0),  # in two corners
])
def test_a_route_near_each_edge_and_in_a_corner_keeps_the_robots_radius(goal, resolution) -> None:
    ws = Workspace(resolution=resolution)
    route = Route(build_grid([], ws), START)
    res = route.plan(START, goal)
    assert res.ok, res.message
    pts = _dense(res.points(route.grid))
    plan, _ = _gaps(pts, ws)
    assert plan >= MORPHOGEAR.radius - 1e-9, (goal, plan)
    assert plan <= MORPHOGEAR.radius + 2 * resolution  # it does go there: about as near as the rule lets it


@pytest.mark.parametrize("gap, walks", [(0.6, False), (0.9, True)])
def test_the_gap_between_a_lines_end_and_the_wall_is_walked_only_when_the_robot_fits(gap, walks) -> None:
    # a 1.2 m high line along y = 4 m from the wall x = 5 to x = gap: before, the 0.7 m robot walked
    # through the 0.6 m gap at x = 0.12, its body 0.23 m into the wall
    line = SceneObject("line", "cardboard_box", ((5.0 + gap) / 2, 4.0, 0.6), (0.5, 1.2, 5.0 - gap), 0.0, "world")
    route = Route(build_grid([line], WS), (1.0, 2.0, 0.0))
    res = route.plan(route.start, (1.0, 6.0, 0.0))
    assert res.ok, res.message
    pts = res.points(route.grid)
    through = bool(np.all(res.cells[:, 2] == 0))
    assert through is walks, res.message
    assert _gaps(_dense(pts))[0] >= MORPHOGEAR.radius - 1e-9


def test_a_flight_over_a_line_from_wall_to_wall_keeps_the_radius_from_the_walls_and_its_height_from_the_top() -> None:
    # a 2.2 m high line from wall to wall: the only way is over it, under the 3 m top. Above 2.55 m (its
    # top and the 0.35 m radius) the only layer is 2.62 m high, where the body (0.45 m high) would reach
    # 3.07 m: closed (before, the robot flew there)
    line = SceneObject("wall", "cardboard_box", (2.5, 4.0, 1.1), (0.4, 2.2, 5.0), 0.0, "world")
    route = Route(build_grid([line], WS), START)
    res = route.plan(START, (2.5, 6.0, 0.0))
    assert not res.ok and "cut off by obstacles" in res.message, res.message
    low = SceneObject("wall", "cardboard_box", (2.5, 4.0, 1.0), (0.4, 2.0, 5.0), 0.0, "world")
    route = Route(build_grid([low], WS), (0.4, 0.7, 0.0))
    res = route.plan(route.start, (4.6, 7.6, 0.0))
    assert res.ok, res.message
    pts = res.points(route.grid)
    air = pts[res.cells[:, 2] > 0]
    assert len(air) and air[:, 2].max() > 2.0  # it flew over the line
    plan, top = _gaps(_dense(pts))
    assert plan >= MORPHOGEAR.radius - 1e-9
    assert top >= max(MORPHOGEAR.flying_radius, MORPHOGEAR.height) - 1e-9


def test_a_goal_near_the_edge_is_refused_naming_the_edge_by_the_same_rule_as_the_route() -> None:
    route = Route(build_grid([], WS), START)
    res = route.plan(START, (4.99, 0.2, 0.0))
    assert not res.ok
    assert res.message == (
        "goal (4.99, 0.20, 0.00) is 0.01 m from the workspace's edge x = 5.00 (its cell centre (4.88, 0.12, 0.00): "
        "0.12 m; also 0.12 m from edge y = 0.00); the robot needs 0.35 m from it (its radius): choose a point further in")
    cell, why = route.check_point((4.99, 0.2, 0.0), "goal")
    assert cell is None and why == res.message  # the goal check and the route: one rule
    assert "at or beyond the workspace's edge x = 5.00" in route.plan(START, (5.0, 4.0, 0.0)).message
    top = route.plan(START, (2.5, 4.0, 2.9)).message
    assert top.startswith("goal (2.50, 4.00, 2.90) is 0.10 m from the workspace's top z = 3.00 (its cell centre "
                          "(2.62, 4.12, 2.88): 0.12 m); the robot needs 0.45 m from it (its height)"), top
    # one rule: a floor goal is planned exactly when its cell centre keeps the radius from every wall
    xs, ys, _ = WS.axes()
    for x in xs:
        for y in (ys[0], ys[1], ys[len(ys) // 2]):
            ok = route.check_point((float(x), float(y), 0.0), "goal")[0] is not None
            assert ok == (not edge_blockers(WS.min, WS.max, (x, y, 0.125), True, MORPHOGEAR)), (x, y)
    # the goal snaps to its cell's centre, which the check measured: never past the rule
    res = route.plan(START, (4.74, 4.0, 0.0))
    assert res.ok and res.goal == pytest.approx((4.625, 4.125, 0.0))


def test_the_edge_is_named_before_space_not_seen_yet() -> None:
    # nothing seen yet: a goal at the wall would never be allowed, so the refusal says why, not "look from"
    g = build_grid([], WS, known=KnownSpace.empty(WS.min, WS.max, WS.resolution))
    route = Route(g, START)  # the robot's own cells are free
    assert g.reason_at((19, 10, 0)) is Closed.UNKNOWN and g.edge[19, 10, 0]
    msg = route.plan(START, (4.95, 2.6, 0.0)).message
    assert "the workspace's edge x = 5.00" in msg and "not seen" not in msg, msg
    assert "not seen yet" in route.plan(START, (2.5, 5.0, 0.0)).message


def test_a_robot_beside_the_wall_keeps_off_it_and_one_in_the_band_may_leave() -> None:
    # the robot stands 0.45 m from the wall where a capture saw its body free (as the console marks it):
    # the band along the wall stays closed to it
    ks = KnownSpace.empty(WS.min, WS.max, WS.resolution).with_free_body((0.45, 2.0, 0.0), 1.0, 0.5)
    route = Route(build_grid([], WS, known=ks), (0.45, 2.0, 0.0))
    assert np.isfinite(route.cost_array[1, 8, 0]) and not np.isfinite(route.cost_array[0, 8, 0])
    assert "the workspace's edge x = 0.00" in route.plan(route.start, (0.1, 2.3, 0.0)).message
    assert route.plan(route.start, (0.45, 2.6, 0.0)).ok
    # a robot put in the band by hand (its own cell closed) may use its own cells to leave it
    stuck = Route(build_grid([], WS), (0.1, 2.0, 0.0))
    res = stuck.plan(stuck.start, (2.5, 2.0, 0.0))
    assert res.ok, res.message


def test_edge_closed_matches_the_rule_for_every_cell_and_robot() -> None:
    fat = RobotModel(radius=0.6, height=0.9, flying_radius=0.5)
    for robot in (MORPHOGEAR, fat):
        mask = edge_closed(WS.min, WS.max, WS.axes(), robot)
        xs, ys, zs = WS.axes()
        for i in (0, 1, 2, 3, 17, 18, 19):
            for k in (0, 1, 5, 8, 9, 10, 11):
                p = (xs[i], ys[12], zs[k])
                assert mask[i, 12, k] == bool(edge_blockers(WS.min, WS.max, p, k == 0, robot)), (robot, i, k)
    # a workspace lower than the walking body closes the floor
    low = Workspace(max=(5.0, 8.0, 0.4))
    assert edge_closed(low.min, low.max, low.axes(), MORPHOGEAR)[:, :, 0].all()


def _seen_front_and_along_the_wall() -> KnownSpace:
    """Seen free: the front of the room (x < 3 m, y < 1.5 m) and a 0.5 m strip along the wall x = 0, the
    whole room's length; the rest unknown. Without the edge rule the strip's cells 0.125 m from the wall
    are open (0.375 m from the unknown beyond the strip): the old planner looked from there (Go look's
    hover (0.12, 7.38, 0.62), Find's first viewpoint (0.12, 0.12, 0.88))."""
    ks = KnownSpace.empty(WS.min, WS.max, WS.resolution)
    free = np.zeros(ks.shape, dtype=bool)
    free[:12, :6, :] = True
    free[:2, :, :] = True
    return ks.updated(free, np.zeros_like(free))


def test_viewpoints_and_hover_spots_keep_the_radius_from_the_edge() -> None:
    g = build_grid([], WS, known=_seen_front_and_along_the_wall())
    route = Route(g, START)
    s = WS.cell_of(START)
    for target in ((0.3, 7.7, 0.0), (1.0, 6.0, 0.0), (0.2, 5.5, 1.0)):  # (0.3, 7.7): was (0.12, 2.12, 0.35)
        looks = next_look(g, route.cost_array, s, target)
        assert looks, target
        for look in looks:
            spot = np.asarray([look.eye])
            plan, top = _gaps(spot)
            assert plan >= MORPHOGEAR.radius - 1e-9, (target, look)
        eye = suggest_viewpoint(g, np.isfinite(route.cost_array), s, target)
        if eye is not None:
            assert _gaps(np.asarray([eye]))[0] >= MORPHOGEAR.radius - 1e-9, (target, eye)
    # every spot the robot can reach keeps the radius from the walls and its height from the top
    reach = np.argwhere(np.isfinite(route.cost_array))
    pts = path_points(reach, g)
    plan, top = _gaps(pts)
    assert plan >= MORPHOGEAR.radius - 1e-9 and top >= MORPHOGEAR.height - 1e-9


def test_the_searchs_viewpoints_keep_the_radius_from_the_edge() -> None:
    # without the edge rule the 8th best was (0.12, 1.12, 0.00), beside the wall
    ks = _seen_front_and_along_the_wall()
    g = build_grid([], WS, known=ks)
    route = Route(g, START)
    vps = score_viewpoints(ks.state(), g, route.cost_array, WS.cell_of(START), 0.4, limit=20, seen_only=False)
    assert len(vps) >= 5
    for vp in vps:
        plan, top = _gaps(np.asarray([vp.goal]))
        assert plan >= MORPHOGEAR.radius - 1e-9 and top >= MORPHOGEAR.height - 1e-9, vp.why
