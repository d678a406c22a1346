"""How far an object is, from one photo: size prior, depth map, depth-scale fitting and fusion.

Pure functions on numbers and arrays; no models, no I/O. Conventions:

- boxes are ``(x1, y1, x2, y2)`` [px] in the image (x right, y down), ``x2 > x1``, ``y2 > y1``;
- a *distance* is a depth along the camera's optical axis (camera-frame ``z``) [m];
- focal lengths ``fx``, ``fy`` [px].

The paper's recipe is :func:`geometric_distance` (``d = f * h_m / h_px``), :func:`mask_median_depth`
and :func:`fuse_distances` (80 % geometric, 20 % depth; depth only when the size is unknown). Beyond the
paper: :func:`truncation` finds the box sides that the image border cuts, so the geometric estimate uses
a dimension the border does not shorten; :func:`fit_depth_scale` turns a relative (or inverse
relative) depth map into metres from the objects whose size is known; :func:`depth_fit_spread` and
:func:`inverse_variance_weights` weigh the depth map by how well it agrees with those objects on the
image at hand, and the ``gate`` of :func:`fuse_distances` drops depth readings that contradict a size
prior.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from itertools import combinations
from typing import Literal, Sequence

import numpy as np

from pipeline.boxes import BoxError, parse_box

DepthKind = Literal["metric", "relative", "inverse_relative"]
"""What a depth map holds: metres; depth up to an unknown scale; inverse depth up to scale and shift."""

DEPTH_KINDS: tuple[DepthKind, ...] = ("metric", "relative", "inverse_relative")

Box = Sequence[float]


class DistanceError(ValueError):
    """Invalid input to a distance formula (bad box, size, focal length, weights or depth kind)."""


def check_box(box: Box) -> tuple[float, float, float, float]:
    """The box as four finite floats with ``x2 > x1`` and ``y2 > y1``; :class:`DistanceError` otherwise."""
    try:
        return parse_box(box)
    except BoxError as exc:
        raise DistanceError(str(exc)) from None


def _positive(name: str, value: float) -> float:
    v = float(value)
    if not math.isfinite(v) or v <= 0:
        raise DistanceError(f"{name} must be a finite number > 0, got {value!r}")
    return v


# --- truncation -----------------------------------------------------------------------------------


@dataclass(frozen=True)
class Truncation:
    """Which sides of a 2D box the image border cuts (the object continues beyond that side)."""

    left: bool = False
    top: bool = False
    right: bool = False
    bottom: bool = False

    @property
    def vertical_cut(self) -> bool:
        """The box height is shorter than the object's image height."""
        return self.top or self.bottom

    @property
    def horizontal_cut(self) -> bool:
        """The box width is shorter than the object's image width."""
        return self.left or self.right

    @property
    def sides(self) -> tuple[bool, bool, bool, bool]:
        """``(left, top, right, bottom)``, in box-coordinate order."""
        return (self.left, self.top, self.right, self.bottom)


def truncation(box: Box, width: int, height: int, margin_px: float = 3.0) -> Truncation:
    """The sides of ``box`` within ``margin_px`` [px] of the border of a ``width`` x ``height`` image."""
    x1, y1, x2, y2 = check_box(box)
    if width <= 0 or height <= 0:
        raise DistanceError(f"image size must be > 0, got {width}x{height}")
    if margin_px < 0:
        raise DistanceError(f"margin_px must be >= 0, got {margin_px}")
    return Truncation(
        left=x1 <= margin_px,
        top=y1 <= margin_px,
        right=x2 >= width - margin_px,
        bottom=y2 >= height - margin_px,
    )


# --- size prior -----------------------------------------------------------------------------------


def expected_horizontal_extent(width_m: float, length_m: float) -> float:
    """Mean image-plane horizontal extent [m] of a ``width_m`` x ``length_m`` footprint under a uniform
    random yaw: ``E[w |cos a| + l |sin a|] = 2 (w + l) / pi``."""
    return 2.0 * (_positive("width_m", width_m) + _positive("length_m", length_m)) / math.pi


@dataclass(frozen=True)
class GeometricDistance:
    """A size-prior distance: ``distance`` [m] of the measured face, from the box ``axis`` that was used."""

    distance: float
    axis: Literal["vertical", "horizontal"]


