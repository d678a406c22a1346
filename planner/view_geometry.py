"""Plane geometry of footprints and of the robot's view, for the scene graph.

World frame, z up; footprints are an object's oriented box seen from above (``[4, 2]`` corners,
metres); bearings are in the robot frame (0 ahead along the robot's x axis, positive to the
left) [rad].
"""

from __future__ import annotations

import math
from typing import Any, Sequence

import numpy as np

from pipeline.scene import SceneObject

from planner.object_goal import footprint, footprint_distance


def wrap(a: np.ndarray | float) -> Any:
    """Angles [rad] wrapped to ``[-pi, pi)``."""
    return (np.asarray(a) + np.pi) % (2 * np.pi) - np.pi


def polygon_gap(a: np.ndarray, b: np.ndarray) -> float:
    """Distance [m] between two convex polygons ``[n, 2]`` (0 when they overlap)."""
    def inside(pts: np.ndarray, poly: np.ndarray) -> np.ndarray:
        e = np.roll(poly, -1, axis=0) - poly  # [m, 2]
        r = pts[:, None, :] - poly[None, :, :]  # [n, m, 2]
        cross = e[None, :, 0] * r[:, :, 1] - e[None, :, 1] * r[:, :, 0]
        return np.all(cross >= -1e-12, axis=1) | np.all(cross <= 1e-12, axis=1)

    def seg_dist(pts: np.ndarray, poly: np.ndarray) -> float:
        s0 = poly
        d = np.roll(poly, -1, axis=0) - poly  # [m, 2]
        r = pts[:, None, :] - s0[None, :, :]  # [n, m, 2]
        t = np.clip(np.einsum("nmk,mk->nm", r, d) / np.maximum(np.einsum("mk,mk->m", d, d), 1e-18), 0.0, 1.0)
        return float(np.min(np.linalg.norm(r - t[:, :, None] * d[None, :, :], axis=2)))

    if inside(a, b).any() or inside(b, a).any():
        return 0.0
    for i in range(len(a)):  # edges crossing with no vertex inside (a plus shape)
        for j in range(len(b)):
            if segments_cross(a[i], a[(i + 1) % len(a)], b[j], b[(j + 1) % len(b)]):
                return 0.0
    return min(seg_dist(a, b), seg_dist(b, a))


def segments_cross(p1: np.ndarray, p2: np.ndarray, q1: np.ndarray, q2: np.ndarray) -> bool:
    """Whether segments ``p1-p2`` and ``q1-q2`` (2D) cross at a point inside both."""
    def orient(a: np.ndarray, b: np.ndarray, c: np.ndarray) -> float:
        return float((b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]))
    d1, d2 = orient(q1, q2, p1), orient(q1, q2, p2)
    d3, d4 = orient(p1, p2, q1), orient(p1, p2, q2)
    return d1 * d2 < 0 and d3 * d4 < 0


def overlap_fraction(a: SceneObject, b: SceneObject, samples: int = 9) -> float:
    """Fraction of ``a``'s footprint inside ``b``'s (sampled on a ``samples`` x ``samples`` grid)."""
    w, _, l = a.size
    c, s = math.cos(a.yaw), math.sin(a.yaw)
    u = (np.arange(samples) + 0.5) / samples - 0.5
    uu, vv = np.meshgrid(u * l, u * w, indexing="ij")
    xy = np.stack([a.position[0] + c * uu - s * vv, a.position[1] + s * uu + c * vv], axis=-1).reshape(-1, 2)
    return float(np.mean(footprint_distance(b, xy) <= 1e-9))


class RobotView:
    """Bearing intervals and distances of objects as seen from the robot.

    Args:
        objs: The objects (world frame); methods take indices into this sequence.
        robot: ``(x, y, z, yaw)``: world position [m] and heading [rad] of the robot's x axis.
        behind_depth: How much farther [m] (centre distance) an object must be to be behind another.
        behind_overlap: Least overlap of the bearing intervals, as a fraction of the narrower one.

    Attributes (one entry per object): ``lo`` / ``hi`` bearing interval [rad] (robot frame, left
    positive), ``bearing`` of the centre [rad], ``centre`` and ``near`` (nearest footprint point)
    horizontal distances [m], ``contains`` (the robot stands inside, or the object spans half the
    view: no direction relations).
    """

    def __init__(self, objs: Sequence[SceneObject], robot: Sequence[float], behind_depth: float,
                 behind_overlap: float) -> None:
        x, y, _, yaw = robot
        self.behind_depth = behind_depth
        self.behind_overlap = behind_overlap
        self.lo = np.zeros(len(objs))
        self.hi = np.zeros(len(objs))
        self.centre = np.zeros(len(objs))
        self.near = np.zeros(len(objs))
        self.bearing = np.zeros(len(objs))
        self.contains = np.zeros(len(objs), dtype=bool)
        for n, o in enumerate(objs):
            corners = footprint(o) - (x, y)
            ang = wrap(np.arctan2(corners[:, 1], corners[:, 0]) - yaw)
            b = float(wrap(math.atan2(o.position[1] - y, o.position[0] - x) - yaw))
            rel = wrap(ang - b)  # corners relative to the centre's bearing: no wrap-around
            self.lo[n], self.hi[n] = b + rel.min(), b + rel.max()
            self.bearing[n] = b
            self.centre[n] = math.hypot(o.position[0] - x, o.position[1] - y)
            self.near[n] = float(footprint_distance(o, np.array([[x, y]]))[0])
            self.contains[n] = self.near[n] <= 0.0 or self.hi[n] - self.lo[n] >= math.pi

    def _shifted(self, a: int, b: int) -> tuple[float, float]:
        """``b``'s bearing interval moved by whole turns next to ``a``'s."""
        shift = 2 * math.pi * round((self.bearing[b] - self.bearing[a]) / (2 * math.pi))
        return self.lo[b] - shift, self.hi[b] - shift

    def overlap(self, a: int, b: int) -> float:
        """Overlap of the bearing intervals as a fraction of the narrower one."""
        blo, bhi = self._shifted(a, b)
        lo, hi = max(self.lo[a], blo), min(self.hi[a], bhi)
        narrow = max(min(self.hi[a] - self.lo[a], bhi - blo), 1e-9)
        return max(0.0, hi - lo) / narrow

    def behind(self, a: int, b: int) -> bool:
        """Whether object ``a`` is behind object ``b`` as seen from the robot."""
        if self.contains[a] or self.contains[b]:
            return False
        return (self.centre[a] - self.centre[b] >= self.behind_depth and self.near[a] > self.near[b]
                and self.overlap(a, b) >= self.behind_overlap)

    def left_of(self, a: int, b: int) -> bool:
        """Whether ``a``'s bearing interval lies wholly to the left of ``b``'s."""
        if self.contains[a] or self.contains[b]:
            return False
        return self.lo[a] > self._shifted(a, b)[1]

    def hidden_fraction(self, a: int, coverers: Sequence[int]) -> float:
        """Share of ``a``'s bearing interval covered by the union of the ``coverers``' intervals."""
        iv = []
        for b in coverers:
            blo, bhi = self._shifted(a, b)
            lo, hi = max(self.lo[a], blo), min(self.hi[a], bhi)
            if hi > lo:
                iv.append((lo, hi))
        iv.sort()
        covered, end = 0.0, -math.inf
        for lo, hi in iv:
            lo = max(lo, end)
            if hi > lo:
                covered += hi - lo
                end = hi
        return covered / max(self.hi[a] - self.lo[a], 1e-9)


__all__ = ["RobotView", "overlap_fraction", "polygon_gap", "segments_cross", "wrap"]
