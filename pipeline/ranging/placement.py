"""Where an object is: its 3D centre in the camera frame from a 2D box, a size and a distance.

Camera frame throughout: OpenCV optical frame (x right, y down, z forward) [m]; pixels [px].

Two ways:

- :func:`centre_on_ray`: the paper's way, beyond it only in the push: the point of the box-centre ray at
  the measured surface depth, pushed half the object's depth further along the ray.
- :func:`fit_box_to_2d`: when the gravity direction in the camera is known (robot pose + camera
  mount) and the object's size is known, the 3D box (unknown position and yaw about gravity, size
  near the catalog's) whose projection best matches the 2D box edges that the image border does not
  cut (Deep3DBox-style). It accounts for the top face a camera looking down sees (which makes the
  plain ``f * h / h_px`` read objects too close) and for truncation (a cut side only says the object
  continues past the border).

:func:`geometric_estimate` picks between them; :func:`visible_surface_offset` says how much nearer
than the centre a depth map sees a box, so depth readings and size priors can be compared.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Sequence

import numpy as np

from pipeline.ranging.distance import Box, DistanceError, Truncation, check_box
from pipeline.camera.geometry import Intrinsics

_CORNER_SIGNS = np.array(
    [[sl, sh, sw] for sl in (-1, 1) for sh in (-1, 1) for sw in (-1, 1)], dtype=np.float64
)  # (8, 3): signs along (length, gravity-down, width)


def gravity_basis(gravity_cam: Sequence[float]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """An orthonormal camera-frame basis ``(e1, down, e3)``: ``down`` = unit gravity, ``e1`` = camera x
    made horizontal, ``e3 = e1 x down`` (horizontal, forward for a level camera).

    A box's length axis at yaw ``t`` is ``cos(t) e1 + sin(t) e3`` (``t = 0``: along image x).
    """
    g = np.asarray(gravity_cam, dtype=np.float64).reshape(-1)
    if g.shape != (3,) or not np.all(np.isfinite(g)) or np.linalg.norm(g) < 1e-9:
        raise DistanceError(f"gravity_cam must be a non-zero 3-vector, got {gravity_cam!r}")
    down = g / np.linalg.norm(g)
    ref = np.array([1.0, 0.0, 0.0]) if abs(down[0]) < 0.9 else np.array([0.0, 0.0, 1.0])
    e1 = ref - down * float(ref @ down)
    e1 /= np.linalg.norm(e1)
    e3 = np.cross(e1, down)
    return e1, down, e3


def box_axes(yaw: float | np.ndarray, gravity_cam: Sequence[float]) -> np.ndarray:
    """Box axes (length, gravity-down, width) as unit camera-frame vectors: shape ``(..., 3, 3)``,
    the last index the vector component; ``width = length x down``."""
    e1, down, e3 = gravity_basis(gravity_cam)
    t = np.asarray(yaw, dtype=np.float64)[..., None]
    length = np.cos(t) * e1 + np.sin(t) * e3
    width = np.cross(length, down)
    return np.stack([length, np.broadcast_to(down, length.shape), width], axis=-2)


def box_corners(center: Sequence[float], axes: np.ndarray, size_whl: Sequence[float]) -> np.ndarray:
    """The 8 corners (8 x 3) [m] of a box with centre, :func:`box_axes` and size ``(w, h, l)`` [m]."""
    w, h, l = (float(v) for v in size_whl)
    half = 0.5 * np.array([l, h, w])
    return np.asarray(center, dtype=np.float64) + (_CORNER_SIGNS * half) @ np.asarray(axes)


def ray_point(uv: Sequence[float], z: float, intr: Intrinsics) -> np.ndarray:
    """The camera-frame point [m] seen at pixel ``uv`` at optical-axis depth ``z`` [m]."""
    p = intr.undistort_pixels(np.asarray(uv, dtype=np.float64))[0]
    return np.array([(p[0] - intr.cx) / intr.fx * z, (p[1] - intr.cy) / intr.fy * z, z])


def centre_on_ray(uv: Sequence[float], surface_z: float, half_depth_m: float, intr: Intrinsics) -> np.ndarray:
    """Object centre [m]: the point at depth ``surface_z`` [m] on the ray through ``uv`` [px], pushed
    ``half_depth_m`` [m] further along the ray (the visible surface is the object's near side)."""
    if not math.isfinite(surface_z) or surface_z <= 0:
        raise DistanceError(f"surface_z must be > 0 [m], got {surface_z!r}")
    if not math.isfinite(half_depth_m) or half_depth_m < 0:
        raise DistanceError(f"half_depth_m must be >= 0 [m], got {half_depth_m!r}")
    p = ray_point(uv, surface_z, intr)
    return p + half_depth_m * p / np.linalg.norm(p)


def visible_surface_offset(center: Sequence[float], axes: np.ndarray, size_whl: Sequence[float],
                           samples: int = 8) -> float:
    """How much nearer [m, optical-axis depth] the visible surface of a box is than its centre.

    What the median of a depth map over the object's mask measures: the faces turned to the camera
    are sampled on a ``samples`` x ``samples`` grid each, every sample weighted by the solid angle it
    covers (``cos(incidence) / range^2``, i.e. by its pixel count), and the weighted median of their
    depths is taken. ``center_z - offset`` is that surface depth; for a box seen square-on it is
    the front face (offset = half its depth).
    """
    c = np.asarray(center, dtype=np.float64)
    ax = np.asarray(axes, dtype=np.float64)
    w, h, l = (float(v) for v in size_whl)
    half = 0.5 * np.array([l, h, w])
    grid = (np.arange(samples) + 0.5) / samples * 2.0 - 1.0
    gu, gv = (g.reshape(-1) for g in np.meshgrid(grid, grid))
    depths, weights = [], []
    for i in range(3):
        j, k = [a for a in range(3) if a != i]
        for s in (-1.0, 1.0):
            n = s * ax[i]
            pts = c + s * half[i] * ax[i] + np.outer(gu * half[j], ax[j]) + np.outer(gv * half[k], ax[k])
            rng = np.linalg.norm(pts, axis=1)
            facing = -(pts @ n) / np.maximum(rng, 1e-9)
            keep = (facing > 0) & (pts[:, 2] > 0)
            if keep.any():
                depths.append(pts[keep, 2])
                weights.append(facing[keep] * (4.0 * half[j] * half[k] / samples**2) / rng[keep] ** 2)
    if not depths:  # camera inside the box
        return 0.0
    d = np.concatenate(depths)
    wt = np.concatenate(weights)
    order = np.argsort(d)
    cum = np.cumsum(wt[order])
    median = float(d[order][np.searchsorted(cum, 0.5 * cum[-1])])
    return float(c[2] - median)


@dataclass(frozen=True)
class BoxFit:
    """A fitted 3D box (camera frame).

    Attributes:
        center: Box centre [m]; the yaw-marginalised estimate (see :func:`fit_box_to_2d`).
        yaw: Best yaw [rad] about gravity (0: length axis along the horizontal image x).
        axes: Box axes (length, down, width) at ``yaw``, rows, camera frame.
        size: Fitted size ``(w, h, l)`` [m] at ``yaw`` (the prior, adjusted within its spread).
        residual_px: RMS edge residual [px] of the best yaw.
        n_edges: Number of uncut 2D box edges that constrained the fit.
        yaw_spread: Weighted spread [m] of the centre over plausible yaws (ambiguity).
    """

    center: np.ndarray
    yaw: float
    axes: np.ndarray
    size: tuple[float, float, float]
    residual_px: float
    n_edges: int
    yaw_spread: float


def fit_box_to_2d(
    box: Box,
    size_whl: Sequence[float],
    gravity_cam: Sequence[float],
    intr: Intrinsics,
    trunc: Truncation | None = None,
    z_init: float | None = None,
    size_sigma: Sequence[float] = (0.25, 0.15, 0.25),
    sigma_px: float | None = None,
    n_yaw: int = 12,
    prior_weight: float = 0.05,
    iterations: int = 10,
    horizontal_sigma_scale: float = 1.0,
) -> BoxFit | None:
    """The 3D box whose projection's bounding box best fits ``box``, its size near ``size_whl``.

    Unknowns: the centre ``T`` [m], the yaw about gravity and the half extents ``s`` [m] (a catalog size
    is a class average: ``size_sigma`` is the relative spread of real instances around it, for
    ``(w, h, l)``; horizontal extents vary more than heights). For each of ``n_yaw`` yaws in
    ``[0, pi)`` (a box is symmetric under a half turn) ``(T, s)`` solve a weighted linear least-squares
    problem, iterated because which corner is extreme on each side depends on them: an uncut left edge
    ``x1`` with extreme corner offset ``o(s)`` gives ``(T_x + o_x) - a1 (T_z + o_z) = 0`` with
    ``a1 = (x1 - cx) / fx`` (linear in ``T`` and ``s``), weighted ``fx / (T_z + o_z) / sigma_px`` so
    its residual is in units of the edge noise; each size gets the row ``(s_i - s0_i) / (sigma_i
    s0_i)``. A cut side only bounds the projection (it must reach past the border): it enters as an
    equality while violated. Two weak rows (``prior_weight``) keep the centre near the box-centre ray
    when the edges leave it free. Yaws are weighed by ``exp(-cost / 2)`` (cost = the squared
    normalised residuals: edges and sizes; ``sigma_px`` default ``max(2, 3 % of the box size)``) and
    the centre is their weighted mean: when the edges cannot tell the yaw, the answer is the average
    over the yaws that fit.

    ``None`` when fewer than two opposite edges are uncut (neither the height nor the width is
    measured), or no yaw gives a box in front of the camera.
    """
    x1, y1, x2, y2 = check_box(box)
    w, h, l = (float(v) for v in size_whl)
    if min(w, h, l) <= 0 or not all(math.isfinite(v) for v in (w, h, l)):
        raise DistanceError(f"size must be 3 positive numbers (w, h, l) [m], got {size_whl!r}")
    sig = np.asarray(size_sigma, dtype=np.float64).reshape(-1)
    if sig.shape != (3,) or np.any(~np.isfinite(sig)) or np.any(sig <= 0):
        raise DistanceError(f"size_sigma must be 3 numbers > 0 (w, h, l), got {size_sigma!r}")
    if n_yaw < 1:
        raise DistanceError(f"n_yaw must be >= 1, got {n_yaw}")
    trunc = trunc or Truncation()
    visible = np.array([not s for s in trunc.sides])
    if not ((visible[1] and visible[3]) or (visible[0] and visible[2])):
        return None
    if sigma_px is None:
        sigma_px = max(2.0, 0.03 * max(x2 - x1, y2 - y1))
    # box in normalised image coordinates (distortion removed)
    pts = intr.undistort_pixels(np.array([[x1, y1], [x2, y1], [x1, y2], [x2, y2],
                                          [(x1 + x2) / 2, y1], [(x1 + x2) / 2, y2],
                                          [x1, (y1 + y2) / 2], [x2, (y1 + y2) / 2]]))
    nu = (pts[:, 0] - intr.cx) / intr.fx
    nv = (pts[:, 1] - intr.cy) / intr.fy
    edges = np.array([nu.min(), nv.min(), nu.max(), nv.max()])  # left, top, right, bottom
    ac, bc = (edges[0] + edges[2]) / 2, (edges[1] + edges[3]) / 2
    focal = np.array([intr.fx, intr.fy, intr.fx, intr.fy])
    edge_sigma = sigma_px * np.array([horizontal_sigma_scale, 1.0, horizontal_sigma_scale, 1.0])
    comp = np.array([0, 1, 0, 1])  # image coordinate of each edge: u (0) or v (1)

    K = n_yaw
    yaws = np.arange(K) * math.pi / K
    axes = box_axes(yaws, gravity_cam)  # (K, 3 axes, 3 xyz)
    s0 = 0.5 * np.array([l, h, w])  # half extents along (length, down, width)
    s_sig = s0 * np.array([sig[2], sig[1], sig[0]])
    if z_init is None or not math.isfinite(z_init) or z_init <= 0:
        bh, bw = edges[3] - edges[1], edges[2] - edges[0]
        z_init = h / bh if visible[1] and visible[3] else max(w, l) / bw
    z_init = max(float(z_init), 1.5 * float(np.linalg.norm(s0)))
    # unknowns x = (T_x, T_y, T_z, s_l, s_h, s_w)
    X = np.tile(np.array([ac * z_init, bc * z_init, z_init, *s0]), (K, 1))
    rows = np.arange(K)[:, None]
    # d(corner)/d(s_i) = sign_ci * axis_i  -> (K, 8, 3 sizes, 3 xyz)
    dcorner = _CORNER_SIGNS[None, :, :, None] * axes[:, None, :, :]

    def corners_of(X: np.ndarray) -> np.ndarray:
        return X[:, None, :3] + np.einsum("kcid,ki->kcd", dcorner, X[:, 3:])

    def project_box(X: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        C = corners_of(X)
        Z = np.maximum(C[..., 2], 1e-6)
        u, v = C[..., 0] / Z, C[..., 1] / Z
        idx = np.stack([u.argmin(1), v.argmin(1), u.argmax(1), v.argmax(1)], axis=1)  # (K, 4)
        proj = np.stack([u.min(1), v.min(1), u.max(1), v.max(1)], axis=1)
        return idx, proj, C[..., 2]

    n_rows = 4 + 3 + 2
    for _ in range(iterations):
        idx, proj, Zc = project_box(X)
        A = np.zeros((K, n_rows, 6))
        b = np.zeros((K, n_rows))
        wts = np.zeros((K, n_rows))
        dc = dcorner[rows, idx]  # (K, 4 edges, 3 sizes, 3 xyz)
        for e in range(4):
            c = comp[e]
            A[:, e, c] = 1.0
            A[:, e, 2] = -edges[e]
            A[:, e, 3:] = dc[:, e, :, c] - edges[e] * dc[:, e, :, 2]
        zc = np.maximum(Zc[rows, idx], 1e-3)
        short = np.stack([proj[:, 0] > edges[0], proj[:, 1] > edges[1],
                          proj[:, 2] < edges[2], proj[:, 3] < edges[3]], axis=1)
        active = visible[None, :] | short  # cut sides: only while the projection falls short
        wts[:, :4] = np.where(active, focal / zc / edge_sigma, 0.0)
        for i in range(3):
            A[:, 4 + i, 3 + i] = 1.0
            b[:, 4 + i] = s0[i]
            wts[:, 4 + i] = 1.0 / s_sig[i]
        A[:, 7, 0], A[:, 7, 2] = 1.0, -ac
        A[:, 8, 1], A[:, 8, 2] = 1.0, -bc
        wts[:, 7] = prior_weight * intr.fx / np.maximum(X[:, 2], 1e-3) / sigma_px
        wts[:, 8] = prior_weight * intr.fy / np.maximum(X[:, 2], 1e-3) / sigma_px
        Aw = A * wts[..., None]
        bw_ = b * wts
        AtA = np.einsum("kmi,kmj->kij", Aw, Aw) + 1e-12 * np.eye(6)
        Atb = np.einsum("kmi,km->ki", Aw, bw_)
        X_new = np.linalg.solve(AtA, Atb[..., None])[..., 0]
        X_new[:, 3:] = np.maximum(X_new[:, 3:], 0.2 * s0)
        done = np.allclose(X_new, X, rtol=1e-6, atol=1e-6)
        X = X_new
        if done:
            break

    idx, proj, Zc = project_box(X)
    err = (proj - edges) * focal
    short = np.stack([err[:, 0] > 0, err[:, 1] > 0, err[:, 2] < 0, err[:, 3] < 0], axis=1)
    err = np.where(visible[None, :] | short, err, 0.0)
    edge_cost = np.sum(err**2, axis=1)
    cost = np.sum((err / edge_sigma) ** 2, axis=1) + np.sum(((X[:, 3:] - s0) / s_sig) ** 2, axis=1)
    valid = np.all(Zc > 0.05, axis=1) & np.all(np.isfinite(X), axis=1)
    if not valid.any():
        return None
    cost = np.where(valid, cost, np.inf)
    wk = np.where(valid, np.exp(-0.5 * (cost - cost.min())), 0.0)
    wk /= wk.sum()
    T = X[:, :3]
    center = (wk[:, None] * T).sum(axis=0)
    best = int(np.argmin(cost))
    spread = float(np.sqrt(np.sum(wk * np.sum((T - center) ** 2, axis=1))))
    n_edges = int(visible.sum())
    sl, sh, sw = (2.0 * float(v) for v in X[best, 3:])
    return BoxFit(
        center=center,
        yaw=float(yaws[best]),
        axes=axes[best],
        size=(sw, sh, sl),
        residual_px=float(math.sqrt(edge_cost[best] / max(n_edges, 1))),
        n_edges=n_edges,
        yaw_spread=spread,
    )


def heading_in_frame(length_axis_cam: Sequence[float], rotation_frame_cam: np.ndarray) -> float:
    """Yaw [rad] of a camera-frame length axis in a z-up frame (counter-clockwise from the frame's x),
    given the 3x3 rotation ``frame <- camera``."""
    a = np.asarray(rotation_frame_cam, dtype=np.float64) @ np.asarray(length_axis_cam, dtype=np.float64)
    return math.atan2(float(a[1]), float(a[0]))


@dataclass(frozen=True)
class GeometricEstimate:
    """An object's centre from its known size (camera frame).

    Attributes:
        center: Box centre [m].
        surface_offset: Centre depth minus the depth of the visible surface [m, optical axis]; what to
            add to a depth-map reading to get the centre depth.
        axes: Box axes (length, down, width) as rows when the yaw was fitted, else ``None``.
        method: ``box_fit`` (3D box fitted to the 2D edges) or ``ray`` (``f * h / h_px`` on the
            box-centre ray).
        fit: The :class:`BoxFit` for ``box_fit``.
    """

    center: np.ndarray
    surface_offset: float
    axes: np.ndarray | None
    method: str
    fit: BoxFit | None = None


def geometric_estimate(
    box: Box,
    size_whl: Sequence[float],
    intr: Intrinsics,
    trunc: Truncation | None = None,
    gravity_cam: Sequence[float] | None = None,
    method: str = "box_fit",
    **fit_options: object,
) -> GeometricEstimate | None:
    """The centre of an object of known size ``(w, h, l)`` [m] seen as ``box`` [px].

    ``box_fit`` (needs ``gravity_cam``): :func:`fit_box_to_2d`. ``ray`` (or when the fit is impossible):
    the paper's ``z = f * h / h_px`` (:func:`~pipeline.ranging.distance.geometric_distance`, from an uncut
    dimension) taken as the depth of the near side, on the ray through the box centre, pushed by the
    expected half depth of a footprint of unknown yaw, ``(w + l) / pi`` [m]. ``None`` when the image
    border cuts every usable dimension.
    """
    from pipeline.ranging.distance import expected_horizontal_extent, geometric_distance

    if method not in ("box_fit", "ray"):
        raise DistanceError(f"placement method must be 'box_fit' or 'ray', got {method!r}")
    x1, y1, x2, y2 = check_box(box)
    w, h, l = (float(v) for v in size_whl)
    if method == "box_fit" and gravity_cam is not None:
        fit = fit_box_to_2d(box, size_whl, gravity_cam, intr, trunc, **fit_options)  # type: ignore[arg-type]
        if fit is not None:
            offset = visible_surface_offset(fit.center, fit.axes, fit.size)
            return GeometricEstimate(fit.center, offset, fit.axes, "box_fit", fit)
    g = geometric_distance(box, h, expected_horizontal_extent(w, l), intr.fx, intr.fy, trunc)
    if g is None:
        return None
    half = (w + l) / math.pi
    c = centre_on_ray(((x1 + x2) / 2, (y1 + y2) / 2), g.distance, half, intr)
    return GeometricEstimate(c, float(c[2] - g.distance), None, "ray")
