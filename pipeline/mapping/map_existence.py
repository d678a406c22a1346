"""Does a mapped object exist? Its detections, and the captures that saw its place and missed it, as log-odds.

Pure helpers of :mod:`pipeline.mapping.map_misses`. World frame (z up) [m]; a capture's camera pose is
``world <- camera`` (OpenCV optical frame: x right, y down, z forward; see :class:`~pipeline.scene.Capture`),
its intrinsics ``fx, fy, cx, cy, width, height`` [px]; log-odds in nats.

The rule is OctoMap's occupancy update (Hornung et al., "OctoMap: an efficient probabilistic 3D mapping
framework based on octrees", Autonomous Robots 34, 2013, eq. 2-3) applied to an object instead of a voxel:
the object's existence log-odds ``L = ln(P / (1 - P))`` starts at 0 and each capture adds the log of its
likelihood ratio (the same observation if the object exists, over if it does not).

- **A detection** adds ``score * shown * HIT``, ``HIT = ln(P_DETECT / P_FALSE)`` (:data:`HIT`, 4.5): a
  detector that finds an object in view with probability :data:`P_DETECT` and puts a false box of the
  class on a given place with probability :data:`P_FALSE`. ``score`` is the detector confidence in
  ``[0, 1]`` (a sighting keeps none: the object's, the best of its detections); ``shown`` is 1 for a view
  of the whole object and :data:`PARTIAL_WEIGHT` for one cut by the border, read as occluded or mostly
  behind nearer objects (its centre a guess from the class size; a detector's false box low in the image
  is read so).
- **A miss**, a capture that showed a share ``visible`` of the object (:func:`visible_share`) and did not
  detect it, adds ``ln(1 - P_DETECT * min(1, visible / DETECTABLE_SHARE))`` (:func:`miss_log_odds`, -2.3
  for a clean miss): no detection if the object exists, over no detection if it does not (about 1).
- The object is **removed** when ``L < 0``: more likely absent than present. With these figures one
  detection of the whole object outweighs one clean miss and not two (4.5 against 2.3 each); a view of a
  part does not outweigh one; two such views that agreed (two false boxes) do not outweigh two.

:func:`visible_share` is the share of points spread through the object's box (:func:`sample_points`) that
project into the image, lie within ``far`` of the camera and whose line of sight enters no other mapped
object's box more than :data:`~pipeline.mapping.occlusion.HIDDEN_GAP` before the object's own (an object
that overlaps another, as a false box ranged onto a real object's depth, is not hidden by it). Boxes are
solid here: a chair hides what is behind its box.
"""

from __future__ import annotations

import math
from typing import Callable, Mapping, Sequence

import numpy as np
from scipy.spatial.transform import Rotation

from pipeline.mapping.occlusion import HIDDEN_GAP
from pipeline.scene import Capture, SceneObject, Sighting

P_DETECT = 0.9
"""Probability that the detector reports an object whose whole box is in view, unhidden, in range (the
noisy simulator misses 10 % of the detections; the offline detectors' recall on the catalog's classes is of
this order at their default thresholds)."""

P_FALSE = 0.01
"""Probability that a false box of a class lands on a given object's place in one photo. The noisy simulator
makes a false box in 40 % of its photos, of one of 3 classes, over about 36 places of a box's size (the lower
two thirds of the image): 0.004; 0.01 leaves room for a real detector's false boxes, which gather on
object-like clutter, and keeps :data:`HIT` under two clean misses."""

HIT = math.log(P_DETECT / P_FALSE)
"""Log-odds of one detection of the whole object, score 1 (4.50)."""

MISS = math.log(1.0 - P_DETECT)
"""Log-odds of a capture that showed the whole object (or :data:`DETECTABLE_SHARE` of it) and did not
detect it (-2.30)."""

DETECTABLE_SHARE = 0.5
"""Share of an object in view from which a detector finds it as well as the whole object (detection
benchmarks count partly occluded objects as detectable: KITTI's "moderate" difficulty); with less in view
the chance of finding it falls in proportion."""

PARTIAL_WEIGHT = 0.5
"""Weight of a detection whose view showed only part of the object: half the evidence."""

GRID = (-1.0 / 3.0, 0.0, 1.0 / 3.0)
"""Sample points per box axis, as fractions of the size (the centres of a 3 x 3 x 3 split of the box)."""

NEAR = 0.3
"""Nearest camera depth [m] at which a point counts as in view (the depth models' minimum range)."""


def sample_points(obj: SceneObject) -> np.ndarray:
    """``(27, 3)`` world points spread through ``obj``'s box (see :data:`GRID`)."""
    w, h, l = obj.size
    c, s = math.cos(obj.yaw), math.sin(obj.yaw)
    grid = np.array([(a, b, k) for a in GRID for b in GRID for k in GRID])  # along length, width, up
    length, width = np.array([c, s, 0.0]) * l, np.array([-s, c, 0.0]) * w
    up = np.array([0.0, 0.0, h])
    return np.asarray(obj.position, dtype=np.float64) + grid[:, :1] * length + grid[:, 1:2] * width + grid[:, 2:] * up


