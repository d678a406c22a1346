"""Multi-stop routes: candidate / register / discard / undo, and clear errors."""

from __future__ import annotations

import numpy as np
import pytest

from pipeline.scene import SceneObject
from planner.grid import CellState, Workspace, build_grid
from planner.route import Route


def _route(objs=()):
    grid = build_grid(list(objs), Workspace(resolution=0.25), margin=0.3)
    return Route(grid, (0.5, 0.5, 0.0))


def test_candidate_register_continue_undo() -> None:
    r = _route()
    res = r.propose((2.5, 2.5, 0.0))
    assert res.ok and r.candidate is not None
    assert tuple(res.cells[0]) == (2, 2, 0) and tuple(res.cells[-1]) == (10, 10, 0)
    assert r.register() and r.candidate is None
    assert r.last_node() == pytest.approx((2.625, 2.625, 0.0))
    res2 = r.propose((4.0, 6.0, 0.0))
    assert tuple(res2.cells[0]) == (10, 10, 0)  # continues from the last registered node
    r.register()
    joined = r.registered_cells()
    assert len(joined) == len(res.cells) + len(res2.cells) - 1
    assert r.undo() and len(r.registered) == 1
    r.propose((4.0, 6.0, 0.0))
    r.discard()
    assert r.candidate is None and not r.register()
    r.clear()
    assert r.registered == [] and r.last_node() == (0.5, 0.5, 0.0)


def test_errors_leave_state_unchanged() -> None:
    box = SceneObject("cab", "office_cabinet", (2.5, 4.0, 0.9), (0.5, 1.8, 1.0))
    r = _route([box])
    ok = r.propose((1.0, 2.0, 0.0))
    assert ok.ok
    before = r.candidate
    out = r.propose((9.0, 1.0, 0.0))
    assert not out.ok and "outside the workspace" in out.message
    inside = r.propose((2.5, 4.0, 0.5))
    assert not inside.ok and "inside an obstacle (cab)" in inside.message
    assert r.candidate is before


def test_no_path_when_goal_is_enclosed() -> None:
    ring = [SceneObject(f"w{i}", "cardboard_box", p, s) for i, (p, s) in enumerate([
        ((2.5, 3.0, 1.5), (0.25, 3.0, 2.5)), ((2.5, 5.0, 1.5), (0.25, 3.0, 2.5)),
        ((1.5, 4.0, 1.5), (2.5, 3.0, 0.25)), ((3.5, 4.0, 1.5), (2.5, 3.0, 0.25)),
        ((2.5, 4.0, 2.9), (2.5, 0.2, 2.5)),
    ])]
    r = Route(build_grid(ring, Workspace(resolution=0.25), margin=0.0), (0.5, 0.5, 0.0))
    res = r.propose((2.5, 4.0, 0.0))
    assert not res.ok and "no path" in res.message


def test_rebuilt_grid_drops_blocked_segments_and_replans() -> None:
    r = _route()
    r.propose((2.5, 2.5, 0.0))
    r.register()
    r.propose((2.5, 6.0, 0.0))
    wall = SceneObject("wall", "cardboard_box", (2.5, 1.5, 1.5), (0.5, 3.0, 5.0))
    notes = r.set_grid(build_grid([wall], Workspace(resolution=0.25), margin=0.3))
    assert any("removed" in n for n in notes)
    assert r.registered == []


def test_session_dict_round_trip() -> None:
    r = _route()
    r.propose((2.0, 3.0, 0.0))
    r.register()
    r.propose((4.0, 6.0, 0.0))
    data = r.to_dict()
    r2 = _route()
    r2.restore(data)
    assert np.array_equal(r2.registered_cells(), r.registered_cells())
    assert r2.candidate is not None and np.array_equal(r2.candidate.cells, r.candidate.cells)


def test_weights_change_the_choice() -> None:
    r = _route()
    assert np.all(r.propose((4.5, 7.5, 0.0)).cells[:, 2] == 0)  # empty room: walk


def test_the_robot_never_squeezes_between_obstacles_touching_at_a_corner() -> None:
    """Two posts meet at a corner (no danger margin): the diagonal between them is closed."""
    posts = [SceneObject(f"p{i}", "cardboard_box", (x, y, 1.5), (0.25, 3.0, 0.25))
             for i, (x, y) in enumerate([(1.125, 1.375), (1.375, 1.125)])]
    grid = build_grid(posts, Workspace(resolution=0.25), margin=0.0)
    a, b = (1.125, 1.125, 0.0), (1.375, 1.375, 0.0)  # cells (4, 4) and (5, 5) on the floor
    squeezing = Route(grid, a, no_corner_cutting=False).plan(a, b)
    assert squeezing.ok and len(squeezing.cells) == 2  # one diagonal move between the posts
    safe = Route(grid, a).plan(a, b)
    assert safe.ok and len(safe.cells) > 2 and safe.cost > squeezing.cost
    for p, q in zip(safe.cells[:-1], safe.cells[1:]):  # no move sweeps past a post
        lo, hi = np.minimum(p, q), np.maximum(p, q)
        box = grid.state[lo[0]:hi[0] + 1, lo[1]:hi[1] + 1, lo[2]:hi[2] + 1]
        assert not (box == CellState.OCCUPIED).any()
