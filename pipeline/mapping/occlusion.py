"""Which part of an object a photo shows: its camera distance, and how much nearer objects hide it.

Pure functions used by :mod:`pipeline.mapping.observation_sigma` (which re-exports them). An object's
``source.bbox`` is its image box ``(x1, y1, x2, y2)`` [px] in its capture; positions are world frame [m]
(the capture's camera centre, or the object's camera-frame position when the mapper kept it).
"""

from __future__ import annotations

import math
from typing import Sequence

from pipeline.scene import Capture, SceneObject

HIDDEN_GAP = 0.3
"""Another object is nearer when its camera distance is smaller by more than this [m]."""

TOUCH_PX = 6.0
"""A nearer object's image box this close [px] to a side of this one hides that side (:func:`occluded_sides`)."""


def camera_distance(obj: SceneObject, capture: Capture | None) -> float | None:
    """Camera-to-centre distance [m]: from the camera-frame position, else the capture's camera centre."""
    cam = obj.source.positions.get("camera")
    if cam is not None:
        return float(math.dist(cam, (0.0, 0.0, 0.0)))
    if capture is not None and capture.camera_position is not None:
        return float(math.dist(capture.camera_position, obj.position))
    fused = obj.source.distances.get("fused")
    return None if fused is None else float(fused)


def hidden_share(obj: SceneObject, capture: Capture | None, others: Sequence[SceneObject]) -> float:
    """Share of the object's box [0, 1] inside the boxes of nearer objects of the same capture
    (nearer by more than :data:`HIDDEN_GAP` along their camera distance); 0 when unknown."""
    b = obj.source.bbox
    d = camera_distance(obj, capture)
    if b is None or d is None or not others:
        return 0.0
    x0, y0, x1, y1 = (float(v) for v in b)
    if x1 <= x0 or y1 <= y0:
        return 0.0
    rects = []
    for o in others:
        ob = o.source.bbox
        if o is obj or ob is None or o.source.capture != obj.source.capture or o.label == obj.label:
            continue
        od = camera_distance(o, capture)
        if od is None or od >= d - HIDDEN_GAP:
            continue
        rx0, ry0, rx1, ry1 = max(x0, ob[0]), max(y0, ob[1]), min(x1, ob[2]), min(y1, ob[3])
        if rx1 > rx0 and ry1 > ry0:
            rects.append((rx0, ry0, rx1, ry1))
    if not rects:
        return 0.0
    xs = sorted({x0, x1, *(r[0] for r in rects), *(r[2] for r in rects)})
    ys = sorted({y0, y1, *(r[1] for r in rects), *(r[3] for r in rects)})
    covered = 0.0  # the union's area on the grid of the rectangles' edges
    for xa, xb in zip(xs, xs[1:]):
        for ya, yb in zip(ys, ys[1:]):
            mx, my = (xa + xb) / 2, (ya + yb) / 2
            if any(r[0] <= mx <= r[2] and r[1] <= my <= r[3] for r in rects):
                covered += (xb - xa) * (yb - ya)
    return min(1.0, covered / ((x1 - x0) * (y1 - y0)))


def occluded_sides(obj: SceneObject, capture: Capture | None, others: Sequence[SceneObject]) -> int:
    """How many of the box's left and right sides (0-2) a nearer object of the same capture hides: its box
    (nearer by more than :data:`HIDDEN_GAP`, over at least half this box's height) reaches to within
    :data:`TOUCH_PX` of that side from outside. Seen along a line of boxes, each box shows only the part
    its nearer neighbour leaves: its image box ends where that neighbour begins, so its centre across the
    ray is known no better than its extent. 0 when unknown."""
    b = obj.source.bbox
    d = camera_distance(obj, capture)
    if b is None or d is None or not others:
        return 0
    x0, y0, x1, y1 = (float(v) for v in b)
    left = right = False
    for o in others:
        ob = o.source.bbox
        if o is obj or ob is None or o.source.capture != obj.source.capture or o.label != obj.label:
            continue
        od = camera_distance(o, capture)
        if od is None or od >= d - HIDDEN_GAP or min(y1, ob[3]) - max(y0, ob[1]) < 0.5 * (y1 - y0):
            continue
        left |= ob[0] - TOUCH_PX <= x0 <= ob[2] + TOUCH_PX and ob[2] < x1
        right |= ob[0] - TOUCH_PX <= x1 <= ob[2] + TOUCH_PX and ob[0] > x0
    return int(left) + int(right)


__all__ = ["HIDDEN_GAP", "TOUCH_PX", "camera_distance", "hidden_share", "occluded_sides"]
