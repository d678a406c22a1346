"""Benchmark: the Aerial-Ground A* core against scikit-image's ``MCP_Geometric`` (Dijkstra).

Run from the repository root::

    python bench/planner.py            # 400x400x100 room + the paper's room + the console's grid
    python bench/planner.py --fly      # also the room whose wall has no door (must fly)
    python bench/planner.py --quick    # 200x200x50 instead of 400x400x100

Prints the numba compile time (cold and from cache), our search time, MCP's time, their ratio
(both measured in the same run, so the ratio holds on a loaded machine), the share of cells
expanded and the path costs; on the full-size rooms it checks the ratio targets (walk >= 200x,
fly >= 30x). Exits with status 1 when the two path costs differ by more than 0.5 %, and with
``--strict`` also when a ratio target is missed.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass

_HERE = os.path.dirname(os.path.abspath(__file__))
# This file is named planner.py: keep its folder off sys.path so ``import planner`` finds the package.
sys.path[:] = [p for p in sys.path if os.path.abspath(p or os.getcwd()) != _HERE]
sys.path.insert(0, os.path.dirname(_HERE))

import numpy as np  # noqa: E402

from planner.astar import AStarSearcher, astar, min_finite_cost  # noqa: E402
from planner.heuristic import build_layer_heuristic  # noqa: E402

GROUND, TAKEOFF, FLIGHT, DANGER = 1.0, 10.0, 3.0, 5.0
TOLERANCE = 0.005


@dataclass
class Case:
    """A benchmark grid with its start and goal cells."""

    name: str
    cost: np.ndarray
    start: tuple[int, int, int]
    goal: tuple[int, int, int]
    resolution: float


def _paint(occ: np.ndarray, danger: np.ndarray, lo: tuple[int, int, int], hi: tuple[int, int, int],
           shell: int) -> None:
    """Mark box ``[lo, hi)`` occupied and its Chebyshev shell of ``shell`` cells dangerous."""
    dlo = [max(0, v - shell) for v in lo]
    dhi = [min(n, v + shell) for v, n in zip(hi, occ.shape)]
    danger[dlo[0]:dhi[0], dlo[1]:dhi[1], dlo[2]:dhi[2]] = True
    occ[lo[0]:hi[0], lo[1]:hi[1], lo[2]:hi[2]] = True


def _cost(occ: np.ndarray, danger: np.ndarray) -> np.ndarray:
    """Layer costs (ground 1, first air layer 10, higher 3), x5 when dangerous, inf when occupied."""
    layer = np.full(occ.shape[2], FLIGHT)
    layer[0] = GROUND
    layer[1] = TAKEOFF
    cost = np.broadcast_to(layer, occ.shape).copy()
    cost[danger] *= DANGER
    cost[occ] = np.inf
    return np.ascontiguousarray(cost)


def big_room(shape: tuple[int, int, int], seed: int, resolution: float = 0.1, door: bool = True) -> Case:
    """Random floor-standing boxes (some low enough to fly over), a full-height wall across the
    room with one door, dangerous shells of 2 cells; start and goal in opposite corners.
    ``door=False``: the wall has no door but stops at 60 % of the height, so the robot must fly."""
    rng = np.random.default_rng(seed)
    nx, ny, nz = shape
    occ = np.zeros(shape, bool)
    danger = np.zeros(shape, bool)
    shell = 2
    start, goal = (5, 5, 0), (nx - 6, ny - 6, 0)
    for _ in range(max(8, nx * ny // 2500)):
        sx, sy = rng.integers(nx // 50 + 2, nx // 10 + 3, size=2)
        h = int(rng.integers(nz // 10, int(nz * 0.9)))
        x0 = int(rng.integers(0, nx - sx))
        y0 = int(rng.integers(0, ny - sy))
        lo, hi = (x0, y0, 0), (x0 + int(sx), y0 + int(sy), h)
        if any(lo[0] - 12 <= p[0] < hi[0] + 12 and lo[1] - 12 <= p[1] < hi[1] + 12 for p in (start, goal)):
            continue
        _paint(occ, danger, lo, hi, shell)
    wx = nx // 2
    if not door:
        occ[wx - 1 - shell:wx + 1 + shell] = False
        _paint(occ, danger, (wx - 1, 0, 0), (wx + 1, ny, int(nz * 0.6)), shell)
        return Case(f"room {nx}x{ny}x{nz} @ {resolution} m (seed {seed}), wall without door: must fly",
                    _cost(occ, danger), start, goal, resolution)
    door_y, door_w, door_h = int(rng.integers(ny // 10, ny - ny // 10 - 24)), max(12, ny // 16), int(nz * 0.4)
    occ[wx - 1:wx + 1, door_y:door_y + door_w, :door_h] = False  # keep the doorway clear of boxes
    danger[wx - 1 - shell:wx + 1 + shell, door_y:door_y + door_w, :door_h + shell] = False
    _paint(occ, danger, (wx - 1, 0, 0), (wx + 1, door_y, nz), shell)
    _paint(occ, danger, (wx - 1, door_y + door_w, 0), (wx + 1, ny, nz), shell)
    _paint(occ, danger, (wx - 1, door_y, door_h), (wx + 1, door_y + door_w, nz), shell)
    return Case(f"room {nx}x{ny}x{nz} @ {resolution} m (seed {seed})", _cost(occ, danger), start, goal, resolution)


def paper_room(seed: int) -> Case:
    """The paper's 5 x 8 x 3 m planning volume at 0.1 m (50x80x30 cells) with a line of boxes
    (0.6-1.2 m tall, 0.2 m gaps inside their 0.3 m danger shells) across the room between start and goal."""
    rng = np.random.default_rng(seed)
    shape = (50, 80, 30)
    occ = np.zeros(shape, bool)
    danger = np.zeros(shape, bool)
    x = 0
    while x < shape[0]:
        w = int(rng.integers(5, 10))
        _paint(occ, danger, (x, 38, 0), (min(shape[0], x + w), 42, int(rng.integers(6, 13))), 3)
        x += w + 2
    return Case("paper room 50x80x30 @ 0.1 m (5 x 8 x 3 m)", _cost(occ, danger), (25, 5, 0), (25, 75, 0), 0.1)


def console_grid(seed: int, gap: bool = False) -> Case:
    """The console's default grid: the paper's room at 0.25 m (20 x 32 x 12 cells) with a line of
    boxes 1 m tall across it (0.5 m danger shells), so the robot must fly over; ``gap=True``
    leaves a 1.5 m gap at one end of the line, so it walks around."""
    rng = np.random.default_rng(seed)
    shape = (20, 32, 12)
    occ = np.zeros(shape, bool)
    danger = np.zeros(shape, bool)
    x = 6 if gap else 0
    while x < shape[0]:
        w = int(rng.integers(2, 5))
        _paint(occ, danger, (x, 15, 0), (min(shape[0], x + w), 17, 4), 2)
        x += w
    what = "gap at one end: walks around" if gap else "must fly"
    return Case(f"console grid 20x32x12 @ 0.25 m (5 x 8 x 3 m), boxes across, {what}", _cost(occ, danger),
                (10, 2, 0), (10, 29, 0), 0.25)


def compile_times() -> list[tuple[float, float]]:
    """``(import [s], first astar call [s])`` in fresh interpreters: without, then with numba's cache."""
    code = ("import time; t=time.perf_counter(); import numpy as np; from planner.astar import astar; "
            "t1=time.perf_counter(); astar(np.ones((4, 4, 4)), (0, 0, 0), (3, 3, 3)); "
            "print(t1 - t, time.perf_counter() - t1)")
    out = []
    with tempfile.TemporaryDirectory() as d:
        env = dict(os.environ, NUMBA_CACHE_DIR=d)
        for _ in range(2):
            r = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True,
                               cwd=os.path.dirname(_HERE), check=True)
            imp, call = r.stdout.strip().splitlines()[-1].split()
            out.append((float(imp), float(call)))
    return out


