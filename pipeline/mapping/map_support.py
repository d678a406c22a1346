"""What holds an object up: floor-standing classes rest on the floor or on another object.

World frame, z up, the floor at ``z = 0`` [m]; a box centre is ``h / 2`` above its bottom. Pure
functions used by :mod:`pipeline.mapping.map_fusion` after every fusion:

- a *floor-standing* class (:data:`FLOOR_STANDING`, catalog class names) whose bottom is more than
  :data:`SUPPORT_TOLERANCE` off the floor is put on the object under it when one is mapped there
  (its footprint overlaps and its top is within :data:`SUPPORT_REACH` of the bottom: a monitor on a
  desk, a box on a box), else on the floor (``z = h / 2``); the correction is flagged; one resting on its
  support within the tolerance is set on it exactly, unflagged (a stack's rows add up: a box 0.05 m high
  lifts every box on it);
- :func:`settle` does this for the objects a capture touched and for the objects stacked on them
  (lowest first), so a box that moved takes the boxes on it along;
- a *stackable* class (:data:`STACKABLE`: boxes, cases) may also stand on things that were not
  mapped (the lower boxes of a stack hidden behind another one), so only a buried estimate (bottom
  below the floor) is corrected when nothing supports it;
- other classes (a cup, a laptop) are left where the evidence puts them.
"""

from __future__ import annotations

import math
from dataclasses import replace
from typing import Sequence

import cv2
import numpy as np

from pipeline.scene import SceneObject

SUPPORT_TOLERANCE = 0.05
"""A bottom this close to its support [m] is resting on it (no correction)."""

SUPPORT_REACH = 0.15
"""A bottom within this of another object's top [m] (footprints overlapping) stands on it."""

MIN_SUPPORT_OVERLAP = 0.3
"""Smallest footprint overlap (intersection over the smaller footprint) of a support."""

FLOOR_ONLY: frozenset[str] = frozenset({
    "desk", "office_chair", "office_cabinet", "sports_mat", "robot_dog", "table", "chair", "stool", "sofa",
    "bench", "bed", "nightstand", "dresser", "cabinet", "shelf", "door", "refrigerator", "toilet", "sink",
    "bathtub", "trash_bin", "plant", "ladder", "barrel", "traffic_cone", "fire_hydrant", "person", "bicycle",
    "motorcycle", "car", "van", "truck", "bus", "tree",
})
"""Catalog classes that stand on the floor (or on a mapped object), never in mid-air."""

STACKABLE: frozenset[str] = frozenset({"cardboard_box", "suitcase", "compressor", "pallet", "rock", "debris_pile"})
"""Floor-standing classes that are often stacked on things the camera did not see."""

FLOOR_STANDING: frozenset[str] = FLOOR_ONLY | STACKABLE
"""Every class that rests on a support."""


def footprint(obj: SceneObject) -> np.ndarray:
    """The four corners ``(4, 2)`` [m] of the object's footprint on the floor (world x, y)."""
    w, _, l = obj.size
    c, s = math.cos(obj.yaw), math.sin(obj.yaw)
    axis_l, axis_w = np.array([c, s]) * (l / 2), np.array([-s, c]) * (w / 2)
    ctr = np.array(obj.position[:2], dtype=np.float64)
    return np.array([ctr + axis_l + axis_w, ctr - axis_l + axis_w, ctr - axis_l - axis_w, ctr + axis_l - axis_w])


def footprint_overlap(a: SceneObject, b: SceneObject) -> float:
    """Intersection of the two footprints over the smaller one, in ``[0, 1]``."""
    pa, pb = footprint(a).astype(np.float32), footprint(b).astype(np.float32)
    area, _ = cv2.intersectConvexConvex(pa, pb)
    smaller = min(a.size[0] * a.size[2], b.size[0] * b.size[2])
    return float(max(0.0, min(1.0, area / smaller))) if smaller > 0 else 0.0


def vertical_overlap(a: SceneObject, b: SceneObject) -> float:
    """Overlap of the two height ranges over the shorter one, in ``[0, 1]``."""
    lo = max(a.position[2] - a.size[1] / 2, b.position[2] - b.size[1] / 2)
    hi = min(a.position[2] + a.size[1] / 2, b.position[2] + b.size[1] / 2)
    shorter = min(a.size[1], b.size[1])
    return float(max(0.0, min(1.0, (hi - lo) / shorter))) if shorter > 0 else 0.0


