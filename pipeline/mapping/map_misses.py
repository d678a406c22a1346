"""Objects a capture should have seen and did not: a false detection seen once does not stay in the map.

Pure helpers of :func:`pipeline.mapping.map_fusion.fuse`. World frame (z up) [m]; a capture's camera
pose is ``world <- camera`` (OpenCV optical frame, see :class:`~pipeline.scene.Capture`).

A detector's false box (a patch of floor read as a chair) becomes an object like any other: one view
cannot tell it from a real object seen once. Later captures can: when a capture's view holds the
object's centre in range (:func:`~pipeline.mapping.map_consistency.expected_in_view`), no other mapped
object stands on the line of sight to it (:func:`line_of_sight_clear`) and none of the capture's
detections matched it, the capture records a **miss** in the object's history (``used`` false, note
:data:`MISS_NOTE`). An unpinned object seen by one capture only and missed by :data:`MISSES` later
captures (one, when that capture saw it only in part) is removed, with the reason in the fusion's
report; so is one seen only in part by ``n`` captures and missed by ``n`` (two false boxes that happened
to agree, each read as an occluded object, go after two misses; an object seen whole by two captures stays). A real object seen once and then missed
twice where nothing hides it would need two missed detections in a row (the noisy simulator misses
10 % of them), and a view hidden by something unmapped still counts as a miss: hence two, not one.
"""

from __future__ import annotations

import math
from dataclasses import replace
from typing import Sequence

import numpy as np

from pipeline.mapping.map_consistency import expected_in_view
from pipeline.mapping.map_extent import half_extent, ray_interval
from pipeline.mapping.observation_sigma import CUT_YAW_SIGMA
from pipeline.scene import Capture, SceneObject, Sighting

MISS_NOTE = "in view and not detected"
"""History note of a capture that should have seen the object and did not."""

MISSES = 2
"""Misses after which an object seen whole by one capture only is removed (one per capture that saw it
when every view of it was partial: cut by the border or occluded, its centre a guess)."""

MAX_MISS_RANGE = 4.5
"""Farthest camera-to-centre distance [m] at which a capture's silence counts as a miss (the depth
model's range, :data:`~pipeline.mapping.observation_sigma.DEPTH_RANGE`: farther, a small object may go
undetected)."""


def line_of_sight_clear(camera: Sequence[float], obj: SceneObject, others: Sequence[SceneObject]) -> bool:
    """Whether the segment from ``camera`` to ``obj``'s centre meets no other object's box before ``obj``'s
    own near side."""
    ray = np.asarray(obj.position, dtype=np.float64) - np.asarray(camera, dtype=np.float64)
    dist = float(np.linalg.norm(ray))
    if not dist > 1e-9:
        return False
    u = ray / dist
    near_side = dist - half_extent(obj, u)
    for o in others:
        if o.id == obj.id:
            continue
        hit = ray_interval(camera, u, o)
        if hit is not None and hit[0] < near_side:
            return False
    return True


def _seen_by(obj: SceneObject) -> set[str]:
    return {s.capture for s in obj.history if s.used and s.capture}


def _partial_only(obj: SceneObject) -> bool:
    """Whether every used view of ``obj`` was cut or occluded (its yaw not trusted: sigma
    :data:`~pipeline.mapping.observation_sigma.CUT_YAW_SIGMA`)."""
    return all(s.sigma[2] >= CUT_YAW_SIGMA for s in obj.history if s.used)


def _misses(obj: SceneObject) -> int:
    return sum(1 for s in obj.history if not s.used and s.note == MISS_NOTE)


def record_misses(objects: list[SceneObject], captures: Sequence[Capture], seen: set[str]) -> list[str]:
    """Add a miss to each object the ``captures`` should have seen and did not (in place).

    Args:
        objects: The map after this capture's updates.
        captures: The capture(s) folded in.
        seen: Ids of the map objects any observation of these captures matched, updated or added.

    Returns:
        The ids that got a miss.
    """
    out: list[str] = []
    index = {o.id: n for n, o in enumerate(objects)}
    for cap in captures:
        if cap.camera_position is None:
            continue
        for o in expected_in_view(objects, cap):
            if o.id in seen or o.is_pinned or cap.id in {s.capture for s in o.history}:
                continue
            if math.dist(cap.camera_position, o.position) > MAX_MISS_RANGE:
                continue
            if not line_of_sight_clear(cap.camera_position, o, objects):
                continue
            ref = next((s for s in reversed(o.history) if s.used), None)
            if ref is None:
                continue
            miss = Sighting(capture=cap.id, position=o.position, yaw=o.yaw, size=o.size, sigma=ref.sigma,
                            camera=tuple(float(v) for v in cap.camera_position),  # type: ignore[arg-type]
                            distance=float(math.dist(cap.camera_position, o.position)), used=False, note=MISS_NOTE)
            objects[index[o.id]] = replace(o, history=o.history + (miss,))
            out.append(o.id)
    return out


def drop_unconfirmed(objects: list[SceneObject]) -> list[tuple[str, str]]:
    """Remove (in place) each unpinned object seen by one capture only and missed by :data:`MISSES` others
    (one when it was seen in part), and each seen only in part by ``n`` captures and missed by ``n``: the
    evidence against it outweighs the evidence for it.

    Returns:
        ``(id, reason)`` per removed object.
    """
    out: list[tuple[str, str]] = []
    keep: list[SceneObject] = []
    for o in objects:
        n, seen = _misses(o), len(_seen_by(o))
        partial = _partial_only(o)
        if not o.is_pinned and (seen == 1 or (seen > 1 and partial)) and n >= (1 if partial else MISSES) * seen:
            by = "one capture only" if seen == 1 else f"{seen} captures"
            out.append((o.id, f"seen by {by}, then in view and not detected by {n} others: removed"))
        else:
            keep.append(o)
    objects[:] = keep
    return out


__all__ = ["MISSES", "MISS_NOTE", "drop_unconfirmed", "line_of_sight_clear", "record_misses"]
