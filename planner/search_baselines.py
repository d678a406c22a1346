"""Baseline viewpoint pickers for the search benchmark (``bench/search.py``), against which
:func:`planner.search_viewpoints.score_viewpoints` is measured.

World frame (z up) [m], headings counter-clockwise from +x [rad]; the known space comes in as in
:mod:`planner.search_viewpoints` (``uint8 [nx, ny, nz]``: 0 unknown, 1 seen free, 2 occupied), the
reach as the planner's least path costs from the robot (:func:`planner.search_viewpoints.path_costs`).
Each picker returns a :class:`~planner.search_viewpoints.Viewpoint` (its ``gain`` 0: none of them
casts rays) or ``None`` when it has nowhere left to go.

- :func:`nearest_frontier_ground`: the classic frontier explorer (Yamauchi 1997) on the floor only:
  the seen-free floor cell next to unknown space (up to the target's height), in a frontier of at
  least :data:`MIN_FRONTIER` cells (smaller ones are noise), that is cheapest to reach, facing the 62 degree sector that holds the most unknown cells within 3 m (counted, no
  occlusion); spots within :data:`REVISIT` of an earlier capture are skipped.
- :func:`random_viewpoint`: a reachable seen-free cell (floor or air), uniformly, and a random heading.
- :func:`farthest_seen_free`: the paper's manual strategy: go to the reachable seen-free point
  farthest in plan from where the search started (ties: the lowest), facing the way it went; spots
  within :data:`REVISIT_FAR` of an earlier capture are skipped.
"""

from __future__ import annotations

import math
from typing import Sequence

import numpy as np
from scipy import ndimage

from planner.grid import PlanningGrid
from planner.search_viewpoints import FREE, FRONTIER_CELLS, HFOV, UNKNOWN, Viewpoint, path_costs

REVISIT = 0.75
"""Nearest-frontier: a frontier this close to an earlier capture's spot [m] is not visited again."""
REVISIT_FAR = 1.5
"""Farthest-seen-free: a point this close to an earlier capture's spot [m] is not chosen again."""
MIN_FRONTIER = 6
"""Nearest-frontier: frontiers (8-connected floor cells next to unknown space) smaller than this are skipped."""
SECTOR_RANGE = 3.0
"""Nearest-frontier: unknown cells within this distance [m] choose the heading."""


def _visited_mask(grid: PlanningGrid, visited: Sequence[Sequence[float]], radius: float) -> np.ndarray:
    """``bool [nx, ny]``: floor-plan cells within ``radius`` [m] of any visited ``(x, y, ...)``."""
    xs, ys, _ = grid.workspace.axes()
    out = np.zeros(grid.workspace.shape[:2], dtype=bool)
    for p in visited:
        out |= np.hypot(xs[:, None] - float(p[0]), ys[None, :] - float(p[1])) <= radius
    return out


def _viewpoint(grid: PlanningGrid, cell: Sequence[int], yaw: float, cost: float, why: str) -> Viewpoint:
    ws = grid.workspace
    goal = ws.centers(np.array([cell]))[0]
    ground = int(cell[2]) == 0
    if ground:
        goal[2] = ws.floor
    eye = (float(goal[0]), float(goal[1]), float(goal[2]) + grid.robot.camera_height)
    yaw = float((yaw + math.pi) % (2 * math.pi) - math.pi)
    why = (f"{why}: ({goal[0]:.2f}, {goal[1]:.2f}, {eye[2]:.2f}) m {'on the floor' if ground else 'hovering'}, facing "
           f"{math.degrees(yaw) % 360:.0f}°, path cost {cost:.1f}")
    return Viewpoint(tuple(float(v) for v in goal), eye, yaw, "walk" if ground else "fly", 0.0, float(cost), 0.0, why)


def sector_heading(unknown_xy: np.ndarray, grid: PlanningGrid, at: Sequence[float], reach: float = SECTOR_RANGE) -> float:
    """The heading [rad] whose 62 degree sector holds the most ``unknown_xy`` floor-plan cells within
    ``reach`` [m] of ``at`` (counted, no occlusion); 0 when there are none."""
    xs, ys, _ = grid.workspace.axes()
    ij = np.argwhere(unknown_xy)
    if len(ij) == 0:
        return 0.0
    dx, dy = xs[ij[:, 0]] - float(at[0]), ys[ij[:, 1]] - float(at[1])
    near = np.hypot(dx, dy) <= reach
    if not near.any():
        return 0.0
    ang = np.arctan2(dy[near], dx[near])
    bins = np.radians(np.arange(0.0, 360.0, 10.0))
    diff = np.abs((ang[None, :] - bins[:, None] + math.pi) % (2 * math.pi) - math.pi)
    counts = (diff <= HFOV / 2).sum(axis=1)
    return float(bins[int(np.argmax(counts))])