def supported_z(obj: SceneObject, others: Sequence[SceneObject]) -> tuple[float, str] | None:
    """Where ``obj`` should stand: ``(centre z [m], why)``, or ``None`` to leave it as it is.

    ``others`` are the map's other objects (world frame), already resting where they should. Within
    :data:`SUPPORT_TOLERANCE` of its support (a mapped object's top; the floor when it is buried or of a
    :data:`FLOOR_ONLY` class) the object is set on it exactly and ``why`` is empty (not a correction to
    flag); beyond it ``why`` says what was corrected.
    """
    if obj.label not in FLOOR_STANDING:
        return None
    h = obj.size[1]
    bottom = obj.position[2] - h / 2
    best: tuple[float, SceneObject] | None = None
    reach = math.hypot(obj.size[0], obj.size[2]) / 2
    for o in others:
        if o.id == obj.id:
            continue
        top = o.position[2] + o.size[1] / 2
        gap = abs(bottom - top)
        if top > SUPPORT_TOLERANCE and gap <= SUPPORT_REACH and _near(obj, o, reach) \
                and footprint_overlap(obj, o) >= MIN_SUPPORT_OVERLAP:
            if best is None or gap < best[0]:
                best = (gap, o)
    if best is not None:
        gap, o = best
        top = o.position[2] + o.size[1] / 2
        if gap <= SUPPORT_TOLERANCE:
            return (top + h / 2, "") if gap > 1e-9 else None
        return top + h / 2, f"set on {o.id} (its bottom was {bottom - top:+.2f} m from that top)"
    if not (bottom < 0 or obj.label in FLOOR_ONLY) or abs(bottom) <= 1e-9:
        return None
    if abs(bottom) <= SUPPORT_TOLERANCE and obj.position[2] >= 0:  # a centre under the floor: more than half buried
        return h / 2, ""
    if bottom < 0:
        return h / 2, f"buried {-bottom:.2f} m below the floor: set on the floor (z = h/2)"
    return h / 2, f"floating {bottom:.2f} m above the floor: set on the floor (z = h/2)"


def settle(objects: list[SceneObject], touched: set[str]) -> list[tuple[str, str]]:
    """Put the touched floor-standing objects and the objects stacked on them on their support, in place.

    ``objects``: the map (world frame, z up [m]), changed in place; ``touched``: the ids a capture updated or
    added. An object (floor-standing, not pinned) stands on a settled one when their footprints overlap
    (:data:`MIN_SUPPORT_OVERLAP`) and its centre is higher; it is settled too, and so on up the stack.
    Lowest bottom first, each by :func:`supported_z` against the map as it stands; a correction with a
    reason is flagged on the object (``flags``) and returned as ``(id, why)``; pinned objects never move.
    """
    chosen = {o.id for o in objects if o.id in touched and not o.is_pinned}
    queue = [o for o in objects if o.id in chosen]
    while queue:  # up the stacks: what stands on a settled object
        b = queue.pop()
        reach = math.hypot(b.size[0], b.size[2]) / 2
        for o in objects:
            if o.id in chosen or o.is_pinned or o.label not in FLOOR_STANDING or o.position[2] <= b.position[2]:
                continue
            if _near(b, o, reach) and footprint_overlap(o, b) >= MIN_SUPPORT_OVERLAP:
                chosen.add(o.id)
                queue.append(o)
    out: list[tuple[str, str]] = []
    order = sorted((n for n, o in enumerate(objects) if o.id in chosen),
                   key=lambda n: objects[n].position[2] - objects[n].size[1] / 2)
    for n in order:
        o = objects[n]
        fix = supported_z(o, objects)
        if fix is None:
            continue
        z, what = fix
        objects[n] = replace(o, position=(o.position[0], o.position[1], z), flags=o.flags + ((what,) if what else ()))
        if what:
            out.append((o.id, what))
    return out


def _near(a: SceneObject, b: SceneObject, reach_a: float) -> bool:
    """Whether the footprints may overlap: centres (x, y) within both half-diagonals (``reach_a``: ``a``'s)."""
    return math.dist(a.position[:2], b.position[:2]) <= reach_a + math.hypot(b.size[0], b.size[2]) / 2 + 1e-9
