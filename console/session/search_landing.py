"""Land here during a search: land where the robot can, on the nearest seen-free floor.

Outside a search, Land here lands straight down and is off over floor the known space has not seen
free (:func:`console.session.operator_state.unseen_floor_blocker`). During a search the robot is
often paused over floor no capture has seen (hovering behind a line of boxes, looking ahead), so
Land here there *lands where it can*: it flies to the nearest floor spot seen free (every floor
cell under the robot's footprint seen free and the spot free for the robot's size) and lands on it,
over seen-free space only (the planner's Aerial-Ground A* with unknown space closed). When no such
spot can be reached, it is refused with the reason.

Pure functions over the planning grid; the session calls them under its lock. World frame (z up),
metres.
"""

from __future__ import annotations

import math
from typing import Sequence

import numpy as np
from scipy import ndimage

from planner.grid import CellState, Closed, PlanningGrid

SPOTS_TRIED = 8
"""Nearest landing spots planned to, in order, before Land here is refused."""

UNSEEN_PREFIX = "Land here is off: the floor below"
"""How :func:`console.session.operator_state.unseen_floor_blocker`'s reason starts."""


def seen_free_floor(grid: PlanningGrid) -> np.ndarray | None:
    """``bool [nx, ny]``: floor cells where the robot may land: free for its size and every floor cell
    under its footprint (its radius around the cell centre) seen free. ``None`` on a fully known grid
    (no known space: landing is not limited by what was seen)."""
    if grid.rule == "fully_known" or grid.reason is None:
        return None
    ws = grid.workspace
    bad = grid.reason[:, :, 0] == Closed.UNKNOWN
    if grid.unseen is not None:
        bad = bad | grid.unseen[:, :, 0]
    r = max(0, int(math.floor(grid.robot.radius / ws.resolution + 1e-9)))
    ii, jj = np.mgrid[-r:r + 1, -r:r + 1]
    disk = np.hypot(ii, jj) * ws.resolution <= grid.robot.radius + 1e-9  # cell centres within the radius
    near_bad = ndimage.binary_dilation(bad, structure=disk) if bad.any() else bad
    return (grid.state[:, :, 0] == CellState.FREE) & ~near_bad


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


def unseen_below(reason: str) -> bool:
    """Whether a Land here reason is "the floor below has not been seen" (the one a search lands around)."""
    return reason.startswith(UNSEEN_PREFIX)


__all__ = ["SPOTS_TRIED", "UNSEEN_PREFIX", "nearest_landing_spots", "seen_free_floor", "unseen_below"]