def _entry(camera: np.ndarray, points: np.ndarray, box: SceneObject) -> np.ndarray:
    """``(N,)``: where the segment from ``camera`` to each point enters ``box`` (``t`` in ``[0, 1]`` along it,
    0 when the camera is inside; ``inf`` when it misses the box)."""
    w, h, l = box.size
    c, s = math.cos(box.yaw), math.sin(box.yaw)
    axes = np.array([[c, s, 0.0], [-s, c, 0.0], [0.0, 0.0, 1.0]])
    half = np.array([l / 2, w / 2, h / 2])
    o = axes @ (camera - np.asarray(box.position, dtype=np.float64))
    d = (points - camera) @ axes.T  # segment directions in the box frame
    d = np.where(np.abs(d) < 1e-12, 1e-12, d)
    t1, t2 = (-half - o) / d, (half - o) / d
    t_in = np.maximum(np.minimum(t1, t2).max(axis=1), 0.0)
    t_out = np.maximum(t1, t2).min(axis=1)
    return np.where(t_out >= t_in, t_in, np.inf)


def visible_share(obj: SceneObject, capture: Capture, others: Sequence[SceneObject],
                  far: float | None = None, gap: float = HIDDEN_GAP) -> float:
    """Share ``[0, 1]`` of ``obj``'s box the ``capture`` shows: of its :func:`sample_points`, those in the
    image at depth :data:`NEAR` or more, within ``far`` [m] of the camera (``None``: any distance) and whose
    line of sight enters no other object of ``others`` (world frame) more than ``gap`` [m] before it enters
    ``obj``'s box. 0 without the capture's pose or intrinsics."""
    intr = capture.intrinsics
    if capture.camera_position is None or capture.camera_quaternion is None or not all(
            k in intr for k in ("fx", "fy", "cx", "cy", "width", "height")):
        return 0.0
    cam = np.asarray(capture.camera_position, dtype=np.float64)
    pts = sample_points(obj)
    p = (pts - cam) @ Rotation.from_quat(capture.camera_quaternion).as_matrix()  # camera frame (R^T x)
    z = np.maximum(p[:, 2], 1e-9)
    u, v = intr["fx"] * p[:, 0] / z + intr["cx"], intr["fy"] * p[:, 1] / z + intr["cy"]
    ok = (p[:, 2] >= NEAR) & (u >= 0) & (u < intr["width"]) & (v >= 0) & (v < intr["height"])
    length = np.linalg.norm(pts - cam, axis=1)
    if far is not None:
        ok &= length <= far
    reach = float(length.max())
    own = _entry(cam, pts, obj) * length - gap  # [m]: a nearer object must begin before this to hide a point
    for o in others:
        if not ok.any():
            break
        if o.id == obj.id or math.dist(o.position, cam) - 0.5 * math.hypot(*o.size) > reach:
            continue
        ok &= _entry(cam, pts, o) * length >= own
    return float(ok.mean())


def miss_log_odds(visible: float) -> float:
    """Log-odds [nats] of a capture that showed a share ``visible`` (``[0, 1]``) of the object and did not
    detect it: ``ln(1 - P_DETECT * min(1, visible / DETECTABLE_SHARE))``."""
    return math.log(1.0 - P_DETECT * min(max(visible, 0.0) / DETECTABLE_SHARE, 1.0))


def detection_log_odds(score: float, shown: float) -> float:
    """Log-odds [nats] of a detection with confidence ``score`` (NaN: 1) whose view showed ``shown``
    (``[0, 1]``) of the object."""
    s = min(max(score, 0.0), 1.0) if math.isfinite(score) else 1.0
    return s * min(max(shown, 0.0), 1.0) * HIT


def log_odds(obj: SceneObject, captures: Mapping[str, Capture], others: Sequence[SceneObject],
             is_miss: Callable[[Sighting], bool], is_partial: Callable[[Sighting], bool],
             far: float | None = None) -> tuple[float, int, int]:
    """``obj``'s existence log-odds [nats] from its history, with ``(detections, misses)`` counted.

    Every sighting with a capture is a detection (used or not: a view that joined it by its extent, one
    rejected as too close, still saw something there; one per capture, its best) unless ``is_miss``;
    ``is_partial`` tells a view of a part. A miss's visible share is taken with ``others`` (the map now,
    within ``far`` [m]) and its capture in ``captures`` (unknown: a clean miss).
    """
    best: dict[str, float] = {}
    total, misses = 0.0, 0
    for s in obj.history:
        if not s.capture:
            continue
        if is_miss(s):
            cap = captures.get(s.capture)
            misses += 1
            total += miss_log_odds(1.0 if cap is None else visible_share(obj, cap, others, far))
            continue
        weight = detection_log_odds(obj.score, PARTIAL_WEIGHT if is_partial(s) else 1.0)
        best[s.capture] = max(best.get(s.capture, 0.0), weight)
    return total + sum(best.values()), len(best), misses


__all__ = ["DETECTABLE_SHARE", "HIT", "MISS", "PARTIAL_WEIGHT", "P_DETECT", "P_FALSE", "detection_log_odds", "log_odds",
           "miss_log_odds", "sample_points", "visible_share"]
