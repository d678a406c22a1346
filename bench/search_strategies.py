"""The search benchmark's strategies: how each picks the next viewpoint in a :class:`bench.search_sim.SimSearch`.

- ``search``: the product's choice, as :meth:`console.session.search.SearchJob._choose` makes it:
  :func:`planner.search_viewpoints.score_viewpoints` over seen-free space (its gain at least
  :data:`~console.session.search.GAIN_MIN`), else over unknown space too (the route may cross it);
  the cells earlier captures had in view that stayed unknown count no more.
- ``frontier``: nearest frontier on the floor only (:func:`planner.search_baselines.nearest_frontier_ground`).
- ``random``: random reachable seen-free viewpoints (:func:`planner.search_baselines.random_viewpoint`).
- ``manual``: the paper's manual strategy (:func:`planner.search_baselines.farthest_seen_free`):
  capture, go to the seen-free point farthest from the start, capture again (and on, as long as the
  budget lasts).

All plan on the map built from the captures (unknown space closed, except the product's fallback).
"""

from __future__ import annotations

from typing import Callable

from bench.search_sim import SimSearch
from console.session.search import GAIN_MIN
from planner.route import Route
from planner.search_baselines import farthest_seen_free, nearest_frontier_ground, random_viewpoint
from planner.search_viewpoints import Viewpoint, score_viewpoints

Pick = "tuple[Viewpoint, str] | None"


def _closed(sim: SimSearch):
    grid = sim.grid("closed")
    here = sim.here()
    return sim.known.state(), grid, Route(grid, here).cost_array, grid.workspace.cell_of(here)


def product(sim: SimSearch) -> tuple[Viewpoint, str] | None:
    state = sim.known.state()
    here = sim.here()
    for policy in ("closed", "allow"):
        grid = sim.grid(policy)
        cost = Route(grid, here).cost_array
        vps = score_viewpoints(state, grid, cost, grid.workspace.cell_of(here), sim.target_height,
                               seen_only=policy == "closed", limit=3, looked=sim.looked)
        if vps and vps[0].gain >= GAIN_MIN:
            return vps[0], policy
    return None


def frontier(sim: SimSearch) -> tuple[Viewpoint, str] | None:
    state, grid, cost, cell = _closed(sim)
    vp = nearest_frontier_ground(state, grid, cost, cell, sim.target_height, sim.visited)
    return (vp, "closed") if vp is not None else None


def random_pick(sim: SimSearch) -> tuple[Viewpoint, str] | None:
    state, grid, cost, cell = _closed(sim)
    vp = random_viewpoint(state, grid, cost, cell, sim.rng)
    return (vp, "closed") if vp is not None else None


def manual(sim: SimSearch) -> tuple[Viewpoint, str] | None:
    state, grid, cost, cell = _closed(sim)
    vp = farthest_seen_free(state, grid, cost, cell, sim.pos, sim.yaw, sim.visited, origin=sim.visited[0])
    return (vp, "closed") if vp is not None else None


STRATEGIES: dict[str, Callable[[SimSearch], "tuple[Viewpoint, str] | None"]] = {
    "search": product, "frontier": frontier, "random": random_pick, "manual": manual}
"""Strategy name -> picker; ``frontier`` is the baseline the ratios are against."""
BASELINE = "frontier"

__all__ = ["BASELINE", "STRATEGIES", "frontier", "manual", "product", "random_pick"]
