"""Land here during a search: land where the robot can, on the nearest seen-free floor.

Outside a search, Land here lands straight down and is off over floor the known space has not seen
free (:func:`console.session.operator_state.unseen_floor_blocker`). During a search the robot is
often paused over floor no capture has seen (hovering behind a line of boxes, looking ahead), so
Land here there *lands where it can*: it flies to the nearest floor spot fit for landing (the one
landing rule, :mod:`planner.landing_spot`: under the robot's whole footprint no mapped object of any
height, no obstacle cell, no unseen floor; and free ground for its size) and lands on it, over
seen-free space only (the planner's Aerial-Ground A* with unknown space closed). When no such spot
can be reached, it is refused with the reason.

Pure functions over the planning grid; the session calls them under its lock. World frame (z up),
metres.
"""

from __future__ import annotations

from typing import Any, Mapping, Sequence

import numpy as np

from planner.grid import PlanningGrid
from planner.landing_spot import landing_mask
from planner.mission import Mission, MissionError

from console.session import operator_state as rules
from console.session.operator_state import CommandState
from console.session.session_types import SessionError, fmt_point

SPOTS_TRIED = 8
"""Nearest landing spots planned to, in order, before Land here is refused."""


def seen_free_floor(grid: PlanningGrid) -> np.ndarray | None:
    """``bool [nx, ny]``: floor cells where the robot may land (:func:`planner.landing_spot.landing_mask`
    with free ground: every floor cell under its footprint seen free, no mapped object of any height and
    no obstacle cell within its radius, outside the danger band). ``None`` on a fully known grid (no
    known space: landing is not limited by what was seen)."""
    if grid.rule == "fully_known" or grid.reason is None:
        return None
    return landing_mask(grid, clear=True)


def nearest_landing_spots(grid: PlanningGrid, point: Sequence[float], limit: int = SPOTS_TRIED) -> list[tuple[float, float, float]]:
    """The ``limit`` landing spots (floor cell centres, world [m], z = floor) nearest to ``point``
    in plan, nearest first; empty when none is seen free (or the grid has no known space)."""
    ok = seen_free_floor(grid)
    if ok is None or not ok.any():
        return []
    ws = grid.workspace
    idx = np.argwhere(ok)
    cells = np.column_stack([idx, np.zeros(len(idx), dtype=idx.dtype)])
    centres = ws.centers(cells)
    d = np.hypot(centres[:, 0] - float(point[0]), centres[:, 1] - float(point[1]))
    order = np.argsort(d, kind="stable")[:max(1, int(limit))]
    return [(float(centres[n, 0]), float(centres[n, 1]), float(ws.floor)) for n in order]


def straight_down_blocker(robot: Any, grid: PlanningGrid) -> str | None:
    """Why the robot cannot land straight down where it hovers (floor below not seen free, or a mapped
    obstacle below), or ``None``."""
    return rules.unseen_floor_blocker(robot.pose.translation, grid) or rules.landing_blocker(robot, grid)


def land_elsewhere_state(commands: Mapping[str, CommandState], robot: Any, run: Any, ws: Any, launch: Any,
                         grid: PlanningGrid) -> dict[str, CommandState]:
    """The vehicle commands with Land here on when only the floor below stops it and a seen-free spot
    exists (it will land there); off with both reasons when there is none."""
    out = dict(commands)
    land = out.get("land")
    if robot is None or land is None or land.enabled or not land.shown:
        return out
    if not rules.vehicle_commands(robot, run, ws, launch, None)["land"].enabled:  # link, position, a mission ...
        return out
    if straight_down_blocker(robot, grid) is None:
        return out
    if nearest_landing_spots(grid, robot.pose.translation, 1):
        out["land"] = CommandState(True, True, "")
    else:
        out["land"] = CommandState(True, False, f"{land.reason}; and no floor was seen free to land on instead")
    return out


def land_elsewhere_mission(robot: Any, grid: PlanningGrid, route: Any, ws: Any, mission_id: str) -> Mission | None:
    """Land here during a search: ``None`` when the robot can land straight down (the usual Land here);
    else a mission to the nearest seen-free floor spot the planner reaches, landing there (world [m]).

    Raises :class:`SessionError` with the reasons when no spot can be reached."""
    why = straight_down_blocker(robot, grid)
    if why is None:
        return None
    origin = rules.robot_origin(robot, ws)
    if origin is None:
        raise SessionError(rules.position_blocker(robot) or "the robot is outside the workspace")
    spots = nearest_landing_spots(grid, origin)
    if not spots:
        raise SessionError(f"{why}; and no floor was seen free to land on instead")
    last = ""
    for spot in spots:
        res = route.plan(origin, spot)
        if not res.ok:
            last = res.message
            continue
        try:
            return rules.mission_from_path(res.cells, grid, mission_id)
        except MissionError as exc:
            last = str(exc)
    raise SessionError(f"{why}; and none of the {len(spots)} nearest seen-free spots (the nearest "
                       f"{fmt_point(spots[0][:2])}) can be reached: {last}")


__all__ = ["SPOTS_TRIED", "land_elsewhere_mission", "land_elsewhere_state", "nearest_landing_spots", "seen_free_floor",
           "straight_down_blocker"]
