"""One object's estimate from its sightings: the weighted mean position, yaw and size, and its covariance.

Pure helpers of :func:`pipeline.mapping.map_fusion.fuse`. World frame (z up) [m], yaw about +z [rad],
sizes ``(w, h, l)`` [m] (see :mod:`pipeline.scene`); sigmas from :mod:`pipeline.mapping.observation_sigma`.
"""

from __future__ import annotations

import math
from dataclasses import replace
from typing import Sequence

import numpy as np

from pipeline.mapping.observation_sigma import observation_sigma, ray_covariance
from pipeline.scene import Capture, SceneObject, Sighting, Vec3

PINNED_SIGMA = 0.03
"""1-sigma [m] of a pinned object's (or a history-less one's) place in the association gate."""


def sighting(obj: SceneObject, capture: Capture | None, used: bool = True, note: str = "",
             others: Sequence[SceneObject] = ()) -> Sighting:
    """``obj`` as seen by ``capture`` (world frame), with its sigmas (``others``: the capture's other objects)."""
    sig = observation_sigma(obj, capture, others)
    if sig.factors and not note:
        note = "sigma grown: " + ", ".join(sig.factors)
    return Sighting(capture=obj.source.capture, position=obj.position, yaw=obj.yaw, size=obj.size,
                    sigma=(sig.along, sig.across, sig.yaw), camera=sig.camera, distance=sig.distance,
                    used=used, note=note)


def sighting_cov(s: Sighting) -> np.ndarray:
    """The sighting's 3x3 position covariance [m^2] (world): along and across its viewing ray."""
    if s.camera is None:
        return np.eye(3) * s.sigma[0] ** 2
    return ray_covariance(s.position, s.camera, s.sigma[0], s.sigma[1])


def estimate(sightings: Sequence[Sighting]) -> tuple[np.ndarray, np.ndarray, float, Vec3]:
    """``(position (3,), covariance (3, 3), yaw, size)`` fused from the used sightings.

    The position is the mean weighted by ``1 / max(along, across)^2`` (a view is weighed by its weaker
    direction: an object cut on both sides is placed across the ray no better than its extent; a convex
    combination: it stays among the views even when their across-ray errors disagree, which the
    information-weighted mean of narrow ray covariances would not); its covariance (for the association
    gate) ``(sum R_k^-1)^-1``, the views' ray covariances combined: narrow across the rays it was seen
    along. The yaw is the ``1 / sigma_yaw^2`` weighted circular mean modulo pi (a box is symmetric
    under a half turn), on the heading of the best view; the size the position's weighted mean.
    """
    w = np.array([1.0 / max(s.sigma[0], s.sigma[1]) ** 2 for s in sightings])
    pos = (w[:, None] * np.array([s.position for s in sightings], dtype=np.float64)).sum(0) / w.sum()
    cov = np.linalg.inv(sum(np.linalg.inv(sighting_cov(s)) for s in sightings))
    wy = np.array([1.0 / s.sigma[2] ** 2 for s in sightings])
    c2 = float(np.sum(wy * np.cos([2 * s.yaw for s in sightings])))
    s2 = float(np.sum(wy * np.sin([2 * s.yaw for s in sightings])))
    yaw = 0.5 * math.atan2(s2, c2)
    ref = sightings[int(np.argmax(wy))].yaw  # keep the heading of the best view (not its half-turn twin)
    if math.cos(yaw - ref) < 0:
        yaw += math.pi
    yaw = math.atan2(math.sin(yaw), math.cos(yaw))
    size = tuple(float(v) for v in (w[:, None] * np.array([s.size for s in sightings])).sum(0) / w.sum())
    return pos, cov, yaw, size  # type: ignore[return-value]


def history_of(obj: SceneObject, captures: dict[str, Capture]) -> tuple[Sighting, ...]:
    """The object's history, or one sighting of the object as it stands when it has none."""
    if obj.history:
        return obj.history
    return (sighting(obj, captures.get(obj.source.capture or "")),)


def map_cov(obj: SceneObject, captures: dict[str, Capture]) -> np.ndarray:
    """The map object's position covariance [m^2] for the association gate (pinned: :data:`PINNED_SIGMA`)."""
    used = [s for s in history_of(obj, captures) if s.used]
    if obj.is_pinned or not used:
        return np.eye(3) * PINNED_SIGMA**2
    return estimate(used)[1]


def refit(obj: SceneObject, history: tuple[Sighting, ...], newest: SceneObject) -> SceneObject:
    """``obj`` re-estimated from ``history`` (its used sightings), its source and score from ``newest``."""
    used = [s for s in history if s.used]
    if not used:
        return replace(obj, history=history)
    pos, _, yaw, size = estimate(used)
    return replace(obj, position=tuple(float(v) for v in pos), yaw=yaw,  # type: ignore[arg-type]
                   size=size if not obj.size_known else obj.size, history=history,
                   score=max(obj.score, newest.score), source=newest.source, flags=())


__all__ = ["PINNED_SIGMA", "estimate", "history_of", "map_cov", "refit", "sighting", "sighting_cov"]