def time_ours(case: Case, repeats: int, **kw) -> tuple[float, float, object]:
    """Median wall time [s] of a fresh search (same searcher, as a route reuses it) with the
    min-cost scan, and with ``min_cost`` given; everything per goal (the layer-aware tables when
    the search builds them) is inside the timed call."""
    searcher = AStarSearcher()
    mc = min_finite_cost(case.cost)
    full, pre = [], []
    res = None
    for _ in range(repeats):
        t = time.perf_counter()
        res = searcher.search(case.cost, case.start, case.goal, resolution=case.resolution, **kw)
        full.append(time.perf_counter() - t)
        t = time.perf_counter()
        searcher.search(case.cost, case.start, case.goal, resolution=case.resolution, min_cost=mc, **kw)
        pre.append(time.perf_counter() - t)
    return float(np.median(full)), float(np.median(pre)), res


def time_tables(case: Case, repeats: int) -> float:
    """Median wall time [s] of building the layer-aware heuristic's per-goal tables alone."""
    out = []
    for _ in range(repeats):
        t = time.perf_counter()
        build_layer_heuristic(case.cost, case.goal, case.resolution)
        out.append(time.perf_counter() - t)
    return float(np.median(out))


def time_mcp(case: Case) -> tuple[float, float, float, int]:
    """MCP_Geometric: (setup [s], find_costs + traceback [s], cost at goal, path length)."""
    from skimage.graph import MCP_Geometric

    t0 = time.perf_counter()
    r = case.resolution
    mcp = MCP_Geometric(case.cost, fully_connected=True, sampling=(r, r, r))
    t1 = time.perf_counter()
    cum, _ = mcp.find_costs(starts=[case.start], ends=[case.goal])
    path = mcp.traceback(case.goal) if np.isfinite(cum[case.goal]) else []
    t2 = time.perf_counter()
    return t1 - t0, t2 - t1, float(cum[case.goal]), len(path)