def geometric_distance(
    box: Box,
    height_m: float,
    horizontal_m: float | None,
    fx: float,
    fy: float,
    trunc: Truncation | None = None,
) -> GeometricDistance | None:
    """The paper's ``d = f * h_m / h_px`` [m], using a box dimension the image border does not cut.

    Vertical first: ``fy * height_m / h_px`` when neither top nor bottom is cut. Otherwise horizontal:
    ``fx * horizontal_m / w_px`` when neither left nor right is cut and ``horizontal_m`` (the object's
    extent across the image [m], e.g. :func:`expected_horizontal_extent`) is given. ``None`` when every
    usable dimension is cut: the box then only bounds the distance from above.
    """
    x1, y1, x2, y2 = check_box(box)
    height_m = _positive("height_m", height_m)
    fx, fy = _positive("fx", fx), _positive("fy", fy)
    trunc = trunc or Truncation()
    if not trunc.vertical_cut:
        return GeometricDistance(fy * height_m / (y2 - y1), "vertical")
    if horizontal_m is not None and not trunc.horizontal_cut:
        return GeometricDistance(fx * _positive("horizontal_m", horizontal_m) / (x2 - x1), "horizontal")
    return None


# --- depth map ------------------------------------------------------------------------------------


def mask_median_depth(depth: np.ndarray, mask: np.ndarray, min_pixels: int = 1) -> float | None:
    """Median of ``depth`` over the ``True`` pixels of ``mask`` (same H x W), ignoring NaN, inf and
    values <= 0 (invalid); ``None`` when fewer than ``min_pixels`` valid pixels remain.

    The unit is the depth map's own (metres for metric depth, arbitrary for relative maps)."""
    d = np.asarray(depth)
    m = np.asarray(mask)
    if d.ndim != 2 or m.shape != d.shape:
        raise DistanceError(f"depth {d.shape} and mask {m.shape} must be two arrays of the same H x W")
    vals = d[m.astype(bool)]
    vals = vals[np.isfinite(vals) & (vals > 0)]
    if vals.size < max(1, min_pixels):
        return None
    return float(np.median(vals))


@dataclass(frozen=True)
class DepthScale:
    """Maps a depth-map value to metric depth [m].

    - ``metric`` / ``relative``: ``z = scale * value``;
    - ``inverse_relative``: ``1 / z = scale * value + shift`` (value is a disparity-like number).

    ``n_refs`` reference objects were offered, ``n_inliers`` agree with the fit.
    """

    kind: DepthKind
    scale: float
    shift: float = 0.0
    n_refs: int = 0
    n_inliers: int = 0

    def to_metric(self, value: float | np.ndarray) -> float | np.ndarray:
        """Metric depth [m] for depth-map ``value`` (``nan`` where the fit gives no positive depth)."""
        v = np.asarray(value, dtype=np.float64)
        if self.kind == "inverse_relative":
            inv = self.scale * v + self.shift
            with np.errstate(divide="ignore", invalid="ignore"):
                out = np.where(inv > 0, 1.0 / inv, np.nan)
        else:
            out = np.where(v > 0, self.scale * v, np.nan)
        return float(out) if out.ndim == 0 else out


IDENTITY_SCALE = DepthScale("metric", 1.0)
"""Metric depth taken as it is."""


