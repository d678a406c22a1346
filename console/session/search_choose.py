"""The search's next-viewpoint choice in the console, without touching the session's planning rule.

:func:`choose_viewpoint` scores viewpoints (:func:`planner.search_viewpoints.score_viewpoints`) on the
session's own planning grid when it already is the one needed, over seen space (the grid with unknown
space closed). Over unknown space too (a grid with unknown space allowed, built here once and kept
until the known space changes) only when asked (``unknown=True``): the console's search never asks,
it never plans through space no capture has seen.

World frame (z up) [m], headings [rad], times [s].
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Any, Sequence

from planner.grid import PlanningGrid
from planner.route import Route
from planner.search_viewpoints import Viewpoint, confirm_viewpoint, score_viewpoints

from console.session.known_space_state import grid_for
from console.session.search_types import GAIN_MIN


@dataclass(frozen=True)
class Choice:
    """A choice of the next viewpoint.

    Attributes:
        viewpoint: The best viewpoint, or ``None`` when none shows unknown space where the target can be.
        why: Over which space it was chosen, or why none was.
        unknown: The viewpoint (and the route to it) needs unknown space allowed.
        candidates: The best few scored (the chosen one first), for the record.
        seconds: Time the choice took [s].
    """

    viewpoint: Viewpoint | None
    why: str
    unknown: bool
    candidates: tuple[Viewpoint, ...]
    seconds: float


class GridCache:
    """The planning grid under each unknown-space rule for the session's current scene and known space
    (the session's own grid when its rule is that one; another built once per change)."""

    def __init__(self) -> None:
        self._key: Any = None
        self._grids: dict[str, PlanningGrid] = {}

    def grid(self, session: Any, policy: str) -> PlanningGrid:
        own = session.grid
        if session.plan_unknown == policy:
            return own
        key = (session.scene, session.known_space, session.workspace, session.margin)  # held: compared by identity
        if self._key is None or any(a is not b for a, b in zip(key, self._key)):
            self._key, self._grids = key, {}
        if policy not in self._grids:
            self._grids[policy] = grid_for(session.scene, session.workspace, session.margin, session.known_space,
                                           policy)
        return self._grids[policy]


def choose_viewpoint(session: Any, here: tuple[float, float, float], target_height: float,
                     looked: Any, cache: GridCache, unknown: bool = False) -> Choice:
    """The next viewpoint from the robot at ``here`` (world [m]) for a target ``target_height`` [m] tall.

    ``looked``: cells earlier captures had in view that stayed unknown (they count no more).
    ``unknown``: when nothing seen shows enough, also look over unknown space (a route through space no
    capture has seen: only when the operator chose it; the console's search never does).
    """
    t0 = time.perf_counter()
    known = session.known_space
    if known is None:
        return Choice(None, "no known space yet", False, (), time.perf_counter() - t0)
    state = known.state()
    for policy in ("closed", "allow") if unknown else ("closed",):
        grid = cache.grid(session, policy)
        start = (here[0], here[1], max(here[2], grid.workspace.floor))
        cell = grid.workspace.cell_of(start)
        if cell is None:
            return Choice(None, f"the robot at {start} is outside the workspace", False, (), time.perf_counter() - t0)
        cost = Route(grid, start, session.weights).cost_array
        vps = score_viewpoints(state, grid, cost, cell, target_height, seen_only=policy == "closed", limit=3,
                               looked=looked)
        if vps and vps[0].gain >= GAIN_MIN:
            why = "over unknown space (nothing seen shows more)" if policy == "allow" else "over seen space"
            return Choice(vps[0], why, policy == "allow", tuple(vps), time.perf_counter() - t0)
    return Choice(None, "no reachable viewpoint shows unknown space where the target can be", False, (),
                  time.perf_counter() - t0)


def confirm_choice(session: Any, here: tuple[float, float, float], obj: Any,
                   spots: Sequence[Sequence[float]], cache: GridCache) -> Choice:
    """Where to confirm ``obj`` (a target seen once) from, when the confirming capture from each of
    ``spots`` (world [m]) missed it: :func:`planner.search_viewpoints.confirm_viewpoint` over seen space
    (a reachable seen-free spot more than 0.5 m from each, facing the target with a clear line of
    sight). ``Choice.viewpoint`` is ``None`` when there is none (then the ordinary next viewpoint)."""
    t0 = time.perf_counter()
    known = session.known_space
    if known is None:
        return Choice(None, "no known space yet", False, (), time.perf_counter() - t0)
    grid = cache.grid(session, "closed")
    start = (here[0], here[1], max(here[2], grid.workspace.floor))
    cell = grid.workspace.cell_of(start)
    if cell is None:
        return Choice(None, f"the robot at {start} is outside the workspace", False, (), time.perf_counter() - t0)
    vp = confirm_viewpoint(known.state(), grid, Route(grid, start, session.weights).cost_array, cell, obj, spots)
    if vp is None:
        return Choice(None, f"no reachable seen-free spot sees {obj.id} from elsewhere", False, (),
                      time.perf_counter() - t0)
    return Choice(vp, f"to confirm {obj.id}, over seen space", False, (vp,), time.perf_counter() - t0)


__all__ = ["Choice", "GridCache", "choose_viewpoint", "confirm_choice"]
