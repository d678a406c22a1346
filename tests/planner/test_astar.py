"""The Aerial-Ground A* core against a plain Dijkstra and skimage's MCP_Geometric."""

from __future__ import annotations

import itertools
import math
import threading

import numpy as np
import pytest

from planner.astar import (
    AStarResult,
    AStarSearcher,
    astar,
    dijkstra_reference,
    min_finite_cost,
    octile_distance,
)

MOVES = [d for d in itertools.product((-1, 0, 1), repeat=3) if d != (0, 0, 0)]


def _edge(cost: np.ndarray, a, b, res: float) -> float:
    d = np.subtract(b, a)
    assert np.all(np.abs(d) <= 1) and np.any(d != 0), f"{a} -> {b} is not a 26-neighbour move"
    return res * math.sqrt(float(d @ d)) * 0.5 * (cost[tuple(a)] + cost[tuple(b)])


def _check_path(cost: np.ndarray, r: AStarResult, start, goal, res: float, no_cc: bool = False) -> None:
    p = r.path
    assert p.ndim == 2 and p.shape[1] == 3 and np.issubdtype(p.dtype, np.integer)
    assert tuple(p[0]) == tuple(start) and tuple(p[-1]) == tuple(goal)
    assert np.all(np.isfinite(cost[p[:, 0], p[:, 1], p[:, 2]]))
    total = sum(_edge(cost, p[i], p[i + 1], res) for i in range(len(p) - 1))
    assert total == pytest.approx(r.cost, rel=1e-12, abs=1e-9)
    if no_cc:
        for a, b in zip(p[:-1], p[1:]):
            d = b - a
            for sub in itertools.product(*[(0, c) if c else (0,) for c in d]):
                c = tuple(a + np.array(sub))
                assert math.isfinite(cost[c]), f"{a} -> {b} cuts past impassable {c}"


def _random_case(seed: int, inf_frac: float = 0.2):
    rng = np.random.default_rng(seed)
    shape = (int(rng.integers(8, 16)), int(rng.integers(8, 13)), int(rng.integers(4, 7)))
    cost = rng.uniform(1.0, 20.0, shape)
    cost[rng.random(shape) < inf_frac] = np.inf
    free = np.argwhere(np.isfinite(cost))
    start, goal = (tuple(int(v) for v in free[i]) for i in rng.choice(len(free), 2, replace=False))
    res = float(rng.choice([1.0, 0.1, 0.25]))
    return cost, start, goal, res


@pytest.mark.parametrize("seed", range(50))
def test_matches_dijkstra_on_random_grids(seed: int) -> None:
    cost, start, goal, res = _random_case(seed, inf_frac=0.1 + 0.4 * (seed % 5) / 4)
    ref = dijkstra_reference(cost, start, goal, res)
    r = astar(cost, start, goal, resolution=res)
    assert r.found == ref.found
    if ref.found:
        assert r.cost == pytest.approx(ref.cost, rel=1e-12, abs=1e-9)
        _check_path(cost, r, start, goal, res)
        assert 0 < r.expanded <= ref.expanded  # A* never expands more than Dijkstra here
        _check_path(cost, ref, start, goal, res)
    else:
        assert r.path.shape == (0, 3) and r.cost == math.inf


@pytest.mark.parametrize("seed", range(200, 215))
def test_matches_dijkstra_with_a_nearly_tight_heuristic(seed: int) -> None:
    # Costs within 10 % of the minimum make h almost exact, so any overestimate shows up.
    rng = np.random.default_rng(seed)
    cost = rng.uniform(1.0, 1.1, (14, 12, 6))
    cost[rng.random(cost.shape) < 0.3] = np.inf
    free = np.argwhere(np.isfinite(cost))
    start, goal = (tuple(int(v) for v in free[i]) for i in rng.choice(len(free), 2, replace=False))
    ref = dijkstra_reference(cost, start, goal, 0.1)
    r = astar(cost, start, goal, resolution=0.1)
    assert r.found == ref.found
    if ref.found:
        assert r.cost == pytest.approx(ref.cost, rel=1e-12, abs=1e-9)
        _check_path(cost, r, start, goal, 0.1)


@pytest.mark.parametrize("seed", range(100, 115))
def test_no_corner_cutting_matches_dijkstra(seed: int) -> None:
    cost, start, goal, res = _random_case(seed, inf_frac=0.25)
    ref = dijkstra_reference(cost, start, goal, res, no_corner_cutting=True)
    r = astar(cost, start, goal, resolution=res, no_corner_cutting=True)
    assert r.found == ref.found
    if ref.found:
        assert r.cost == pytest.approx(ref.cost, rel=1e-12, abs=1e-9)
        _check_path(cost, r, start, goal, res, no_cc=True)
        free = astar(cost, start, goal, resolution=res)
        assert free.cost <= r.cost + 1e-9


