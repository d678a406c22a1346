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

What a capture can range well grows the along-ray sigma further (factors multiply). Each constant was
fitted on the simulator tour (``bench/sim_sigma_fit.py``: the 629 observations of the 20 captures of
``bench/sim_tour.py --extended``, with and without perception noise, matched to the true objects; a
median regression of ``log(|along-ray error| / sigma)`` on the conditions, the cut factor included in
``sigma``), not set per case:

- **near** (:data:`NEAR_FACTOR` when the camera is nearer than :data:`NEAR_RANGE` to the object's box):
  the object fills the view and its far side is unseen; depth sensors are blind there;
- **hidden** (:data:`HIDDEN_FACTOR` when more than :data:`HIDDEN` of the box lies inside boxes of the
  same capture's nearer objects of another class): only part of the object is seen, so its centre is
  guessed from the class size;
- **beyond the depth model's range** (``distance / DEPTH_RANGE`` beyond :data:`DEPTH_RANGE`, depth from a
  model only; the simulator's rendered depth has no range limit, so the tour cannot fit this one): the
  relative error of a depth model grows beyond what its training sensor measured;
- **cut on two or more sides** (the object is wider than the view): the across-ray sigma is at least
  the object's largest horizontal size over ``2 sqrt(3)`` (the visible part's centre is anywhere within
  that extent: a uniform spread), and the fusion weighs a view by its larger sigma;
- **the object's own extent across the ray**: the across-ray sigma of a view of the whole object is at
  least its largest horizontal size times :data:`FACE_SPREAD` (a box's image centre is its visible faces'
  centre);
- **a side hidden by a nearer object of its class** (:func:`occluded_sides`: a line of boxes seen along
  its length, each box's image box ending where its nearer neighbour's begins): the centre across the
  ray is known no better than the object's extent (:attr:`ObservationSigma.side_extent`, its largest
  horizontal size over ``2 sqrt(3)``, level across the ray only); the association gate takes it on a
  second try, when the narrow gate left such a view without its object;
- **edge of the view** (the box centre farther than :data:`EDGE` of the half-width from the principal
  point) was measured too: fitted 0.91 once cut boxes are accounted for, so it has no factor.

:func:`degenerate` names the views that carry no usable position at all (rejected, with the reason
shown to the operator): a camera too close (the box covers the whole image, a depth reading or the
object nearer than :data:`MIN_RANGE`) and a sliver at the image border.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Sequence

import numpy as np

from pipeline.mapping.occlusion import HIDDEN_GAP, TOUCH_PX, camera_distance, hidden_share, occluded_sides
from pipeline.scene import Capture, SceneObject, Vec3

__all__ = ["HIDDEN_GAP", "TOUCH_PX", "ObservationSigma", "camera_distance", "degenerate", "distance_to_box",
           "hidden_share", "observation_sigma", "occluded_sides", "ray_covariance", "top_and_bottom_seen"]

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


NEAR_RANGE = 0.8
"""A camera nearer than this to the object's box [m] is a close-up (see :data:`NEAR_FACTOR`): the
minimum range of the Kinect v1 that recorded NYU Depth v2 (see :data:`DEPTH_RANGE`)."""

NEAR_FACTOR = 1.3
"""Along-ray sigma multiplier of a close-up (median regression on the tour: 1.27, 9 observations)."""

EDGE = 0.7
"""A box centre farther than this fraction of the image half-width from the principal point is at
the edge of the view (measured by ``bench/sim_sigma_fit.py``; no factor)."""


HIDDEN = 0.7
"""A box more than this fraction inside nearer objects' boxes of the same capture is mostly hidden."""

HIDDEN_FACTOR = 1.3
"""Along-ray sigma multiplier of a mostly hidden view (median regression on the tour: 1.31, 146 observations)."""

DEPTH_RANGE = 4.5
"""Farthest distance [m] a monocular depth model ranges well: the practical range of the Kinect v1
that recorded NYU Depth v2, which the offline depth model (FastDepth) learnt from."""