def run_case(case: Case, repeats: int, with_mcp: bool, target_ms: float | None,
             target_ratio: float | None = None) -> tuple[bool, bool]:
    """Print one case's figures; returns (the costs agree, the ratio target is met or not set)."""
    n = case.cost.size
    print(f"\n== {case.name}: {n:,} cells, {np.isinf(case.cost).mean():.1%} impassable, "
          f"start {case.start} goal {case.goal}")
    t_full, t_pre, res = time_ours(case, repeats)
    kinds = np.bincount(res.path[:, 2].clip(0, 2), minlength=3) if res.found else np.zeros(3, int)
    print(f"  astar   : {t_full * 1e3:9.2f} ms (median of {repeats}; {t_pre * 1e3:.2f} ms with min_cost given)"
          f"  expanded {res.expanded:,} ({res.expanded / n:.2%} of cells), heuristic: {res.heuristic}")
    if res.heuristic == "layer":
        print(f"            of which the per-goal layer-aware tables: {time_tables(case, 3) * 1e3:.1f} ms")
    print(f"            cost {res.cost:.6f}, {len(res.path)} cells "
          f"(ground {kinds[0]}, take-off layer {kinds[1]}, flight {kinds[2]})")
    if target_ms is not None:
        print(f"            target <= {target_ms:.0f} ms: {'met' if t_full * 1e3 <= target_ms else 'NOT met'}")
    if not with_mcp:
        return True, True
    setup, search, mcost, mlen = time_mcp(case)
    rel = abs(mcost - res.cost) / max(abs(mcost), 1e-300) if np.isfinite(mcost) else (
        0.0 if not res.found else np.inf)
    ratio = (setup + search) / t_full
    print(f"  MCP_Geo : {(setup + search) * 1e3:9.1f} ms (setup {setup * 1e3:.1f} ms, find_costs+traceback "
          f"{search * 1e3:.1f} ms)  cost {mcost:.6f}, {mlen} cells")
    print(f"  speed-up: {ratio:.1f}x (search only: {search / t_pre:.1f}x)   cost difference {rel:.2e} "
          f"({'OK' if rel <= TOLERANCE else 'DISAGREE'})")
    met = True
    if target_ratio is not None:
        met = ratio >= target_ratio
        print(f"  target  : >= {target_ratio:.0f}x faster than MCP_Geometric: {'met' if met else 'NOT met'}")
    return bool(rel <= TOLERANCE), met