def fit_depth_scale(
    values: Sequence[float],
    reference_m: Sequence[float],
    kind: DepthKind,
    inlier_tol: float = 0.15,
) -> DepthScale | None:
    """Fit the map from depth-map values to metres from reference objects, robustly.

    Args:
        values: Each reference object's depth-map value (e.g. :func:`mask_median_depth`).
        reference_m: The same objects' metric depth [m] from their known size (the geometric estimate).
        kind: What the map holds (:data:`DEPTH_KINDS`).
        inlier_tol: Relative depth error below which a reference agrees with a fit.

    ``metric`` and ``relative``: scale only, the median of the ratios ``reference / value`` (any
    number of references; one outlier in three cannot move it), then the mean log-ratio of the
    inliers. ``inverse_relative``: ``1/z = s * value + t``. With one reference (or values that do
    not vary) only the scale can be fitted (``t = 0``); with two or more, every pair defines a line
    (``s > 0``), the line with most inliers (ties: smallest error) wins and is refitted by least
    squares on its inliers. ``None`` when no valid reference is given.
    """
    v = np.asarray(values, dtype=np.float64).reshape(-1)
    r = np.asarray(reference_m, dtype=np.float64).reshape(-1)
    if v.shape != r.shape:
        raise DistanceError(f"values ({v.size}) and reference_m ({r.size}) must have the same length")
    if kind not in DEPTH_KINDS:
        raise DistanceError(f"depth kind must be one of {DEPTH_KINDS}, got {kind!r}")
    ok = np.isfinite(v) & np.isfinite(r) & (v > 0) & (r > 0)
    v, r = v[ok], r[ok]
    n = int(v.size)
    if n == 0:
        return None
    if kind != "inverse_relative":
        log_ratio = np.log(r / v)
        med = float(np.median(log_ratio))
        inl = np.abs(log_ratio - med) <= math.log1p(inlier_tol)
        est = float(np.mean(log_ratio[inl])) if inl.any() else med
        return DepthScale(kind, math.exp(est), 0.0, n, int(inl.sum()))
    if n == 1 or np.ptp(v) <= 1e-9 * float(v.max()):
        return _inverse_scale_only(v, r, n, inlier_tol)
    inv = 1.0 / r
    best: tuple[int, float, float, float] | None = None  # (-inliers, error, s, t)
    for i, j in combinations(range(n), 2):
        if abs(v[i] - v[j]) <= 1e-12:
            continue
        s = (inv[i] - inv[j]) / (v[i] - v[j])
        if s <= 0:
            continue
        t = inv[i] - s * v[i]
        err = _inverse_fit_errors(v, r, s, t)
        n_in = int((err <= inlier_tol).sum())
        key = (-n_in, float(np.sum(np.minimum(err, inlier_tol))), s, t)
        if best is None or key[:2] < best[:2]:
            best = key
    if best is None or -best[0] < 2:  # no consistent pair: fall back to a scale-only fit
        return _inverse_scale_only(v, r, n, inlier_tol)
    s, t = best[2], best[3]
    inl = _inverse_fit_errors(v, r, s, t) <= inlier_tol
    A = np.stack([v[inl], np.ones(int(inl.sum()))], axis=1)
    (s2, t2), *_ = np.linalg.lstsq(A, inv[inl], rcond=None)
    if s2 > 0 and np.all(s2 * v[inl] + t2 > 0):
        s, t = float(s2), float(t2)
    inl = _inverse_fit_errors(v, r, s, t) <= inlier_tol
    return DepthScale(kind, float(s), float(t), n, int(inl.sum()))


def _inverse_fit_errors(v: np.ndarray, r: np.ndarray, s: float, t: float) -> np.ndarray:
    inv = s * v + t
    with np.errstate(divide="ignore", invalid="ignore"):
        z = np.where(inv > 0, 1.0 / inv, np.inf)
    return np.abs(z - r) / r


def _inverse_scale_only(v: np.ndarray, r: np.ndarray, n: int, inlier_tol: float) -> DepthScale:
    """``1/z = s * value``: ``s = 1 / (z * value)`` per reference, robust median then inlier mean."""
    log_s = -np.log(r * v)
    med = float(np.median(log_s))
    inl = np.abs(log_s - med) <= math.log1p(inlier_tol)
    est = float(np.mean(log_s[inl])) if inl.any() else med
    return DepthScale("inverse_relative", math.exp(est), 0.0, n, int(inl.sum()))


def depth_fit_spread(values: Sequence[float], reference_m: Sequence[float], scale: DepthScale,
                     min_refs: int = 3) -> float | None:
    """Robust spread of the log-ratio between reference depths [m] and the fitted depth map's
    (``1.4826 * MAD``; a relative error, ~0.1 = 10 %); ``None`` with fewer than ``min_refs`` references.

    It measures how well the depth map agrees with the size priors on this image: small for an
    in-domain model, large when the map is out of its domain (e.g. an indoor model outdoors)."""
    v = np.asarray(values, dtype=np.float64).reshape(-1)
    r = np.asarray(reference_m, dtype=np.float64).reshape(-1)
    if v.shape != r.shape:
        raise DistanceError(f"values ({v.size}) and reference_m ({r.size}) must have the same length")
    z = np.asarray(scale.to_metric(v), dtype=np.float64).reshape(-1)
    ok = np.isfinite(z) & (z > 0) & np.isfinite(r) & (r > 0)
    if int(ok.sum()) < max(2, min_refs):
        return None
    res = np.log(r[ok] / z[ok])
    return float(1.4826 * np.median(np.abs(res - np.median(res))))


