"""How far to trust one observation of an object: its 1-sigma errors and why it may be useless.

Pure functions over a :class:`~pipeline.scene.SceneObject` (world frame [m], yaw about +z [rad])
and the :class:`~pipeline.scene.Capture` it came from (image size [px], camera centre [m]).

The model (until the mapping pipeline reports a per-object sigma, issue 11: an object attribute
``sigma`` [m], a number or a vector, is used as the along-ray sigma when present):

- along the camera ray ``a + b * d`` with ``d`` the camera distance [m] and ``(a, b)`` by method
  (:data:`METHOD_SIGMA`): a depth reading grows slower with distance than a size prior;
- across the ray a quarter of that (a box's image position is far better known than its depth);
- a box cut by the image border multiplies both by :data:`CUT_FACTOR` and its yaw is not trusted
  (:data:`CUT_YAW_SIGMA`); a box much shorter than the class height at that distance (occluded) too;
- yaw ``YAW_SIGMA`` by method.

:func:`degenerate` names the views that carry no usable position at all (rejected, with the reason
shown to the operator): a camera too close (the box covers the whole image, a depth reading or the
object nearer than :data:`MIN_RANGE`) and a sliver at the image border.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Sequence

import numpy as np

from pipeline.scene import Capture, SceneObject, Vec3

METHOD_SIGMA: dict[str, tuple[float, float]] = {
    "ground_truth": (0.02, 0.0),
    "manual": (0.03, 0.0),
    "depth": (0.05, 0.06),
    "fused": (0.05, 0.07),
    "geometric": (0.08, 0.12),
    "demo": (0.3, 0.1),
}
"""``(a [m], b [1])`` of the along-ray sigma ``a + b * distance`` by ``source.method``."""

DEFAULT_METHOD_SIGMA = (0.1, 0.12)
"""``(a, b)`` for a method not in :data:`METHOD_SIGMA`."""

YAW_SIGMA: dict[str, float] = {"ground_truth": 0.02, "manual": 0.05, "demo": 1.0}
"""Yaw 1-sigma [rad] by method; others get :data:`DEFAULT_YAW_SIGMA`."""

DEFAULT_YAW_SIGMA = 0.35
"""Yaw 1-sigma [rad] of a mapped (not manual) object seen whole."""

LATERAL_RATIO = 0.25
"""Across-ray sigma as a fraction of the along-ray sigma."""

CUT_FACTOR = 3.0
"""Sigma multiplier of a box cut by the image border (or occluded to under half its height)."""

CUT_YAW_SIGMA = math.pi / 2
"""Yaw 1-sigma [rad] of a cut view: its heading says nothing."""

DEFAULT_DISTANCE = 3.0
"""Camera distance [m] assumed when an observation carries none."""

BORDER_PX = 3.0
"""A box side this close to the image border [px] is cut by it."""

MIN_RANGE = 0.3
"""Nearer than this [m] a camera sees too little of an object to place it (and depth models are out
of their range)."""

WHOLE_IMAGE = 0.9
"""A box covering this fraction of both the image width and height: the camera is too close."""

SLIVER = 0.06
"""A box cut by a side border and narrower than this fraction of that image dimension is a sliver."""

OCCLUDED = 0.5
"""A box shorter than this fraction of the class height's image extent is taken as occluded."""


@dataclass(frozen=True)
class ObservationSigma:
    """The 1-sigma errors of one observation.

    Attributes:
        along: Along the camera ray [m].
        across: Across the ray (horizontal and vertical) [m].
        yaw: Heading [rad].
        distance: Camera-to-centre distance [m] used.
        camera: Camera centre [m] (world), ``None`` if unknown (isotropic then).
        cut: Whether the box is cut by the image border (or occluded).
    """

    along: float
    across: float
    yaw: float
    distance: float
    camera: Vec3 | None
    cut: bool

    def covariance(self, position: Sequence[float]) -> np.ndarray:
        """3x3 position covariance [m^2] (world): ``along`` on the camera ray, ``across`` off it."""
        if self.camera is None:
            return np.eye(3) * self.along**2
        return ray_covariance(position, self.camera, self.along, self.across)


def ray_covariance(position: Sequence[float], camera: Sequence[float], along: float, across: float) -> np.ndarray:
    """Covariance [m^2] of a point seen from ``camera``: ``along`` [m] on the ray, ``across`` off it."""
    ray = np.asarray(position, dtype=np.float64) - np.asarray(camera, dtype=np.float64)
    n = float(np.linalg.norm(ray))
    if not n > 1e-9:
        return np.eye(3) * along**2
    u = ray / n
    uu = np.outer(u, u)
    return along**2 * uu + across**2 * (np.eye(3) - uu)


def _image_size(capture: Capture | None) -> tuple[float, float] | None:
    if capture is None:
        return None
    w, h = capture.intrinsics.get("width"), capture.intrinsics.get("height")
    if not w or not h or not (math.isfinite(w) and math.isfinite(h)):
        return None
    return float(w), float(h)