def run_console(case: Case, repeats: int, with_mcp: bool) -> bool:
    """The console's grid: the default search (as a route runs it, corner cutting forbidden and
    not), and the same with the layer-aware tables forced on every call, to show what the
    per-goal precomputation would cost per click."""
    ok, _ = run_case(case, repeats, with_mcp, None)
    for ncc in (False, True):
        t_oct, _, r_oct = time_ours(case, repeats, no_corner_cutting=ncc, layer_heuristic=False)
        t_def, _, r_def = time_ours(case, repeats, no_corner_cutting=ncc)
        t_lay, _, r_lay = time_ours(case, repeats, no_corner_cutting=ncc, layer_budget=0)
        print(f"  per click{' (no corner cutting, as a route)' if ncc else ''}: octile only {t_oct * 1e3:.3f} ms "
              f"(expanded {r_oct.expanded:,}); default {t_def * 1e3:.3f} ms ({r_def.heuristic}, expanded "
              f"{r_def.expanded:,}); tables from the start {t_lay * 1e3:.3f} ms (expanded {r_lay.expanded:,}; "
              f"tables alone {time_tables(case, repeats) * 1e3:.3f} ms)")
        ok &= bool(abs(r_def.cost - r_lay.cost) <= 1e-9 * r_def.cost and abs(r_def.cost - r_oct.cost) <= 1e-9 * r_def.cost)
    return ok


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="200x200x50 instead of 400x400x100")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--repeats", type=int, default=5, help="timed runs of our A* per case")
    ap.add_argument("--fly", action="store_true", help="also the room whose wall has no door (A*'s hard case)")
    ap.add_argument("--no-mcp", action="store_true", help="skip the scikit-image baseline")
    ap.add_argument("--no-compile-probe", action="store_true", help="skip the cold-compile subprocesses")
    ap.add_argument("--strict", action="store_true", help="exit 1 when a speed-up target is missed")
    args = ap.parse_args(argv)

    if not args.no_compile_probe:
        (imp0, cold), (imp1, cached) = compile_times()
        print(f"numba, fresh process: first astar call {cold:.2f} s without cache (compile), {cached:.2f} s "
              f"with cache (load); import numpy+numba+planner.astar {imp0:.2f} s / {imp1:.2f} s")
    t = time.perf_counter()
    astar(np.ones((4, 4, 4)), (0, 0, 0), (3, 3, 3))
    astar(np.ones((4, 4, 4)), (0, 0, 0), (3, 3, 3), layer_budget=0)
    print(f"warm-up in this process: {time.perf_counter() - t:.3f} s")

    ok = met = True
    shape = (200, 200, 50) if args.quick else (400, 400, 100)
    targets = (None, None) if args.quick else (200.0, 30.0)  # the targets are for the full size
    t = time.perf_counter()
    big = big_room(shape, args.seed)
    print(f"built {big.name} in {time.perf_counter() - t:.2f} s")
    a, b = run_case(big, args.repeats, not args.no_mcp, None, targets[0])
    ok, met = ok & a, met & b
    if args.fly:
        a, b = run_case(big_room(shape, args.seed, door=False), args.repeats, not args.no_mcp, None, targets[1])
        ok, met = ok & a, met & b
    a, _ = run_case(paper_room(args.seed), max(args.repeats, 20), not args.no_mcp, 20.0)
    ok &= a
    ok &= run_console(console_grid(args.seed), max(args.repeats, 50), not args.no_mcp)
    ok &= run_console(console_grid(args.seed, gap=True), max(args.repeats, 50), not args.no_mcp)
    if not ok:
        print("\nFAIL: A* and MCP_Geometric path costs disagree by more than 0.5 %")
    if not met:
        print("\nspeed-up target NOT met" + (" (--strict)" if args.strict else ""))
    return 0 if ok and (met or not args.strict) else 1


if __name__ == "__main__":
    sys.exit(main())
