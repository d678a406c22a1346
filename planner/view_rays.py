"""What a level camera sees of the grid's cells: field of view and line of sight.

World frame (z up) [m], headings counter-clockwise from +x [rad]. The camera is fixed and level
(MorphoGear's default mount and the simulated 640 x 480 camera): a point is in view when its bearing
from the heading is within half the horizontal field of view, its elevation within half the vertical
field of view and its distance within :data:`MIN_RANGE` .. :data:`VIEW_RANGE`; it is seen when, in
addition, the straight line to it crosses no blocking cell (sampled every half cell, a compiled loop
that stops at the first blocking cell). Used by :mod:`planner.goal_look`.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from planner.grid import PlanningGrid

MIN_RANGE = 0.5
"""Nearest a seen cell may be to the camera [m] (the mapper drops objects closer)."""
VIEW_RANGE = 6.0
"""Farthest a cell is counted as seen [m] (the known space's rays reach 8 m; margin for sparse rays)."""
HFOV = math.radians(62.0)
"""The camera's horizontal field of view [rad] (the simulated 640 x 480 camera, fx = 525 px)."""
FOV_MARGIN = 0.92
"""Share of each half field of view counted (the image's border pixels are sampled sparsely)."""


def wrap(a: np.ndarray | float) -> np.ndarray:
    """Angles [rad] wrapped into [-pi, pi)."""
    return (np.asarray(a) + np.pi) % (2 * np.pi) - np.pi


def in_view(eyes: np.ndarray, yaws: np.ndarray, pts: np.ndarray, half_vfov: float) -> np.ndarray:
    """``bool [N, M]``: whether points ``pts [M, 3]`` lie in the field of view of level cameras at
    ``eyes [N, 3]`` facing ``yaws [N]`` (range, bearing and elevation; no occlusion)."""
    d = pts[None, :, :] - eyes[:, None, :]
    flat = np.hypot(d[..., 0], d[..., 1])
    dist = np.hypot(flat, d[..., 2])
    bearing = np.abs(wrap(np.arctan2(d[..., 1], d[..., 0]) - yaws[:, None]))
    elev = np.abs(np.arctan2(d[..., 2], flat))
    return ((dist >= MIN_RANGE) & (dist <= VIEW_RANGE) & (bearing <= FOV_MARGIN * HFOV / 2)
            & (elev <= FOV_MARGIN * half_vfov))


@njit(cache=True)
def _los_kernel(eyes: np.ndarray, pts: np.ndarray, pe: np.ndarray, pp: np.ndarray, own: np.ndarray,
                block: np.ndarray, lo: np.ndarray, res: float, nx: int, ny: int, nz: int) -> np.ndarray:
    """For each pair ``(pe[q], pp[q])``: no ``block`` cell (flat, C order) on the segment from the eye to
    the point, sampled every half cell, the point's own cell ``own[pp[q]]`` excepted."""
    out = np.ones(len(pe), dtype=np.bool_)
    step = res / 2.0
    for q in range(len(pe)):
        e = eyes[pe[q]]
        p = pts[pp[q]]
        dx, dy, dz = p[0] - e[0], p[1] - e[1], p[2] - e[2]
        n = int(math.ceil(math.sqrt(dx * dx + dy * dy + dz * dz) / step))
        target = own[pp[q]]
        for m in range(n):  # the target's own sample (m = n) left out
            f = m / n
            i = int(math.floor((e[0] + f * dx - lo[0]) / res))
            j = int(math.floor((e[1] + f * dy - lo[1]) / res))
            k = int(math.floor((e[2] + f * dz - lo[2]) / res))
            if i < 0 or j < 0 or k < 0 or i >= nx or j >= ny or k >= nz:
                continue
            c = (i * ny + j) * nz + k
            if c != target and block[c]:
                out[q] = False
                break
    return out


def line_of_sight(grid: PlanningGrid, blocking: np.ndarray, eyes: np.ndarray, cells: np.ndarray,
                  pairs: np.ndarray | None = None) -> np.ndarray:
    """``bool [N, M]``: whether the straight line from each eye ``[N, 3]`` (world [m]) to the centre
    of each cell ``[M, 3]`` crosses no ``blocking`` cell (the target's own cell excepted; sampled every
    half cell). Only the ``pairs`` (``bool [N, M]``) are cast (default all); the others are ``False``."""
    ws = grid.workspace
    n, m = len(eyes), len(cells)
    out = np.zeros((n, m), dtype=bool)
    if n == 0 or m == 0:
        return out
    nx, ny, nz = ws.shape
    todo = np.ones((n, m), dtype=bool) if pairs is None else np.asarray(pairs, dtype=bool)
    pe, pp = np.nonzero(todo)
    if len(pe) == 0:
        return out
    cells = np.asarray(cells, dtype=np.int64)
    own = (cells[:, 0] * ny + cells[:, 1]) * nz + cells[:, 2]
    ok = _los_kernel(np.ascontiguousarray(eyes, dtype=np.float64), ws.centers(cells), pe.astype(np.int64),
                     pp.astype(np.int64), own, np.ascontiguousarray(blocking, dtype=np.bool_).ravel(),
                     np.asarray(ws.min, dtype=np.float64), float(ws.resolution), nx, ny, nz)
    out[pe, pp] = ok
    return out


__all__ = ["FOV_MARGIN", "HFOV", "MIN_RANGE", "VIEW_RANGE", "in_view", "line_of_sight", "wrap"]
