"""Objects a capture should have seen and did not: a false detection does not stay in the map.

Pure helpers of :func:`pipeline.mapping.map_fusion.fuse`. World frame (z up) [m]; a capture's camera
pose is ``world <- camera`` (OpenCV optical frame, see :class:`~pipeline.scene.Capture`).

A detector's false box (a patch of floor read as a chair) becomes an object like any other: one view
cannot tell it from a real object seen once, and two false boxes of two captures may agree. Later
captures can tell: when a capture shows at least :data:`MIN_MISS_SHARE` of an object's box (in the
image, within :data:`MAX_MISS_RANGE`, no other mapped object on the line of sight:
:func:`~pipeline.mapping.map_existence.visible_share`) and none of its detections matched it, it records a
**miss** in the object's history (``used`` false, note :data:`MISS_NOTE`). The object's existence is then
weighed (:func:`~pipeline.mapping.map_existence.log_odds`, an occupancy log-odds as OctoMap's): each
detection counts for it by its score (half for a view of a part), each miss against it by how much of the
object's place that capture saw; an object whose log-odds falls below 0 is removed,
with the reason in the fusion's report ("suitcase-3: seen by 2 captures (in part), missed by 2 captures that
saw its place: removed"). Pinned and operator-placed objects (:attr:`~pipeline.scene.SceneObject.is_pinned`) and
objects with no detection in their history are never removed.

What that gives: an object seen whole once goes after two clean misses, not one (the noisy simulator misses
10 % of the detections); one seen only in part (its centre a guess) after one; two partial views that
agreed after two; a capture that shows under half of the object counts for less (a third of it: -0.9
against -2.3), and one that shows a place a mapped object hides counts nothing.
"""

from __future__ import annotations

import math
from dataclasses import replace
from typing import Mapping, Sequence

import numpy as np

from pipeline.mapping.map_existence import log_odds, visible_share
from pipeline.mapping.map_extent import half_extent, ray_interval
from pipeline.mapping.observation_sigma import CUT_YAW_SIGMA
from pipeline.scene import Capture, SceneObject, Sighting

MISS_NOTE = "in view and not detected"
"""History note of a capture that should have seen the object and did not."""

MAX_MISS_RANGE = 4.5
"""Farthest camera distance [m] of the part of an object whose absence counts (the depth model's range,
:data:`~pipeline.mapping.observation_sigma.DEPTH_RANGE`: farther, a small object may go undetected)."""

MIN_MISS_SHARE = 0.4
"""Least share of an object's box a capture must show (in view, unhidden, in range) to record a miss."""


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


def is_miss(s: Sighting) -> bool:
    """Whether the history entry is a miss (:data:`MISS_NOTE`)."""
    return not s.used and s.note == MISS_NOTE


HIDDEN_NOTE = "behind nearer objects"
"""The words of a sighting's note (:func:`~pipeline.mapping.map_estimate.sighting`, its sigma's factors) that
say its box lay mostly inside nearer objects' boxes (:data:`~pipeline.mapping.observation_sigma.HIDDEN`)."""


def is_partial(s: Sighting) -> bool:
    """Whether the view showed only part of the object: cut by the border or read as occluded (its yaw not
    trusted: sigma :data:`~pipeline.mapping.observation_sigma.CUT_YAW_SIGMA`), or mostly behind nearer
    objects of its capture (:data:`HIDDEN_NOTE`)."""
    return s.sigma[2] >= CUT_YAW_SIGMA or HIDDEN_NOTE in s.note


def record_misses(objects: list[SceneObject], captures: Sequence[Capture], seen: set[str]) -> list[str]:
    """Add a miss to each object the ``captures`` showed and did not detect (in place).

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
        for o in list(objects):
            if o.id in seen or o.is_pinned or cap.id in {s.capture for s in o.history}:
                continue
            if math.dist(cap.camera_position, o.position) - 0.5 * math.hypot(*o.size) > MAX_MISS_RANGE:
                continue
            ref = next((s for s in reversed(o.history) if s.used), None)
            if ref is None or visible_share(o, cap, objects, MAX_MISS_RANGE) < MIN_MISS_SHARE:
                continue
            miss = Sighting(capture=cap.id, position=o.position, yaw=o.yaw, size=o.size, sigma=ref.sigma,
                            camera=tuple(float(v) for v in cap.camera_position),  # type: ignore[arg-type]
                            distance=float(math.dist(cap.camera_position, o.position)), used=False, note=MISS_NOTE)
            objects[index[o.id]] = replace(o, history=o.history + (miss,))
            out.append(o.id)
    return out


def drop_unconfirmed(objects: list[SceneObject], captures: Mapping[str, Capture] | None = None,
                     judge: set[str] | None = None) -> list[tuple[str, str]]:
    """Remove (in place) each unpinned object of ``judge`` (``None``: every object) whose existence log-odds
    (:func:`~pipeline.mapping.map_existence.log_odds`) fell below 0 after a miss.

    Args:
        objects: The map.
        captures: The captures by id (their pose and intrinsics weigh each view); a capture not in it
            counts its detection whole, its miss clean.
        judge: Ids to weigh (the fusion passes those that just got a miss).

    Returns:
        ``(id, reason)`` per removed object.
    """
    caps = captures or {}
    out: list[tuple[str, str]] = []
    keep: list[SceneObject] = []
    for o in objects:
        if o.is_pinned or (judge is not None and o.id not in judge) or not any(is_miss(s) for s in o.history):
            keep.append(o)
            continue
        others = [p for p in objects if p.id != o.id]
        total, hits, _ = log_odds(o, caps, others, is_miss, is_partial, MAX_MISS_RANGE)
        if hits == 0 or total >= 0:
            keep.append(o)
            continue
        saw = {s.capture for s in o.history if s.capture and not is_miss(s)}
        missed = {s.capture for s in o.history if s.capture and is_miss(s)}
        part = " (in part)" if all(is_partial(s) for s in o.history if s.capture in saw) else ""
        by = "one capture only" if len(saw) == 1 else f"{len(saw)} captures"
        n = len(missed)
        out.append((o.id, f"seen by {by}{part}, missed by {n} capture{'s' if n > 1 else ''} that saw its place: "
                          "removed"))
    objects[:] = keep
    return out


__all__ = ["MAX_MISS_RANGE", "MIN_MISS_SHARE", "MISS_NOTE", "drop_unconfirmed", "is_miss", "is_partial",
           "line_of_sight_clear", "record_misses"]
