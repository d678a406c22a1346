"""Get the planner's compiled kernels ready while the page loads, so the operator's first goal is planned at once.

The A* search (:mod:`planner.astar_kernel`) and its layer-aware heuristic (:mod:`planner.heuristic`) are numba
functions: the first call in a process loads them from numba's cache, or compiles them when the cache is
missing or stale (a fresh install, an updated planner). On the simulated robot that first call took 2.7 s with
the cache and 14.7 s without it (load ~8 on 2 cores), and the console said nothing meanwhile: an **Add goal**
pressed right after the page loaded looked ignored. :func:`start_planner_warmup` makes that first call on a
throwaway 8 x 6 x 5 grid in a background thread when the console starts (both heuristics, the ground and the
air), and a goal asked for meanwhile simply waits for it (numba compiles a function once, under its lock).
"""

from __future__ import annotations

import logging
import threading
import time

import numpy as np

log = logging.getLogger(__name__)


def warm_up() -> float:
    """Plan twice on a tiny grid (the octile bound, then the layer-aware heuristic from the start, over a wall
    that must be flown over), so every planner kernel is loaded or compiled. Returns the time taken [s]."""
    from planner.astar import astar

    t0 = time.perf_counter()
    cost = np.ones((8, 6, 5))
    cost[:, :, 1:] = 3.0  # flying costs more than walking (as the planner's cost grids do)
    cost[4, :, :3] = np.inf  # a wall three cells high: the path must fly over it (the heuristic's levels)
    astar(cost, (0, 0, 0), (7, 5, 0), resolution=0.25)
    astar(cost, (0, 0, 0), (7, 5, 0), resolution=0.25, layer_budget=0)
    return time.perf_counter() - t0


def start_planner_warmup() -> threading.Thread:
    """Run :func:`warm_up` in a daemon thread (logged, never raised: a failure only means the first goal waits)."""
    def run() -> None:
        try:
            log.info("planner kernels ready in %.1f s", warm_up())
        except Exception:  # noqa: BLE001 - the first real plan compiles them then, and reports its own errors
            log.exception("planner warm-up failed")

    thread = threading.Thread(target=run, name="planner-warmup", daemon=True)
    thread.start()
    return thread


__all__ = ["start_planner_warmup", "warm_up"]
