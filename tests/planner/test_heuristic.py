"""The layer-aware A* heuristic: never above the true cost-to-go, consistent on every edge, and
A* with it returns Dijkstra's costs (random grids and aerial-ground rooms that force flying)."""

from __future__ import annotations

import heapq
import itertools
import math

import numpy as np
import pytest
from scipy import ndimage

from planner.astar import AStarSearcher, astar, default_layer_budget, dijkstra_reference
from planner.heuristic import build_layer_heuristic, heuristic_field

MOVES = [d for d in itertools.product((-1, 0, 1), repeat=3) if d != (0, 0, 0)]


def _edge(cost, a, b, res):
    d = np.subtract(b, a)
    return res * math.sqrt(float(d @ d)) * 0.5 * (cost[a] + cost[b])


def cost_to_go(cost: np.ndarray, goal, res: float) -> np.ndarray:
    """True least cost from every cell to ``goal`` (plain Dijkstra from the goal; edges are
    symmetric)."""
    dist = np.full(cost.shape, np.inf)
    dist[goal] = 0.0
    heap = [(0.0, tuple(goal))]
    while heap:
        d, u = heapq.heappop(heap)
        if d > dist[u]:
            continue
        for m in MOVES:
            v = (u[0] + m[0], u[1] + m[1], u[2] + m[2])
            if not all(0 <= v[i] < cost.shape[i] for i in range(3)) or not math.isfinite(cost[v]):
                continue
            nd = d + _edge(cost, u, v, res)
            if nd < dist[v]:
                dist[v] = nd
                heapq.heappush(heap, (nd, v))
    return dist


def random_grid(rng):
    shape = (int(rng.integers(6, 13)), int(rng.integers(6, 12)), int(rng.integers(3, 8)))
    cost = rng.uniform(0.5, 20.0, shape)
    cost[rng.random(shape) < rng.uniform(0.0, 0.45)] = np.inf
    return cost, float(rng.choice([1.0, 0.1, 0.25]))


def room(rng, door: bool):
    """An aerial-ground room: ground / take-off / flight layer costs, boxes, dangerous shells
    (x5), and a wall across x lower than the ceiling, with or without a door."""
    nx, ny, nz = int(rng.integers(10, 17)), int(rng.integers(7, 13)), int(rng.integers(5, 10))
    occ = np.zeros((nx, ny, nz), bool)
    for _ in range(int(rng.integers(0, 4))):
        x0, y0 = int(rng.integers(0, nx - 2)), int(rng.integers(0, ny - 2))
        occ[x0:x0 + int(rng.integers(1, 4)), y0:y0 + int(rng.integers(1, 4)), :int(rng.integers(1, nz))] = True
    wx = int(rng.integers(3, nx - 3))
    wall_h = int(rng.integers(1, nz - 1))
    occ[wx:wx + int(rng.integers(1, 3)), :, :wall_h] = True
    if door:
        y0 = int(rng.integers(0, ny - 2))
        occ[wx:wx + 2, y0:y0 + 2, :min(wall_h, 2)] = False
    danger = ndimage.binary_dilation(occ, np.ones((3, 3, 3), bool)) & ~occ
    layer = np.full(nz, float(rng.uniform(2.0, 4.0)))
    layer[0] = float(rng.uniform(0.8, 1.2))
    layer[1] = float(rng.uniform(8.0, 14.0))
    cost = np.broadcast_to(layer, occ.shape).copy()
    cost[danger] *= float(rng.uniform(2.0, 6.0))
    if rng.random() < 0.5:
        cost[:, :, 1][danger[:, :, 1]] = np.inf  # take-off layer next to obstacles forbidden
    cost[occ] = np.inf
    return cost, float(rng.choice([0.1, 0.25]))


