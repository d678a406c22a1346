"""The search benchmark's strategies: how each picks the next viewpoint in a :class:`bench.search_sim.SimSearch`.

- ``search``: the product's choice, the console's own
  :func:`console.session.search_choose.choose_viewpoint` (on a view of the simulated search as its
  session): :func:`planner.search_viewpoints.score_viewpoints` over seen-free space (its gain at
  least :data:`~console.session.search_types.GAIN_MIN`; never over unknown space); the cells earlier
  captures had in view that stayed unknown count no more; a viewpoint whose route ended in contact
  is not tried again from the same spot (:func:`console.session.search_finish.untried`).
- ``frontier``: nearest frontier on the floor only (:func:`planner.search_baselines.nearest_frontier_ground`).
- ``random``: random reachable seen-free viewpoints (:func:`planner.search_baselines.random_viewpoint`).
- ``manual``: the paper's manual strategy (:func:`planner.search_baselines.farthest_seen_free`):
  capture, go to the seen-free point farthest from the start, capture again (and on, as long as the
  budget lasts).

All plan on the map built from the captures with unknown space closed (as the console's search).
"""

from __future__ import annotations

from typing import Callable

from bench.search_sim import SimSearch
from console.session.search_choose import GridCache, choose_viewpoint, confirm_choice
from console.session.search_finish import untried
from pipeline.scene import Scene
from planner.grid import CostWeights
from planner.robot_model import MORPHOGEAR
from planner.route import Route
from planner.search_baselines import farthest_seen_free, nearest_frontier_ground, random_viewpoint
from planner.search_viewpoints import Viewpoint

Pick = "tuple[Viewpoint, str] | None"


def _closed(sim: SimSearch):
    grid = sim.grid("closed")
    here = sim.here()
    return sim.known.state(), grid, Route(grid, here).cost_array, grid.workspace.cell_of(here)


class SessionView:
    """What :func:`console.session.search_choose.choose_viewpoint` reads of the console's session, from a
    simulated search (its map, known space and planning rule: unknown space closed)."""

    def __init__(self, sim: SimSearch) -> None:
        self.known_space = sim.known
        self.workspace = sim.ws
        self.margin = MORPHOGEAR.radius
        self.weights = CostWeights()
        self.plan_unknown = "closed"
        self.scene = Scene(objects=tuple(sim.objects()))
        self.grid = sim.grid("closed")


def product(sim: SimSearch) -> tuple[Viewpoint, str] | None:
    """The console's own choice (:func:`console.session.search_choose.choose_viewpoint`); a target seen once
    whose confirming capture missed it first gets a spot elsewhere that faces it
    (:func:`console.session.search_choose.confirm_choice`), as the console's loop."""
    view = SessionView(sim)
    choice = None
    if sim.confirm_target is not None:
        choice = confirm_choice(view, sim.here(), sim.confirm_target, sim.confirmed_from, GridCache())
    if choice is None or choice.viewpoint is None:
        choice = choose_viewpoint(view, sim.here(), sim.target_height, sim.looked, GridCache())
    vp = untried(choice, sim.pos, sim.contact_routes)  # as the console: a route that ended in contact is not repeated
    if vp is None:
        return None
    return vp, "allow" if choice.unknown else "closed"


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