def camera_distance(obj: SceneObject, capture: Capture | None) -> float | None:
    """Camera-to-centre distance [m]: from the camera-frame position, else the capture's camera centre."""
    cam = obj.source.positions.get("camera")
    if cam is not None:
        return float(math.dist(cam, (0.0, 0.0, 0.0)))
    if capture is not None and capture.camera_position is not None:
        return float(math.dist(capture.camera_position, obj.position))
    fused = obj.source.distances.get("fused")
    return None if fused is None else float(fused)


def is_cut(obj: SceneObject, capture: Capture | None) -> bool:
    """Whether the object's box touches the image border (the object continues beyond it)."""
    size = _image_size(capture)
    b = obj.source.bbox
    if size is None or b is None:
        return False
    w, h = size
    return b[0] <= BORDER_PX or b[1] <= BORDER_PX or b[2] >= w - BORDER_PX or b[3] >= h - BORDER_PX


def is_occluded(obj: SceneObject, capture: Capture | None, distance: float | None) -> bool:
    """The box is much shorter than the object's height would be at that distance (hidden behind
    something): its centre height is unreliable."""
    b, fy = obj.source.bbox, (capture.intrinsics.get("fy") if capture is not None else None)
    if b is None or not fy or distance is None or distance <= 0:
        return False
    expected = obj.size[1] * float(fy) / distance
    return (b[3] - b[1]) < OCCLUDED * expected


def _given_sigma(obj: SceneObject) -> float | None:
    """The mapping pipeline's own sigma [m] when the object carries one (issue 11), else ``None``."""
    s = getattr(obj, "sigma", None)
    if s is None:
        return None
    try:
        vals = [float(s)] if isinstance(s, (int, float)) else [float(v) for v in s]
    except (TypeError, ValueError):
        return None
    vals = [v for v in vals if math.isfinite(v) and v > 0]
    return max(vals) if vals else None


def observation_sigma(obj: SceneObject, capture: Capture | None = None) -> ObservationSigma:
    """The 1-sigma errors of ``obj`` as seen by ``capture`` (see the module docstring)."""
    d = camera_distance(obj, capture)
    dist = DEFAULT_DISTANCE if d is None or not math.isfinite(d) else d
    a, b = METHOD_SIGMA.get(obj.source.method, DEFAULT_METHOD_SIGMA)
    along = _given_sigma(obj) or (a + b * dist)
    yaw = YAW_SIGMA.get(obj.source.method, DEFAULT_YAW_SIGMA)
    cut = obj.source.method not in ("manual", "ground_truth") and (
        is_cut(obj, capture) or is_occluded(obj, capture, d))
    if cut:
        along *= CUT_FACTOR
        yaw = CUT_YAW_SIGMA
    camera = capture.camera_position if capture is not None else None
    return ObservationSigma(along, along * LATERAL_RATIO if camera is not None else along, yaw, dist,
                            None if camera is None else tuple(float(v) for v in camera), cut)  # type: ignore[arg-type]


def distance_to_box(point: Sequence[float], centre: Sequence[float], size: Sequence[float], yaw: float) -> float:
    """Euclidean distance [m] from ``point`` to the oriented box (``0`` inside it), world frame."""
    p = np.asarray(point, dtype=np.float64) - np.asarray(centre, dtype=np.float64)
    c, s = math.cos(yaw), math.sin(yaw)
    along_l = c * p[0] + s * p[1]  # along the length axis
    along_w = -s * p[0] + c * p[1]
    w, h, l = size
    out = np.array([max(abs(along_l) - l / 2, 0.0), max(abs(along_w) - w / 2, 0.0), max(abs(p[2]) - h / 2, 0.0)])
    return float(np.linalg.norm(out))


def degenerate(obj: SceneObject, capture: Capture | None) -> str | None:
    """Why this view carries no usable position (``None`` if it does): camera too close, or a sliver."""
    size = _image_size(capture)
    b = obj.source.bbox
    if size is not None and b is not None:
        w, h = size
        bw, bh = b[2] - b[0], b[3] - b[1]
        if bw >= WHOLE_IMAGE * w and bh >= WHOLE_IMAGE * h:
            return f"camera too close: the box covers the whole image ({bw:.0f}x{bh:.0f} of {w:.0f}x{h:.0f} px)"
        side_cut = b[0] <= BORDER_PX or b[2] >= w - BORDER_PX
        top_cut = b[1] <= BORDER_PX or b[3] >= h - BORDER_PX
        if side_cut and bw < SLIVER * w:
            return f"a sliver at the image border ({b[0]:.0f}-{b[2]:.0f} of {w:.0f} px wide)"
        if top_cut and bh < SLIVER * h:
            return f"a sliver at the image border ({b[1]:.0f}-{b[3]:.0f} of {h:.0f} px high)"
    depth = obj.source.distances.get("depth")
    if depth is not None and depth < MIN_RANGE:
        return f"camera too close: depth {depth:.2f} m is below the model's range ({MIN_RANGE:g} m)"
    if capture is not None and capture.camera_position is not None:
        near = distance_to_box(capture.camera_position, obj.position, obj.size, obj.yaw)
        if near < MIN_RANGE:
            return f"camera too close: {near:.2f} m from the object (under {MIN_RANGE:g} m)"
    return None
