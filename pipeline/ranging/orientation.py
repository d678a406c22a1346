"""An object's yaw from the partial 3D point cloud its mask and a metric depth map give.

Camera frame: OpenCV optical frame (x right, y down, z forward) [m]; pixels [px]; angles [rad].

A 2D box hardly constrains the yaw, but with a trusted metric depth map the mask's pixels
back-projected at their depth are points of the object's visible surface. Projected on the ground
plane (gravity known from the camera mount and the robot pose) they trace the faces turned to the
camera (an "L" seen obliquely, a line seen square-on) plus the top face when seen from above. The
footprint rectangle's orientation is the direction that puts the points closest to the rectangle's
edges (the closeness criterion of search-based L-shape fitting, Zhang et al. 2017); which of its two
axes is the length axis is decided by the catalog size ``(w, l)``: the assignment whose footprint
best matches the points' extents.

Ground-plane coordinates are along ``(e1, e3)`` of :func:`pipeline.ranging.placement.gravity_basis`, so a
yaw ``t`` here is the yaw of :func:`pipeline.ranging.placement.box_axes` (length axis ``cos t e1 + sin t e3``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Sequence

import numpy as np

from pipeline.camera.geometry import Intrinsics
from pipeline.ranging.placement import box_axes, gravity_basis

MIN_POINTS = 30
"""Fewest ground-plane points a yaw is fitted from."""


@dataclass(frozen=True)
class FootprintYaw:
    """The fitted footprint orientation.

    Attributes:
        yaw: Yaw [rad] in ``[0, pi)`` of the length axis in the gravity basis (see module doc).
        extents: Robust extents [m] of the points along the length and width axes.
        contrast: Closeness score at the best orientation over its mean over all orientations
            (1: no preferred orientation; larger: a clear edge structure).
        n_points: Points used.
    """

    yaw: float
    extents: tuple[float, float]
    contrast: float
    n_points: int


def backproject_mask(mask: np.ndarray, depth_m: np.ndarray, intr: Intrinsics, max_points: int = 2000,
                     erode_px: int = 1) -> np.ndarray:
    """Camera-frame points [m] (N x 3) of the mask's pixels at their metric depth ``depth_m`` (camera
    z [m], non-positive or non-finite = no reading).

    The mask is eroded by ``erode_px`` (mixed foreground/background depths at its border), falling
    back to the full mask when erosion empties it; at most ``max_points`` pixels (a regular subsample).
    """
    m = np.asarray(mask, dtype=bool)
    d = np.asarray(depth_m, dtype=np.float64)
    if m.shape != d.shape:
        raise ValueError(f"mask {m.shape} and depth {d.shape} must have the same shape")
    if erode_px > 0 and m.any():
        import cv2

        k = np.ones((2 * erode_px + 1, 2 * erode_px + 1), np.uint8)
        eroded = cv2.erode(m.astype(np.uint8), k).astype(bool)
        if np.count_nonzero(eroded & np.isfinite(d) & (d > 0)) >= MIN_POINTS:
            m = eroded
    rows, cols = np.nonzero(m & np.isfinite(d) & (d > 0))
    if rows.size > max_points:
        step = int(math.ceil(rows.size / max_points))
        rows, cols = rows[::step], cols[::step]
    z = d[rows, cols]
    uv = intr.undistort_pixels(np.stack([cols + 0.5, rows + 0.5], axis=1))
    x = (uv[:, 0] - intr.cx) / intr.fx * z
    y = (uv[:, 1] - intr.cy) / intr.fy * z
    return np.stack([x, y, z], axis=1)


def ground_plane_points(points_cam: np.ndarray, gravity_cam: Sequence[float]) -> np.ndarray:
    """Camera-frame points [m] projected on the ground plane: N x 2 coordinates along ``(e1, e3)`` of
    :func:`~pipeline.ranging.placement.gravity_basis`."""
    e1, _, e3 = gravity_basis(gravity_cam)
    p = np.asarray(points_cam, dtype=np.float64).reshape(-1, 3)
    return np.stack([p @ e1, p @ e3], axis=1)


def _robust_range(c: np.ndarray, q: float) -> tuple[np.ndarray, np.ndarray]:
    """Lower and upper ``q`` / ``1 - q`` order statistics of ``c`` along its last axis."""
    n = c.shape[-1]
    k_lo = min(max(int(math.floor(q * (n - 1))), 0), n - 1)
    k_hi = n - 1 - k_lo
    part = np.partition(c, (k_lo, k_hi), axis=-1)
    return part[..., k_lo], part[..., k_hi]


def _refine(p: np.ndarray, a: float, d0: float, min_points: int = 10) -> float:
    """Orientation ``a`` [rad] refined by the principal directions of the point groups along the
    rectangle's edges at ``a`` (within ``2 d0`` [m] of their nearest edge, elongated groups only),
    averaged modulo ``pi/2`` weighted by group size; ``a`` when no group qualifies."""
    dirs = np.array([[math.cos(a), math.sin(a)], [-math.sin(a), math.cos(a)]])
    c = p @ dirs.T  # (N, 2)
    lo, hi = c.min(axis=0), c.max(axis=0)
    dist = np.stack([c[:, 0] - lo[0], hi[0] - c[:, 0], c[:, 1] - lo[1], hi[1] - c[:, 1]], axis=1)
    nearest = np.argmin(dist, axis=1)
    near = dist[np.arange(len(p)), nearest] < 2.0 * d0
    devs, wts = [], []
    for k in range(4):
        g = p[near & (nearest == k)]
        if g.shape[0] < min_points:
            continue
        ev, vec = np.linalg.eigh(np.cov((g - g.mean(axis=0)).T))
        if ev[1] <= 0 or ev[0] > 0.01 * ev[1]:  # not a line
            continue
        ang = math.atan2(float(vec[1, 1]), float(vec[0, 1]))
        dev = (ang - a + math.pi / 4) % (math.pi / 2) - math.pi / 4  # edge direction vs a, mod pi/2
        devs.append(dev)
        wts.append(g.shape[0])
    if not devs:
        return a
    return a + float(np.average(devs, weights=wts))


def fit_footprint_yaw(
    points_xy: np.ndarray,
    size_wl: Sequence[float],
    n_yaw: int = 45,
    min_points: int = MIN_POINTS,
    min_contrast: float = 1.05,
    outlier_quantile: float = 0.02,
) -> FootprintYaw | None:
    """The yaw [rad, in ``[0, pi)``] of the length axis of a ``w`` x ``l`` [m] footprint fitting the
    ground-plane points ``points_xy`` [m] (N x 2) of an object's visible surface.

    Orientations ``a`` in ``[0, pi/2)`` (``n_yaw`` steps) are scored by the closeness criterion: each
    point's distance to the nearest edge of the points' bounding rectangle along ``(cos a, sin a)``
    and its normal (robust: ``outlier_quantile`` quantiles), summed as ``1 / max(d, d0)`` with
    ``d0 = 2 %`` of the footprint's longer side; the best one is refined by the principal directions of
    the points along its edges (the criterion is flat within a few degrees of a lone side). The length axis is then ``a`` or ``a + pi/2``,
    whichever footprint ``(l, w)`` matches the extents better (relative mismatch, an extent beyond the
    size counted three times).

    ``None`` (keep the fallback orientation) with fewer than ``min_points`` points, points spread less
    than 10 % of the shorter side, or no preferred orientation (contrast below ``min_contrast``).
    """
    p = np.asarray(points_xy, dtype=np.float64).reshape(-1, 2)
    p = p[np.all(np.isfinite(p), axis=1)]
    w, l = (float(v) for v in size_wl)
    if not (w > 0 and l > 0):
        raise ValueError(f"size_wl must be 2 positive numbers (w, l) [m], got {size_wl!r}")
    if n_yaw < 2:
        raise ValueError(f"n_yaw must be >= 2, got {n_yaw}")
    n = p.shape[0]
    if n < min_points:
        return None
    p = p - np.median(p, axis=0)
    if float(np.max(np.linalg.norm(p, axis=1))) < 0.1 * min(w, l):
        return None
    a = np.arange(n_yaw) * (math.pi / 2) / n_yaw
    c1 = np.cos(a)[:, None] * p[None, :, 0] + np.sin(a)[:, None] * p[None, :, 1]  # (K, N)
    c2 = -np.sin(a)[:, None] * p[None, :, 0] + np.cos(a)[:, None] * p[None, :, 1]
    lo1, hi1 = _robust_range(c1, outlier_quantile)
    lo2, hi2 = _robust_range(c2, outlier_quantile)
    d1 = np.minimum(np.abs(c1 - lo1[:, None]), np.abs(hi1[:, None] - c1))
    d2 = np.minimum(np.abs(c2 - lo2[:, None]), np.abs(hi2[:, None] - c2))
    d0 = 0.02 * max(w, l)
    score = np.sum(1.0 / np.maximum(np.minimum(d1, d2), d0), axis=1)
    best = int(np.argmax(score))
    contrast = float(score[best] / max(float(score.mean()), 1e-12))
    if contrast < min_contrast:
        return None
    a_best = _refine(p, float(a[best]), d0)
    c1r = p @ np.array([math.cos(a_best), math.sin(a_best)])
    c2r = p @ np.array([-math.sin(a_best), math.cos(a_best)])
    (l1, h1), (l2, h2) = _robust_range(c1r, outlier_quantile), _robust_range(c2r, outlier_quantile)
    e1, e2 = float(h1 - l1), float(h2 - l2)

    def mismatch(extent: float, side: float) -> float:
        r = (extent - side) / side
        return 3.0 * r if r > 0 else -r

    along = mismatch(e1, l) + mismatch(e2, w)  # length axis along a
    across = mismatch(e1, w) + mismatch(e2, l)  # length axis along a + pi/2
    if along <= across:
        yaw, ext = a_best, (e1, e2)
    else:
        yaw, ext = a_best + math.pi / 2, (e2, e1)
    return FootprintYaw(yaw=yaw % math.pi, extents=ext, contrast=contrast, n_points=n)


def length_axis_from_points(
    mask: np.ndarray,
    depth_m: np.ndarray,
    intr: Intrinsics,
    gravity_cam: Sequence[float],
    size_whl: Sequence[float],
    **fit_options: float,
) -> np.ndarray | None:
    """Unit camera-frame length axis (horizontal) of a ``(w, h, l)`` [m] object from its mask and a
    metric depth map [m]; ``None`` when the points do not determine it (see :func:`fit_footprint_yaw`).

    Points farther than ``1.5 * max(w, h, l)`` from the median point (background leaking into the
    mask, an occluder's edge) are dropped first.
    """
    w, h, l = (float(v) for v in size_whl)
    pts = backproject_mask(mask, depth_m, intr)
    if pts.shape[0] < MIN_POINTS:
        return None
    med = np.median(pts, axis=0)
    pts = pts[np.linalg.norm(pts - med, axis=1) <= 1.5 * max(w, h, l)]
    fit = fit_footprint_yaw(ground_plane_points(pts, gravity_cam), (w, l), **fit_options)  # type: ignore[arg-type]
    if fit is None:
        return None
    return np.asarray(box_axes(fit.yaw, gravity_cam)[0], dtype=np.float64)


__all__ = ["FootprintYaw", "MIN_POINTS", "backproject_mask", "fit_footprint_yaw", "ground_plane_points",
           "length_axis_from_points"]