def test_no_corner_cutting_blocks_diagonal_squeeze() -> None:
    cost = np.ones((3, 3, 1))
    cost[1, 0, 0] = cost[0, 1, 0] = np.inf  # the diagonal (0,0)->(1,1) squeezes between them
    assert astar(cost, (0, 0, 0), (1, 1, 0)).cost == pytest.approx(math.sqrt(2))
    r = astar(cost, (0, 0, 0), (1, 1, 0), no_corner_cutting=True)
    assert not r.found and r.cost == math.inf


def test_unreachable_goal() -> None:
    cost = np.ones((9, 9, 5))
    cost[3:6, 3:6, 1:4] = np.inf
    cost[4, 4, 2] = 2.0  # a free cell sealed inside a solid shell
    r = astar(cost, (0, 0, 0), (4, 4, 2))
    assert not r.found and r.cost == math.inf and r.path.shape == (0, 3)
    assert r.expanded == np.isfinite(cost).sum() - 1  # everything reachable was explored


def test_start_equals_goal() -> None:
    cost = np.full((4, 5, 3), 7.0)
    r = astar(cost, (2, 3, 1), (2, 3, 1), resolution=0.1)
    assert r.found and r.cost == 0.0 and r.path.tolist() == [[2, 3, 1]]


@pytest.mark.parametrize(
    "start, goal, match",
    [
        ((5, 0, 0), (0, 0, 0), "outside"),
        ((0, 0, 0), (0, 0, 3), "outside"),
        ((-1, 0, 0), (0, 0, 0), "outside"),
        ((1, 1, 1), (0, 0, 0), "impassable"),
        ((0, 0, 0), (1, 1, 1), "impassable"),
        ((0, 0), (0, 0, 0), "3 integer"),
        ((0.5, 0, 0), (0, 0, 0), "3 integer"),
    ],
)
def test_bad_cells_raise(start, goal, match) -> None:
    cost = np.ones((5, 4, 3))
    cost[1, 1, 1] = np.inf
    with pytest.raises(ValueError, match=match):
        astar(cost, start, goal)


def test_bad_grids_raise() -> None:
    ok = np.ones((4, 4, 2))
    with pytest.raises(ValueError, match="3D"):
        astar(np.ones((4, 4)), (0, 0, 0), (1, 1, 0))
    for bad in (np.nan, -1.0):
        c = ok.copy()
        c[3, 3, 1] = bad
        with pytest.raises(ValueError, match="NaN or negative"):
            astar(c, (0, 0, 0), (1, 1, 0))
    with pytest.raises(ValueError, match="resolution"):
        astar(ok, (0, 0, 0), (1, 1, 0), resolution=0.0)
    with pytest.raises(ValueError, match="heuristic_weight"):
        astar(ok, (0, 0, 0), (1, 1, 0), heuristic_weight=-1)


def test_octile_is_the_lattice_metric() -> None:
    # On a uniform unit-cost grid the optimal path cost is exactly the octile distance.
    cost = np.ones((7, 6, 5))
    rng = np.random.default_rng(3)
    for _ in range(20):
        a, b = (tuple(int(rng.integers(0, n)) for n in cost.shape) for _ in range(2))
        assert dijkstra_reference(cost, a, b).cost == pytest.approx(octile_distance(a, b), rel=1e-12)


def test_heuristic_consistent_and_admissible() -> None:
    rng = np.random.default_rng(11)
    cost = rng.uniform(1.0, 20.0, (12, 10, 6))
    cost[rng.random(cost.shape) < 0.15] = np.inf
    mc = min_finite_cost(cost)
    res = 0.2
    h = lambda a, goal: mc * res * octile_distance(a, goal)  # noqa: E731
    free = np.argwhere(np.isfinite(cost))
    for _ in range(2000):
        a = tuple(free[rng.integers(len(free))])
        goal = tuple(free[rng.integers(len(free))])
        m = MOVES[rng.integers(26)]
        b = tuple(np.add(a, m))
        if not all(0 <= b[i] < cost.shape[i] for i in range(3)) or not np.isfinite(cost[b]):
            continue
        assert h(a, goal) <= _edge(cost, a, b, res) + h(b, goal) + 1e-12
    for _ in range(10):
        a, goal = (tuple(free[rng.integers(len(free))]) for _ in range(2))
        assert h(a, goal) <= dijkstra_reference(cost, a, goal, res).cost + 1e-12


def test_tie_breaking_keeps_open_grid_search_on_the_path() -> None:
    cost = np.ones((60, 50, 20))
    r = astar(cost, (0, 0, 0), (59, 30, 12), resolution=0.1)
    assert r.cost == pytest.approx(0.1 * octile_distance((0, 0, 0), (59, 30, 12)))
    assert r.expanded <= 2 * len(r.path)  # Dijkstra would expand ~tens of thousands


