"""Click picking in the 3D view: where a click ray meets a horizontal plane, and the goal it picks.

World frame (z up) [m].
"""

from __future__ import annotations

from typing import Sequence

import numpy as np

from planner.grid import Workspace

from .session_types import SessionError, Vec3, fmt_point


def ray_plane(origin: Sequence[float], direction: Sequence[float], z: float) -> Vec3 | None:
    """Where a ray meets the horizontal plane at height ``z`` [m] (world), or ``None``.

    ``None`` when the ray is parallel to the plane or the plane lies behind the origin.
    """
    o = np.asarray(origin, dtype=np.float64)
    d = np.asarray(direction, dtype=np.float64)
    if o.shape != (3,) or d.shape != (3,) or not (np.all(np.isfinite(o)) and np.all(np.isfinite(d))):
        return None
    if abs(d[2]) < 1e-9:
        return None
    t = (z - o[2]) / d[2]
    if t <= 0:
        return None
    p = o + t * d
    return (float(p[0]), float(p[1]), float(z))


def goal_on_plane(origin: Sequence[float], direction: Sequence[float], z: float, workspace: Workspace) -> Vec3:
    """The goal a click ray picks: its hit with the plane at height ``z`` (world [m]).

    Raises :class:`SessionError` when the ray misses the plane or the hit lies outside the
    workspace's x-y bounds.
    """
    p = ray_plane(origin, direction, z)
    if p is None:
        raise SessionError(f"the click does not hit the plane z = {z:.2f} m; click on the floor or a grid layer")
    ws = workspace
    if not (ws.min[0] <= p[0] <= ws.max[0] and ws.min[1] <= p[1] <= ws.max[1]):
        raise SessionError(f"goal {fmt_point(p[:2])} is outside the workspace {fmt_point(ws.min[:2])}..{fmt_point(ws.max[:2])}")
    return p
