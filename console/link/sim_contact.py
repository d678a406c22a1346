"""The simulated robot's body against the hidden world: where a motion would touch an object.

The robot's body is a vertical cylinder: ``radius`` [m] around the body origin in plan and from
the origin's height up to ``height`` [m] above it (the origin is on the ground when the robot
walks: the floor or a top face it stands on). A hidden object is its oriented box (``SceneObject``
centre, ``(w, h, l)`` with ``l`` along its yaw, ``w`` across it). The body *touches* an object when the object's footprint comes
within ``radius`` of the origin in plan and their height ranges overlap.

The room's shell (the world file's ``room``: walls at its ``x`` and ``y`` bounds, the ceiling at its
top) is felt the same way: the body touches a wall when the wall comes within ``radius`` of the
origin in plan, the ceiling when the body's top (origin + ``height``) reaches it; leaving the room
is touching its wall. The floor is no contact (the robot stands on it).

A vertical descent that meets an object's **top face** under the body is no obstacle "ahead": the
robot touches down on it (:meth:`BodyContact.top_below`), as a landing gear does, when the face holds
the body's centre and is at least the body's width (``2 * radius``) on its shorter side; otherwise
it stops on the face's height and says why ("contact below at (x, y, z): too small to stand on").
The world's boxes are upright (yaw only), so their top faces are level: none is too steep.

A walking body follows the ground under it (:meth:`BodyContact.ground_under`): it stands on the highest
top face under its footprint that it can step onto (at most :data:`STEP_UP` above its feet), else on
the floor. It steps down any drop (off the sports mat, off a table it landed on); a face taller than
:data:`STEP_UP` is not climbed: the body walks into its side ("contact ... ahead").

A motion stops where the body would touch an object or a wall it is not already touching, or would
come closer to one it touches (so a robot that starts against one can still move away). The
contact is reported as a point on the surface: the robot "feels" it, as a bumper would; the
object's name, class and extent are never reported (the operator has to map it), and a wall is
reported in the same words (a bumper cannot tell a wall from a box).

Frames: world (z up) [m]; yaw about +z [rad].
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Sequence

import numpy as np

from pipeline.scene import SceneObject

Vec3 = tuple[float, float, float]

# [m] The highest ledge a walking body steps up onto. Chosen, not measured: a legged robot of this
# size (0.45 m tall) steps over a door sill, a cable duct or a mat (0.02-0.05 m), while a stair riser
# (about 0.17 m, the usual building-code limit) is left to flight; 0.10 m sits between them.
STEP_UP = 0.10


@dataclass(frozen=True)
class Touchdown:
    """Where a vertical descent meets the first top face under the body (world frame [m]).

    Attributes:
        height: The face's height (world z) [m]: the body's origin rests there.
        point: The contact point on the face (under the body's centre, or the face's nearest point).
        why: Why the body cannot stand on the face (``too small to stand on ...``), ``""`` when it can.
    """

    height: float
    point: Vec3
    why: str


class BodyContact:
    """Contact tests of the robot's body (a vertical cylinder) against hidden object boxes.

    Args:
        objects: The hidden world's objects (world frame).
        radius: The body's radius in plan [m] (> 0).
        height: The body's height above its origin [m] (> 0).
        room: The room's shell ``(min, max)`` corners [m] (world frame), or ``None`` (no walls).
    """

    def __init__(self, objects: Sequence[SceneObject], radius: float, height: float,
                 room: tuple[Sequence[float], Sequence[float]] | None = None) -> None:
        for name, v in (("radius", radius), ("height", height)):
            if not (isinstance(v, (int, float)) and math.isfinite(v) and v > 0):
                raise ValueError(f"body {name}: must be a positive number [m], got {v!r}")
        self.radius = float(radius)
        self.height = float(height)
        self.room: tuple[np.ndarray, np.ndarray] | None = None
        if room is not None:
            lo, hi = (np.asarray(c, dtype=np.float64).reshape(-1) for c in room)
            if lo.shape != (3,) or hi.shape != (3,) or not (np.all(np.isfinite(lo)) and np.all(np.isfinite(hi))):
                raise ValueError(f"room: must be two corners of 3 finite numbers [m], got {room!r}")
            if not np.all(hi > lo):
                raise ValueError(f"room: max {tuple(hi)} must exceed min {tuple(lo)} on every axis")
            self.room = (lo, hi)
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
        """Whether the body at ``p`` (world frame [m]) touches any object (walls: :meth:`touches_wall`)."""
        return bool(self._touching(p)[0].any()) if len(self._centre) else False

    def top_below(self, p: Sequence[float], z_to: float) -> Touchdown | None:
        """The first top face that the body met by descending straight down from ``p`` to height ``z_to``
        (world frame [m]): the highest face under the body's footprint between the body's bottom at ``p``
        and ``z_to``, or ``None`` (nothing under it: it reaches ``z_to``).

        The body stands on it when the face holds the body's centre (plan distance 0) and is at least
        ``2 * radius`` [m] on its shorter side (the landing gear's width); else :attr:`Touchdown.why` says
        why not."""
        if not len(self._centre):
            return None
        dist, near = self._plan_distance(p)
        z = float(p[2])
        under = (dist < self.radius - 1e-9) & (self._zhi <= z + 1e-9) & (self._zhi > float(z_to) + 1e-9)
        if not under.any():
            return None
        i = int(np.flatnonzero(under)[np.argmax(self._zhi[under])])
        top = float(self._zhi[i])
        point = (float(near[i, 0]), float(near[i, 1]), top)
        short = 2 * float(min(self._half[i]))
        why = ""
        if dist[i] > 1e-9:
            why = "the robot's centre is beyond the edge of the surface under it"
        elif short < 2 * self.radius - 1e-9:
            why = f"the surface under the robot is too small to stand on ({short:.2f} m wide)"
        return Touchdown(top, point, why)

    def ground_under(self, p: Sequence[float], floor: float, step_up: float = STEP_UP) -> float:
        """The height [m] (world z) a walking body's origin stands at with its centre at ``p`` (x, y;
        ``p[2]`` is its feet's height now): the highest top face under the footprint (plan distance
        < ``radius``) no higher than ``p[2] + step_up``, or ``floor`` when there is none. A drop is
        stepped down whatever its height; a taller face is the body's contact ahead (:meth:`blocked`)."""
        if not len(self._centre):
            return float(floor)
        dist, _ = self._plan_distance(p)
        ok = (dist < self.radius - 1e-9) & (self._zhi <= float(p[2]) + step_up + 1e-9) & (self._zhi > floor)
        return float(self._zhi[ok].max()) if ok.any() else float(floor)

    def _wall_gaps(self, p: Sequence[float]) -> np.ndarray:
        """Free space [m] between the body at ``p`` and each wall (x min, x max, y min, y max) and the
        ceiling; negative: the body crosses it."""
        assert self.room is not None
        lo, hi = self.room
        x, y, z = (float(v) for v in p[:3])
        r = self.radius
        return np.array([x - lo[0] - r, hi[0] - x - r, y - lo[1] - r, hi[1] - y - r, hi[2] - z - self.height])

    def touches_wall(self, p: Sequence[float]) -> bool:
        """Whether the body at ``p`` (world frame [m]) touches a wall or the ceiling of the room."""
        return self.room is not None and bool(np.any(self._wall_gaps(p) < -1e-9))

    def wall_blocked(self, here: Sequence[float], there: Sequence[float]) -> Vec3 | None:
        """Where the body moving from ``here`` to ``there`` would touch a wall (or the ceiling) it is
        not touching at ``here``, or come closer to one it touches: the point on the wall (world frame
        [m]), or ``None``."""
        if self.room is None:
            return None
        gap, gap0 = self._wall_gaps(there), self._wall_gaps(here)
        worse = (gap < -1e-9) & ((gap0 >= -1e-9) | (gap < gap0 - 1e-9))
        if not worse.any():
            return None
        lo, hi = self.room
        i = int(np.flatnonzero(worse)[np.argmin(gap[worse])])
        x = min(max(float(there[0]), lo[0]), hi[0])
        y = min(max(float(there[1]), lo[1]), hi[1])
        zc = min(max(float(there[2]) + self.height / 2, lo[2]), hi[2])
        if i < 2:
            return (float(lo[0] if i == 0 else hi[0]), y, zc)
        if i < 4:
            return (x, float(lo[1] if i == 2 else hi[1]), zc)
        return (x, y, float(hi[2]))

    def blocked(self, here: Sequence[float], there: Sequence[float]) -> Vec3 | None:
        """Where the body moving from ``here`` to ``there`` (a short step) would touch an object or a
        wall it is not touching at ``here`` (or come closer to one it touches): the contact point on
        the surface (world frame [m]), or ``None`` when the step is clear."""
        if not len(self._centre):
            return self.wall_blocked(here, there)
        hit, dist, near = self._touching(there)
        if not hit.any():
            return self.wall_blocked(here, there)
        was, dist0, _ = self._touching(here)
        worse = hit & (~was | (dist < dist0 - 1e-9))
        if not worse.any():
            return self.wall_blocked(here, there)
        i = int(np.flatnonzero(worse)[np.argmin(dist[worse])])
        zc = min(max(float(there[2]) + self.height / 2, float(self._zlo[i])), float(self._zhi[i]))
        return (float(near[i, 0]), float(near[i, 1]), zc)


def contact_text(point: Vec3) -> str:
    """The operator's words for a contact (no object named): ``contact with an unmapped obstacle
    ahead at (x, y, z)`` [m]."""
    return f"contact with an unmapped obstacle ahead at ({point[0]:.2f}, {point[1]:.2f}, {point[2]:.2f})"


def contact_below_text(point: Vec3, why: str) -> str:
    """The operator's words for a descent stopped on a face it cannot stand on: ``contact below at
    (x, y, z): <why>`` [m] (no object named)."""
    return f"contact below at ({point[0]:.2f}, {point[1]:.2f}, {point[2]:.2f}): {why}"


__all__ = ["STEP_UP", "BodyContact", "Touchdown", "contact_below_text", "contact_text"]