def walls(rng):
    """Several walls of different heights across x or y (some with a door) and tall boxes: more
    than one bottleneck altitude; flight layers of unequal costs."""
    nx, ny, nz = int(rng.integers(10, 16)), int(rng.integers(8, 13)), int(rng.integers(6, 10))
    occ = np.zeros((nx, ny, nz), bool)
    for _ in range(int(rng.integers(1, 4))):
        h = int(rng.integers(1, nz - 1))
        if rng.random() < 0.5:
            w = int(rng.integers(1, nx - 1))
            occ[w, :, :h] = True
            if rng.random() < 0.3:
                y0 = int(rng.integers(0, ny - 1))
                occ[w, y0:y0 + 2, :] = False
        else:
            occ[:, int(rng.integers(1, ny - 1)), :h] = True
    for _ in range(int(rng.integers(0, 4))):
        x0, y0 = int(rng.integers(0, nx - 1)), int(rng.integers(0, ny - 1))
        occ[x0:x0 + 2, y0:y0 + 2, :int(rng.integers(1, nz))] = True
    danger = ndimage.binary_dilation(occ, np.ones((3, 3, 3), bool)) & ~occ
    layer = np.full(nz, float(rng.uniform(2.0, 4.0)))
    layer[0] = 1.0
    layer[1] = float(rng.uniform(5.0, 14.0))
    if rng.random() < 0.5:
        layer[2:] *= rng.uniform(0.8, 1.5, nz - 2)
    cost = np.broadcast_to(layer, occ.shape).copy()
    cost[danger] *= float(rng.uniform(2.0, 6.0))
    cost[occ] = np.inf
    return cost, 0.1


def _cells(cost, rng, k=2, ground=False):
    free = np.argwhere(np.isfinite(cost) & ((np.arange(cost.shape[2]) == 0) if ground else True))
    idx = rng.choice(len(free), k, replace=False)
    return [tuple(int(v) for v in free[i]) for i in idx]


def _grids(seed: int):
    rng = np.random.default_rng(seed)
    kind = seed % 4
    if kind == 0:
        cost, res = random_grid(rng)
        goal = _cells(cost, rng, 1)[0]
    elif kind == 3:
        cost, res = walls(rng)
        goal = _cells(cost, rng, 1)[0]
    else:
        cost, res = room(rng, door=(kind == 1))
        goal = _cells(cost, rng, 1, ground=rng.random() < 0.7)[0]
    return rng, cost, res, goal


@pytest.mark.parametrize("seed", range(80))
def test_heuristic_admissible_and_consistent(seed: int) -> None:
    rng, cost, res, goal = _grids(seed)
    h = heuristic_field(cost, goal, res)
    true = cost_to_go(cost, goal, res)
    fin = np.isfinite(cost)
    reach = fin & np.isfinite(true)
    assert h[goal] == pytest.approx(0.0, abs=1e-12)
    # admissible: never above the true cost-to-go
    assert np.all(h[reach] <= true[reach] * (1 + 1e-9) + 1e-12), np.max(h[reach] - true[reach])
    # consistent: h(a) <= edge(a, b) + h(b) on every edge
    worst = -math.inf
    for a in map(tuple, np.argwhere(fin)):
        for m in MOVES:
            b = (a[0] + m[0], a[1] + m[1], a[2] + m[2])
            if all(0 <= b[i] < cost.shape[i] for i in range(3)) and fin[b] and math.isfinite(h[b]):
                worst = max(worst, h[a] - _edge(cost, a, b, res) - h[b])
    assert worst <= 1e-9 * max(1.0, float(np.nanmax(np.where(np.isfinite(h), h, np.nan))))


def test_heuristic_is_tight_where_flying_is_the_only_way() -> None:
    # Ground 1, take-off 10, flight 3; a wall of 5 layers with no door across the room.
    cost = np.broadcast_to(np.array([1.0, 10.0] + [3.0] * 8), (30, 12, 10)).copy()
    cost[14:16, :, :5] = np.inf
    start, goal, res = (2, 6, 0), (27, 6, 0), 0.1
    h = heuristic_field(cost, goal, res)
    true = dijkstra_reference(cost, start, goal, res).cost
    octile_only = res * 1.0 * 25  # what the octile bound knows
    assert octile_only < 0.6 * true
    assert 0.9 * true <= h[start] <= true * (1 + 1e-9)


def test_several_bottleneck_altitudes_are_covered() -> None:
    # The admissibility / consistency test above runs on grids whose goal has several bottleneck
    # altitudes, each with its own distance table.
    hits = 0
    for seed in range(3, 80, 4):  # its several-walls grids
        rng, cost, res, goal = _grids(seed)
        hits += len(build_layer_heuristic(np.ascontiguousarray(cost), goal, res).levels) > 1
    assert hits >= 3


