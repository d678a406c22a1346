"""Two small rules about where a route starts and where a goal may be (pure functions, world frame,
z up [m]; the session applies them under its lock):

- :func:`zero_length`: a goal in the cell the route already starts from (or less than one cell away)
  is refused with the distance: it would plan a 0 m path and build a 0 m mission.
- :func:`nothing_seen`: on the console's map before the first capture (every cell unknown) a refused
  goal says so first: :data:`NOTHING_SEEN`, then the planner's own words (the look to take: Go look).
- :func:`run_start`: during a run of any kind (the operator's mission, Land here, Return, a search's
  move; running, paused or in a failsafe) the route start shown follows the robot, in steps of
  :data:`RUN_START_STEP`, so the marker never stays at an old hover point.
"""

from __future__ import annotations

import math
from dataclasses import replace
from typing import Any, Sequence

from planner.route import PlanResult
from planner.grid import Workspace

from console.session import operator_state as rules
from console.session.session_types import Vec3

NOTHING_SEEN = "nothing seen yet: Capture & map or Look around first"
"""How a goal refusal starts on the console's map before the first capture (no capture has seen any
of the room, so every cell is unknown and closed; a scene file's map is taken as fully known)."""

RUN_START_STEP = 0.2
"""During a run the shown start moves once the robot is this far [m] from it (two cells: the marker
keeps up without redrawing the route for every centimetre)."""


def zero_length(goal: Sequence[float], route: Any, workspace: Workspace) -> str | None:
    """Why ``goal`` would make a zero-length route from where the next candidate starts, or ``None``.

    Zero-length: the goal lies in the same grid cell as the start (its layer's cell: ground goals on the
    floor) or less than one cell (``workspace.resolution``) away from it (3D). ``route`` is the session's
    :class:`planner.route.Route`; the next candidate starts at its last registered node, else at the robot.
    """
    start = route.last_node()
    d = math.dist(tuple(float(v) for v in goal[:3]), tuple(float(v) for v in start[:3]))
    cell_goal, cell_start = workspace.cell_of(goal), workspace.cell_of(start)
    same = cell_goal is not None and cell_goal == cell_start
    if not same and d >= workspace.resolution:
        return None
    where = "the route already ends" if route.registered else "the robot already is"
    return (f"goal is where {where} ({d:.2f} m): pick a goal at least one cell ({workspace.resolution:.2f} m) "
            "away, or nothing needs planning")


def nothing_seen(res: PlanResult, nothing: bool) -> PlanResult:
    """``res`` with :data:`NOTHING_SEEN` put before its refusal when ``nothing`` has been seen yet (the
    console's map before the first capture); a planned route, or a map with something seen, unchanged."""
    if res.ok or not nothing or res.message.startswith(NOTHING_SEEN):
        return res
    return replace(res, message=f"{NOTHING_SEEN} ({res.message})")


def run_start(robot: Any, active: bool, workspace: Workspace, shown: Vec3 | None) -> Vec3 | None:
    """The route start to show during a run: the robot's origin (:func:`operator_state.robot_origin`),
    updated when it moved :data:`RUN_START_STEP` from ``shown``; ``None`` when no run is under way (the
    route's own start is shown), ``shown`` unchanged while the robot's position is not known."""
    if not active:
        return None
    origin = rules.robot_origin(robot, workspace) if robot is not None else None
    if origin is None:
        return shown
    if shown is None or rules.gap(shown, origin) >= RUN_START_STEP:
        return origin
    return shown
