"""How far a mapped object may really be from where the map puts it: the extra margin the planner keeps.

A mapped box is an estimate. The map fusion (:mod:`pipeline.mapping.map_fusion`) keeps each object's
sightings with their 1-sigma errors (:class:`pipeline.scene.Sighting`: along and across the camera ray
[m], yaw [rad]); the planner keeps the robot's radius from the box **grown by** :func:`object_margin`,
so that the body also clears the object where it probably is, not only where it was mapped.

The margin (horizontal, world frame [m]) is ``min(MARGIN_CAP, K_SIGMA * s)`` with

- ``s = sqrt(sigma_xy^2 + (r * sigma_yaw)^2)``: the horizontal 1-sigma displacement of the box's
  farthest footprint corner, ``sigma_xy`` the centre's (:func:`position_sigma`), ``sigma_yaw`` the
  heading's (:func:`yaw_sigma`, the same inverse-variance fusion) and ``r`` the footprint's half
  diagonal (a heading error ``d`` moves a point ``r`` from the centre by ``r * d``, small angles);
- ``K_SIGMA = 2``: the chance-constraint back-off of a Gaussian obstacle position. Keeping a distance
  ``K * sigma`` beyond the nominal obstacle bounds the chance of entering the true one, per obstacle
  face, by ``1 - Phi(K)`` (Blackmore, Ono and Williams, "Chance-constrained optimal path planning with
  obstacles", IEEE Trans. Robotics 27(6), 2011: the linear constraint ``a^T x <= b`` holds with probability
  ``1 - delta`` when ``b - a^T mu >= sqrt(2 a^T Sigma a) erfinv(1 - 2 delta)``, i.e. ``Phi^-1(1 - delta)``
  sigmas along ``a``): 2.3 % for ``K = 2``;
- ``MARGIN_CAP = 0.25`` m: beyond it the object is reported as uncertain (the scene graph's
  ``SIGMA_WARN``: "position uncertain by about ...") and should be looked at again; a larger margin
  would close most gaps the robot fits (a 1.3 m gap leaves the 0.7 m robot 0.3 m).

Objects with no used sighting (hand-made scene files, objects loaded without history) and pinned ones
(the operator placed or confirmed them) get no margin: their place is taken as exact.
"""

from __future__ import annotations

import math
from typing import Sequence

from pipeline.scene import SceneObject

K_SIGMA = 2.0
"""Sigmas of a mapped object's position kept beyond its box (see the module docstring for the source)."""

MARGIN_CAP = 0.25
"""Largest margin [m] added for a mapped object's uncertainty."""


def _used(o: SceneObject) -> list:
    return [h for h in getattr(o, "history", ()) if h.used]


def position_sigma(o: SceneObject) -> float | None:
    """Horizontal 1-sigma position error [m] of a mapped object: the inverse-variance fusion of
    its used sightings' larger horizontal sigma (ray directions ignored); ``None`` without history."""
    used = _used(o)
    if not used:
        return None
    info = sum(1.0 / max(h.sigma[0], h.sigma[1], 1e-9) ** 2 for h in used)
    return math.sqrt(1.0 / info)


def yaw_sigma(o: SceneObject) -> float | None:
    """1-sigma heading error [rad] of a mapped object, fused like :func:`position_sigma`; ``None``
    without history."""
    used = _used(o)
    if not used:
        return None
    info = sum(1.0 / max(h.sigma[2], 1e-9) ** 2 for h in used)
    return math.sqrt(1.0 / info)


def object_margin(o: SceneObject) -> float:
    """The margin [m] the planner keeps around ``o``'s box beyond the robot's radius for where it may
    really be (module docstring); 0 for pinned objects and objects without history."""
    if getattr(o, "is_pinned", False):
        return 0.0
    s_xy, s_yaw = position_sigma(o), yaw_sigma(o)
    if s_xy is None or s_yaw is None:
        return 0.0
    r = math.hypot(float(o.size[0]), float(o.size[2])) / 2
    s = math.hypot(s_xy, r * min(s_yaw, math.pi / 2))
    return min(MARGIN_CAP, K_SIGMA * s)


def margins(objects: Sequence[SceneObject]) -> list[float]:
    """:func:`object_margin` of each object [m], in order."""
    return [object_margin(o) for o in objects]


__all__ = ["K_SIGMA", "MARGIN_CAP", "margins", "object_margin", "position_sigma", "yaw_sigma"]