UNIFORM_STD = 1.0 / (2.0 * math.sqrt(3.0))
FACE_SPREAD = 0.5 * UNIFORM_STD
"""Across-ray sigma floor of a mapped view, over the object's largest horizontal size: the box's image
centre is the visible faces' centre, off the object's centre by up to half its footprint depending on its
heading (a uniform spread over half the size). Only for a view of the whole object: a partial one's centre is
a guess from the class size and joins an object by its extent (a wider gate let a desk seen 73 % hidden from
the side, 1.0 m off, move the desk). Across-ray errors on the extended tour (3,301 observations, ground truth
and noise seeds 0-9): within 1 / 2 sigma 46 / 80 % without the floor, 49 / 81 % with it; a robot dog seen from
the side, 0.2 m off across the ray, no longer starts a second dog."""
"""Standard deviation of a uniform spread over a unit extent."""


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
        partial: Only part of the object is seen (cut, occluded or mostly hidden): its centre comes
            from the class size, so the fusion may match it by its extent along the viewing ray
            (:mod:`pipeline.mapping.map_extent`).
        gate_along: The along-ray sigma before the range factors (see :meth:`gate_covariance`).
        across_extent: The across-ray floor of a view cut on two or more sides [m] (0 otherwise).
        side_extent: The across-ray floor [m] of a view whose side a nearer object of its class hides
            (:func:`occluded_sides`; 0 otherwise): the gate's when ``wide`` (see :meth:`gate_covariance`).
        level_seen: The view shows the object's top and bottom (its image box is not cut by the top or
            bottom border and not much shorter than the class height: :func:`top_and_bottom_seen`), so its
            height in the world is measured, whatever cuts it on the left or right: the association does not
            take it for an object on another level of a stack
            (:func:`pipeline.mapping.map_association.other_level`).
        factors: What grew the sigmas beyond the method's (``near``, ``... behind nearer objects``,
            ``beyond the depth model's range``, ``cut on N sides``), for the object's history.
    """

    along: float
    across: float
    yaw: float
    distance: float
    camera: Vec3 | None
    cut: bool
    factors: tuple[str, ...] = ()
    partial: bool = False
    gate_along: float = math.nan
    across_extent: float = 0.0
    side_extent: float = 0.0
    level_seen: bool = False

    @property
    def weight_sigma(self) -> float:
        """The larger of the two sigmas [m]: what the fusion weighs this view by."""
        return max(self.along, self.across)

    def covariance(self, position: Sequence[float]) -> np.ndarray:
        """3x3 position covariance [m^2] (world): ``along`` on the camera ray, ``across`` off it."""
        if self.camera is None:
            return np.eye(3) * self.along**2
        return ray_covariance(position, self.camera, self.along, self.across)

    def gate_covariance(self, position: Sequence[float], wide: bool = False) -> np.ndarray:
        """The covariance [m^2] the association gate uses: the method's (and cut) sigmas without the
        range factors, which weigh a view less but must not widen its reach to the next object;
        ``wide``: across the ray at least :attr:`side_extent` (a second try, see
        :func:`pipeline.mapping.map_association.assign_capture`)."""
        along = self.gate_along if math.isfinite(self.gate_along) else self.along
        if self.camera is None:
            return np.eye(3) * along**2
        across = max(along * LATERAL_RATIO, self.across_extent)
        cov = ray_covariance(position, self.camera, along, across)
        if wide and self.side_extent > across:  # a hidden left or right side: wider across the ray, level only
            ray = np.asarray(position, dtype=np.float64) - np.asarray(self.camera, dtype=np.float64)
            side = np.cross(ray, (0.0, 0.0, 1.0))
            n = float(np.linalg.norm(side))
            if n > 1e-9:
                side /= n
                cov = cov + (self.side_extent**2 - across**2) * np.outer(side, side)
        return cov


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


def cut_sides(obj: SceneObject, capture: Capture | None) -> int:
    """How many sides of the object's box the image border cuts (0-4): the mapper's ``cut`` when it
    names them, else from the box against the image size."""
    if obj.cut:
        return len(set(obj.cut))
    size = _image_size(capture)
    b = obj.source.bbox
    if size is None or b is None:
        return 0
    w, h = size
    return int(b[0] <= BORDER_PX) + int(b[1] <= BORDER_PX) + int(b[2] >= w - BORDER_PX) + int(b[3] >= h - BORDER_PX)


def edge_offset(obj: SceneObject, capture: Capture | None) -> float:
    """Horizontal offset of the box centre from the principal point over the image half-width
    (0 on the optical axis, 1 at the border); 0 when unknown."""
    size = _image_size(capture)
    b = obj.source.bbox
    if size is None or b is None:
        return 0.0
    cx = float(capture.intrinsics.get("cx", size[0] / 2)) if capture is not None else size[0] / 2
    return abs((b[0] + b[2]) / 2 - cx) / (size[0] / 2)


def surface_distance(obj: SceneObject, capture: Capture | None) -> float | None:
    """Distance [m] from the capture's camera to the object's box (0 inside it), ``None`` if unknown."""
    if capture is None or capture.camera_position is None:
        return None
    return distance_to_box(capture.camera_position, obj.position, obj.size, obj.yaw)


def _model_depth(capture: Capture | None) -> bool:
    """Whether the capture's depth came from a depth model (not the simulator's rendered depth)."""
    name = str(capture.models.get("depth", "")) if capture is not None and capture.models else ""
    return bool(name) and not name.startswith("ground-truth")


def observation_sigma(obj: SceneObject, capture: Capture | None = None,
                      others: Sequence[SceneObject] = ()) -> ObservationSigma:
    """The 1-sigma errors of ``obj`` as seen by ``capture`` (see the module docstring).

    ``others``: the other objects of the same capture (for :func:`hidden_share`); empty: not known.
    """
    d = camera_distance(obj, capture)
    dist = DEFAULT_DISTANCE if d is None or not math.isfinite(d) else d
    a, b = METHOD_SIGMA.get(obj.source.method, DEFAULT_METHOD_SIGMA)
    along = _given_sigma(obj) or (a + b * dist)
    yaw = YAW_SIGMA.get(obj.source.method, DEFAULT_YAW_SIGMA)
    mapped = obj.source.method not in ("manual", "ground_truth")
    occluded = mapped and is_occluded(obj, capture, d)
    cut = mapped and (is_cut(obj, capture) or occluded)
    level_seen = mapped and not occluded and top_and_bottom_seen(obj, capture)
    if cut:
        along *= CUT_FACTOR
        yaw = CUT_YAW_SIGMA
    factors: list[str] = []
    gate_along = along
    sides = cut_sides(obj, capture) if mapped else 0
    partial = bool(cut)
    if mapped:
        near = surface_distance(obj, capture)
        if near is not None and near < NEAR_RANGE:
            along *= NEAR_FACTOR
            factors.append(f"near ({near:.2f} m)")
        hidden = hidden_share(obj, capture, others)
        if hidden > HIDDEN:
            along *= HIDDEN_FACTOR
            partial = True
            factors.append(f"{100 * hidden:.0f} % behind nearer objects")
        if d is not None and d > DEPTH_RANGE and _model_depth(capture):
            along *= d / DEPTH_RANGE
            factors.append(f"beyond the depth model's range ({d:.1f} m)")
    camera = capture.camera_position if capture is not None else None
    across = along * LATERAL_RATIO if camera is not None else along
    extent = max(obj.size[0], obj.size[2]) * UNIFORM_STD if sides >= 2 else 0.0
    if mapped and camera is not None and not partial:
        extent = max(extent, max(obj.size[0], obj.size[2]) * FACE_SPREAD)
        across = max(across, extent)
    if sides >= 2:
        across = max(across, extent)
        factors.append(f"cut on {sides} sides")
    hid = occluded_sides(obj, capture, others) if mapped and camera is not None else 0
    side_extent = max(obj.size[0], obj.size[2]) * UNIFORM_STD if hid else 0.0
    if hid:
        factors.append(f"{hid} side{'s' if hid > 1 else ''} behind a nearer {obj.label}")
    return ObservationSigma(along, across, yaw, dist,
                            None if camera is None else tuple(float(v) for v in camera), cut,  # type: ignore[arg-type]
                            tuple(factors), partial, gate_along, extent, side_extent, level_seen)


def top_and_bottom_seen(obj: SceneObject, capture: Capture | None) -> bool:
    """Whether the object's image box keeps its top and bottom edges: neither is within
    :data:`BORDER_PX` of the image's top or bottom border (a cut on the left or right hides neither).
    ``False`` when the box or the image size is unknown."""
    size = _image_size(capture)
    b = obj.source.bbox
    if size is None or b is None:
        return False
    return b[1] > BORDER_PX and b[3] < size[1] - BORDER_PX


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