MIN_SPREAD_REFS = 2
"""References needed to measure the depth map's spread against the other cues (one degree of freedom
beyond its fitted scale; pooled with the prior ``MapperConfig.depth_sigma`` by :func:`pooled_sigma`)."""

DEPTH_PRIOR_DOF = 3.0
"""How many reference objects the prior depth-map sigma (``MapperConfig.depth_sigma``, 30 %) is worth when
pooled with the spread measured on a photo (:func:`pooled_sigma`): 4 references that happen to agree
within 7 % (a KITTI photo, FastDepth far outside its indoor range) give 22 %, 27 references the spread
they show."""


def pooled_sigma(measured: float, dof: int, prior: float, prior_dof: float = DEPTH_PRIOR_DOF) -> float:
    """A relative sigma measured with ``dof`` degrees of freedom (references less one fitted scale) pooled
    with a prior one worth ``prior_dof``: ``sqrt((prior_dof prior^2 + dof measured^2) / (prior_dof + dof))``
    (the scaled inverse chi-square posterior's mean variance): few references cannot make a depth map look
    more exact than it is."""
    m, p = _positive("measured", measured), _positive("prior", prior)
    dof = max(int(dof), 0)
    if not (math.isfinite(prior_dof) and prior_dof >= 0) or prior_dof + dof <= 0:
        raise DistanceError(f"prior_dof: must be >= 0 with prior_dof + dof > 0, got {prior_dof!r}, {dof!r}")
    return math.sqrt((prior_dof * p * p + dof * m * m) / (prior_dof + dof))


def inverse_variance_weights(sigma_geometric: float, sigma_depth: float) -> tuple[float, float]:
    """Fusion weights ``(w_g, w_d)`` summing to 1 from the relative errors of the two estimates."""
    sg, sd = _positive("sigma_geometric", sigma_geometric), _positive("sigma_depth", sigma_depth)
    wg, wd = 1.0 / sg**2, 1.0 / sd**2
    return wg / (wg + wd), wd / (wg + wd)


# --- fusion ---------------------------------------------------------------------------------------


@dataclass(frozen=True)
class FusedDistance:
    """The final distance [m] and which estimates made it: ``fused``, ``geometric`` or ``depth``."""

    distance: float
    method: Literal["fused", "geometric", "depth"]


def fuse_distances(
    geometric: float | None,
    depth: float | None,
    w_geometric: float = 0.8,
    w_depth: float = 0.2,
    gate: float | None = None,
    nearer_depth_wins: bool = False,
) -> FusedDistance | None:
    """The paper's weighted mean ``(w_g * geometric + w_d * depth) / (w_g + w_d)`` [m].

    Depth only when the size prior gives nothing (unknown size, or every dimension cut), geometric only
    when there is no depth; ``None`` when neither exists. Weights must be >= 0 and not both 0.
    ``gate``: when ``|ln(depth / geometric)|`` exceeds it, the two disagree beyond their errors and
    the depth reading is dropped (a size prior is off by tens of percent at worst; a depth map out of
    its domain can be off by any factor).

    ``nearer_depth_wins`` (for a metric depth map): when the gate is exceeded with the depth reading
    *nearer* than the size prior, the depth wins instead. A box cut short (by the image border, or by
    an occluder in front: a desk hiding a suitcase's lower half) makes an object look smaller, hence
    farther, by any factor; nothing makes it look larger. So a size prior far beyond a metric depth
    reading is the unreliable one.
    """
    if w_geometric < 0 or w_depth < 0 or not math.isfinite(w_geometric + w_depth) or w_geometric + w_depth <= 0:
        raise DistanceError(f"fusion weights must be >= 0 and not both 0, got {w_geometric}, {w_depth}")
    g = None if geometric is None or not math.isfinite(geometric) or geometric <= 0 else float(geometric)
    d = None if depth is None or not math.isfinite(depth) or depth <= 0 else float(depth)
    if g is not None and d is not None and gate is not None and abs(math.log(d / g)) > gate:
        if nearer_depth_wins and d < g:
            return FusedDistance(d, "depth")
        d = None
    if g is not None and d is not None:
        if w_depth == 0:
            return FusedDistance(g, "geometric")
        if w_geometric == 0:
            return FusedDistance(d, "depth")
        return FusedDistance((w_geometric * g + w_depth * d) / (w_geometric + w_depth), "fused")
    if g is not None:
        return FusedDistance(g, "geometric")
    if d is not None:
        return FusedDistance(d, "depth")
    return None
