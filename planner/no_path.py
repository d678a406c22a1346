"""Why the planner found no path to a goal, in the operator's words (:meth:`planner.route.Route.plan`).

A goal can be cut off by obstacles (or, with unknown space closed, by space not seen yet), or be
reachable only by landing where the robot may not land (:func:`planner.landing_spot.no_landing`: the
planner never offers such a route, since Build would refuse it). World frame [m].
"""

from __future__ import annotations

from typing import Any, Sequence

import numpy as np

from planner.grid import Closed, PlanningGrid
from planner.landing_spot import refused_landing


def _fmt(p: Sequence[float]) -> str:
    return "(" + ", ".join(f"{float(v):.2f}" for v in p) + ")"


def no_path_text(grid: PlanningGrid, start: Sequence[float], goal: Sequence[float], ungated: Any = None) -> str:
    """The refusal of a search from ``start`` to ``goal`` (world [m]) that found no path.

    ``ungated``: the same search without the landing rule (an :class:`planner.astar.AStarResult`), or
    ``None``; when it found a path, the text names the first landing of that path the rule refuses and why.
    """
    head = f"no path from {_fmt(start)} to {_fmt(goal)}: "
    if ungated is not None and getattr(ungated, "found", False):
        why = refused_landing(grid, ungated.path)
        if why is not None:
            return head + why + (" (Look around, or Go look, to see the floor there)" if "not been seen" in why else "")
    hint = ""
    if grid.rule == "closed" and grid.reason is not None and bool(np.any(grid.reason == Closed.UNKNOWN)):
        hint = " or unseen space (Look around, or plan with unknown space allowed)"
    elif grid.rule == "allow" and goal[2] - grid.workspace.floor < grid.workspace.resolution:
        hint = " (with unknown space allowed the robot still lands only on seen-free floor)"
    return head + f"the goal is cut off by obstacles{hint}"


__all__ = ["no_path_text"]