def test_weights_and_precomputed_min_cost() -> None:
    cost, start, goal, res = _random_case(7, inf_frac=0.15)
    opt = dijkstra_reference(cost, start, goal, res).cost
    dij = astar(cost, start, goal, resolution=res, heuristic_weight=0)
    assert dij.cost == pytest.approx(opt, rel=1e-12)
    w = astar(cost, start, goal, resolution=res, heuristic_weight=3.0)
    assert opt - 1e-9 <= w.cost <= 3.0 * opt
    _check_path(cost, w, start, goal, res)
    pre = astar(cost, start, goal, resolution=res, min_cost=min_finite_cost(cost))
    assert pre.cost == pytest.approx(opt, rel=1e-12)
    assert min_finite_cost(cost) == cost[np.isfinite(cost)].min()


def test_searcher_reuse_across_sizes_and_generation_wrap() -> None:
    s = AStarSearcher()
    cases = [_random_case(seed) for seed in (21, 22, 21, 23)]
    expected = [dijkstra_reference(c, a, b, r).cost for c, a, b, r in cases]
    for (c, a, b, r), e in zip(cases * 2, expected * 2):
        assert s.search(c, a, b, resolution=r).cost == pytest.approx(e, rel=1e-12)
    s._gen = (1 << 30) - 2  # force the stamp wrap-around
    for (c, a, b, r), e in zip(cases, expected):
        assert s.search(c, a, b, resolution=r).cost == pytest.approx(e, rel=1e-12)


def test_heap_growth() -> None:
    rng = np.random.default_rng(9)
    cost = rng.uniform(1.0, 20.0, (40, 40, 15))
    start, goal = (20, 20, 0), (0, 0, 14)
    s = AStarSearcher()
    r = s.search(cost, start, goal, resolution=0.1, heuristic_weight=0)  # Dijkstra: a wide frontier
    assert s._hi.size > 4096  # the heap really had to grow during this search
    assert r.cost == pytest.approx(dijkstra_reference(cost, start, goal, 0.1).cost, rel=1e-12)
    _check_path(cost, r, start, goal, 0.1)


def test_non_contiguous_float32_input() -> None:
    rng = np.random.default_rng(5)
    cost = rng.uniform(1.0, 20.0, (40, 40, 10)).astype(np.float32)
    cost[rng.random(cost.shape) < 0.2] = np.inf
    cost[0, 0, 0] = cost[39, 39, 9] = 1.0
    ref = dijkstra_reference(cost, (0, 0, 0), (39, 39, 9), 0.1)
    r = astar(np.asfortranarray(cost), (0, 0, 0), (39, 39, 9), resolution=0.1)
    assert r.cost == pytest.approx(ref.cost, rel=1e-12)
    _check_path(cost.astype(np.float64), r, (0, 0, 0), (39, 39, 9), 0.1)


def test_threads_get_correct_results() -> None:
    cases = [_random_case(seed) for seed in range(30, 38)]
    expected = [dijkstra_reference(c, a, b, r).cost for c, a, b, r in cases]
    errors: list[str] = []

    def work(k: int) -> None:
        for _ in range(20):
            for i, (c, a, b, r) in enumerate(cases[k::2]):
                got = astar(c, a, b, resolution=r).cost
                if not math.isclose(got, expected[k + 2 * i], rel_tol=1e-12, abs_tol=1e-9):
                    errors.append(f"thread {k} case {i}: {got}")

    ts = [threading.Thread(target=work, args=(k,)) for k in range(2)]
    for t in ts:
        t.start()
    for t in ts:
        t.join()
    assert not errors


@pytest.mark.parametrize("seed, res", [(40, 1.0), (41, 0.1), (42, 0.25), (43, 0.05)])
def test_agrees_with_mcp_geometric(seed: int, res: float) -> None:
    graph = pytest.importorskip("skimage.graph")
    rng = np.random.default_rng(seed)
    cost = rng.uniform(1.0, 20.0, (30, 25, 10))
    cost[rng.random(cost.shape) < 0.2] = np.inf
    start, goal = (0, 0, 0), (29, 24, 9)
    cost[start] = cost[goal] = 2.0
    mcp = graph.MCP_Geometric(cost, fully_connected=True, sampling=(res, res, res))
    cum, _ = mcp.find_costs(starts=[start], ends=[goal])
    r = astar(cost, start, goal, resolution=res)
    assert math.isfinite(cum[goal]) and r.found
    assert r.cost == pytest.approx(float(cum[goal]), rel=1e-12)
    mpath = np.array(mcp.traceback(goal))
    assert sum(_edge(cost, mpath[i], mpath[i + 1], res) for i in range(len(mpath) - 1)) == pytest.approx(r.cost)