def test_tables_shapes_and_levels() -> None:
    cost = np.broadcast_to(np.array([1.0, 10.0] + [3.0] * 6), (20, 9, 8)).copy()
    cost[9:11, :, :4] = np.inf
    lh = build_layer_heuristic(cost, (18, 4, 0), 0.25)
    assert lh.d2.shape == (180,) and lh.rcol.shape == (180,) and lh.s.shape == (8,)
    assert lh.levels.tolist() == [4]  # the wall's top: the only bottleneck altitude
    assert lh.rcol[2 * 9 + 4] == 4 and lh.rcol[18 * 9 + 4] == 0
    assert lh.dw.shape == (1, 180 + 8 + 1) and lh.dw[0, 2 * 9 + 4] == pytest.approx(8.0)  # to column x = 10


@pytest.mark.parametrize("seed", range(40))
@pytest.mark.parametrize("budget", [0, 7])
def test_astar_with_layer_heuristic_matches_dijkstra(seed: int, budget: int) -> None:
    rng, cost, res, goal = _grids(1000 + seed)
    start = _cells(cost, rng, 1, ground=rng.random() < 0.7)[0]
    if start == goal:
        return
    ref = dijkstra_reference(cost, start, goal, res)
    r = astar(cost, start, goal, resolution=res, layer_budget=budget)
    assert r.found == ref.found
    if ref.found:
        assert r.cost == pytest.approx(ref.cost, rel=1e-12, abs=1e-9)
        p = r.path
        assert tuple(p[0]) == start and tuple(p[-1]) == goal
        assert sum(_edge(cost, tuple(p[i]), tuple(p[i + 1]), res) for i in range(len(p) - 1)) == pytest.approx(r.cost)
        if r.expanded > budget:
            assert r.heuristic == "layer"
        ncc = dijkstra_reference(cost, start, goal, res, no_corner_cutting=True)
        r2 = astar(cost, start, goal, resolution=res, layer_budget=budget, no_corner_cutting=True)
        assert r2.found == ncc.found and (not ncc.found or r2.cost == pytest.approx(ncc.cost, rel=1e-12))
    else:
        assert r.path.shape == (0, 3) and r.cost == math.inf


def test_fly_only_room_expands_far_less_with_the_layer_heuristic() -> None:
    cost = np.broadcast_to(np.array([1.0, 10.0] + [3.0] * 18), (60, 40, 20)).copy()
    cost[29:31, :, :12] = np.inf
    cost[27:29, :, :14] *= 5.0
    cost[31:33, :, :14] *= 5.0
    start, goal, res = (2, 3, 0), (57, 36, 0), 0.1
    s = AStarSearcher()
    octile = s.search(cost, start, goal, resolution=res, layer_heuristic=False)
    layer = s.search(cost, start, goal, resolution=res, layer_budget=0)
    auto = s.search(cost, start, goal, resolution=res)  # the default budget, then the switch
    assert layer.cost == pytest.approx(octile.cost, rel=1e-12) == auto.cost
    assert layer.heuristic == "layer" and octile.heuristic == "octile"
    assert layer.expanded < 0.3 * octile.expanded
    assert auto.expanded < octile.expanded


def test_default_budget_builds_the_tables_only_when_the_octile_bound_struggles() -> None:
    # The console's grid (20 x 32 x 12): a wall to fly over needs the tables, an open room not.
    cost = np.broadcast_to(np.array([1.0, 12.0] + [3.0] * 10), (20, 32, 12)).copy()
    assert astar(cost, (2, 2, 0), (17, 29, 0), resolution=0.25).heuristic == "octile"
    cost[:, 14:16, :5] = np.inf
    s = AStarSearcher()
    r = s.search(cost, (2, 2, 0), (17, 29, 0), resolution=0.25)
    oct_only = s.search(cost, (2, 2, 0), (17, 29, 0), resolution=0.25, layer_heuristic=False)
    assert r.heuristic == "layer" and oct_only.heuristic == "octile"
    assert r.cost == pytest.approx(oct_only.cost, rel=1e-12)
    assert r.expanded < oct_only.expanded
    assert default_layer_budget((20, 32, 12)) < oct_only.expanded


@pytest.mark.parametrize("bad", [-1, 1.5, True, "3"])
def test_bad_layer_budget_raises(bad) -> None:
    with pytest.raises(ValueError, match="layer_budget"):
        astar(np.ones((4, 4, 3)), (0, 0, 0), (3, 3, 0), layer_budget=bad)
