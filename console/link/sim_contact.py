"""The simulated robot's body against the hidden world: where a motion would touch an object.

The robot's body is a vertical cylinder: ``radius`` [m] around the body origin in plan and from
the origin's height up to ``height`` [m] above it (the origin is on the floor when the robot
walks). A hidden object is its oriented box (``SceneObject`` centre, ``(w, h, l)`` with ``l``
along its yaw, ``w`` across it). The body *touches* an object when the object's footprint comes
within ``radius`` of the origin in plan and their height ranges overlap.

A motion stops where the body would touch an object it is not already touching, or would come
closer to one it touches (so a robot that starts against an object can still move away). The
contact is reported as a point on the object's surface: the robot "feels" it, as a bumper would;
the object's name, class and extent are never reported (the operator has to map it).

Frames: world (z up) [m]; yaw about +z [rad].
"""

from __future__ import annotations

import math
from typing import Sequence

import numpy as np

from pipeline.scene import SceneObject

Vec3 = tuple[float, float, float]


class BodyContact:
    """Contact tests of the robot's body (a vertical cylinder) against hidden object boxes.

    Args:
        objects: The hidden world's objects (world frame).
        radius: The body's radius in plan [m] (> 0).
        height: The body's height above its origin [m] (> 0).
    """

    def __init__(self, objects: Sequence[SceneObject], radius: float, height: float) -> None:
        for name, v in (("radius", radius), ("height", height)):
            if not (isinstance(v, (int, float)) and math.isfinite(v) and v > 0):
                raise ValueError(f"body {name}: must be a positive number [m], got {v!r}")
        self.radius = float(radius)
        self.height = float(height)
        n = len(objects)
        self._centre = np.array([o.position for o in objects], dtype=np.float64).reshape(n, 3)
        size = np.array([o.size for o in objects], dtype=np.float64).reshape(n, 3)
        self._half = np.stack([size[:, 2] / 2, size[:, 0] / 2], axis=1)  # along (l), across (w)
        self._zlo = self._centre[:, 2] - size[:, 1] / 2
        self._zhi = self._centre[:, 2] + size[:, 1] / 2
        yaw = np.array([o.yaw for o in objects], dtype=np.float64)
        self._cos, self._sin = np.cos(yaw), np.sin(yaw)

    def _plan_distance(self, p: Sequence[float]) -> tuple[np.ndarray, np.ndarray]:
        """Each object's footprint distance to ``p`` in plan [m] and the nearest footprint points (N x 2)."""
        dx = float(p[0]) - self._centre[:, 0]
        dy = float(p[1]) - self._centre[:, 1]
        along = self._cos * dx + self._sin * dy
        across = -self._sin * dx + self._cos * dy
        ca = np.clip(along, -self._half[:, 0], self._half[:, 0])
        cc = np.clip(across, -self._half[:, 1], self._half[:, 1])
        dist = np.hypot(along - ca, across - cc)
        near = np.stack([self._centre[:, 0] + self._cos * ca - self._sin * cc,
                         self._centre[:, 1] + self._sin * ca + self._cos * cc], axis=1)
        return dist, near

    def _touching(self, p: Sequence[float]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        dist, near = self._plan_distance(p)
        z = float(p[2])
        overlap = (z < self._zhi - 1e-9) & (z + self.height > self._zlo + 1e-9)
        return (dist < self.radius - 1e-9) & overlap, dist, near

    def touches(self, p: Sequence[float]) -> bool:
        """Whether the body at ``p`` (world frame [m]) touches any object."""
        return bool(self._touching(p)[0].any()) if len(self._centre) else False

    def blocked(self, here: Sequence[float], there: Sequence[float]) -> Vec3 | None:
        """Where the body moving from ``here`` to ``there`` (a short step) would touch an object it
        is not touching at ``here`` (or come closer to one it touches): the contact point on the
        object's surface (world frame [m]), or ``None`` when the step is clear."""
        if not len(self._centre):
            return None
        hit, dist, near = self._touching(there)
        if not hit.any():
            return None
        was, dist0, _ = self._touching(here)
        worse = hit & (~was | (dist < dist0 - 1e-9))
        if not worse.any():
            return None
        i = int(np.flatnonzero(worse)[np.argmin(dist[worse])])
        zc = min(max(float(there[2]) + self.height / 2, float(self._zlo[i])), float(self._zhi[i]))
        return (float(near[i, 0]), float(near[i, 1]), zc)


def contact_text(point: Vec3) -> str:
    """The operator's words for a contact (no object named): ``contact with an unmapped obstacle
    ahead at (x, y, z)`` [m]."""
    return f"contact with an unmapped obstacle ahead at ({point[0]:.2f}, {point[1]:.2f}, {point[2]:.2f})"


__all__ = ["BodyContact", "contact_text"]