def nearest_frontier_ground(state: np.ndarray, grid: PlanningGrid, cost: np.ndarray, start_cell: Sequence[int],
                            target_height: float, visited: Sequence[Sequence[float]] = ()) -> Viewpoint | None:
    """The cheapest-to-reach seen-free floor cell next to unknown space up to ``target_height`` [m]
    (see the module docstring), or ``None``."""
    st = np.asarray(state)
    ws = grid.workspace
    dist = path_costs(grid, cost, start_cell)
    kt = max(1, min(st.shape[2], int(math.ceil((float(target_height) + ws.resolution) / ws.resolution))))
    unknown_xy = (st[:, :, :kt] == UNKNOWN).any(axis=2)
    near = ndimage.binary_dilation(unknown_xy, ndimage.generate_binary_structure(2, 2), iterations=FRONTIER_CELLS)
    cand = near & (st[:, :, 0] == FREE) & np.isfinite(dist[:, :, 0])
    lab, n = ndimage.label(cand, ndimage.generate_binary_structure(2, 2))
    if n:
        sizes = np.bincount(lab.ravel(), minlength=n + 1)
        cand &= sizes[lab] >= MIN_FRONTIER
    cand &= ~_visited_mask(grid, visited, REVISIT)
    if not cand.any():
        return None
    d = np.where(cand, dist[:, :, 0], np.inf)
    i, j = np.unravel_index(int(np.argmin(d)), d.shape)
    at = ws.centers(np.array([[i, j, 0]]))[0]
    yaw = sector_heading(unknown_xy, grid, at)
    return _viewpoint(grid, (i, j, 0), yaw, float(d[i, j]), "nearest frontier on the floor")


def random_viewpoint(state: np.ndarray, grid: PlanningGrid, cost: np.ndarray, start_cell: Sequence[int],
                     rng: np.random.Generator) -> Viewpoint | None:
    """A uniformly drawn reachable seen-free cell (floor or air) and a random heading, or ``None``."""
    dist = path_costs(grid, cost, start_cell)
    idx = np.argwhere((np.asarray(state) == FREE) & np.isfinite(dist))
    if len(idx) == 0:
        return None
    c = idx[int(rng.integers(0, len(idx)))]
    return _viewpoint(grid, c, float(rng.uniform(-math.pi, math.pi)), float(dist[tuple(c)]), "random")


def farthest_seen_free(state: np.ndarray, grid: PlanningGrid, cost: np.ndarray, start_cell: Sequence[int],
                       here: Sequence[float], yaw: float, visited: Sequence[Sequence[float]] = (),
                       origin: Sequence[float] | None = None) -> Viewpoint | None:
    """The reachable seen-free cell farthest in plan from ``origin`` [m] (default ``here``; ties: the
    lowest layer), facing from ``here`` [m] towards it (``yaw`` [rad] when it is straight above or
    below), or ``None``."""
    ws = grid.workspace
    dist = path_costs(grid, cost, start_cell)
    ok = (np.asarray(state) == FREE) & np.isfinite(dist) & ~_visited_mask(grid, visited, REVISIT_FAR)[:, :, None]
    idx = np.argwhere(ok)
    if len(idx) == 0:
        return None
    pts = ws.centers(idx)
    o = here if origin is None else origin
    far = np.round(np.hypot(pts[:, 0] - float(o[0]), pts[:, 1] - float(o[1])), 6)
    best = int(np.lexsort((idx[:, 2], -far))[0])
    dx, dy = pts[best, 0] - float(here[0]), pts[best, 1] - float(here[1])
    heading = math.atan2(dy, dx) if math.hypot(dx, dy) > 0.3 else float(yaw)
    return _viewpoint(grid, idx[best], heading, float(dist[tuple(idx[best])]), "farthest seen-free point")


__all__ = ["MIN_FRONTIER", "REVISIT", "REVISIT_FAR", "farthest_seen_free", "nearest_frontier_ground", "random_viewpoint",
           "sector_heading"]
