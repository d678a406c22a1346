"""The floor under the camera from the photo itself: gravity direction and camera height.

Camera frame throughout (OpenCV: x right, y down, z forward) [m]. The floor is the plane ``g . X = H``
(``g`` unit gravity-down in the camera frame, ``H`` the camera centre's height above it [m]), as in
:mod:`pipeline.ranging.ground_contact`.

The floor is described by three numbers relative to a reference gravity ``g0`` (the given or
assumed camera pose): a pitch ``theta`` (rotation of gravity about the camera x axis, positive looks
further down), a roll ``phi`` (rotation of gravity about the optical axis) and ``ln H``; a size error
common to all of a photo's contacts is a fourth parameter (:data:`COMMON_SIZE_SIGMA`), marginalised out. :func:`fit_floor` estimates them by robust (Cauchy)
least squares from up to three kinds of evidence, each with its own 1-sigma:

- **a prior** (the given pose with its small sigmas, or when no pose is given a level camera at a
  typical height with wide ones, :data:`UNKNOWN_POSE_PRIOR`);
- **object contacts**: an object standing on the floor whose box bottom the border does not cut touches
  it at the bottom-centre pixel, at the depth its size prior gives (:class:`Contact`); the floor must
  pass there (``ln(H / (g . r)) = ln z``, ``r = K^-1 [u, v, 1]``);
- **the depth map's floor plane** (:func:`plane_from_depth`): a RANSAC plane through the lower image's
  back-projected depth points outside the detected boxes, refitted on its inliers; it gives the
  gravity direction (two angles, to the spread of its inliers) and, in the depth map's metric scale,
  the height.

The result (:class:`FloorEstimate`) carries the posterior covariance of ``(theta, phi, ln H)``: the
ground-contact cue propagates it to each object's distance (:func:`contact_sigma`), so an uncertain floor
widens the ground-contact sigma instead of moving objects. :func:`fit_floor` with ``leave_out=i`` leaves
one contact out: the ground contact of object ``i`` then does not reuse its own size prior.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Sequence

import numpy as np
from scipy.optimize import least_squares

from pipeline.camera.geometry import Intrinsics


class FloorFitError(ValueError):
    """Invalid input to the floor fit (non-finite or out-of-range value, named)."""


@dataclass(frozen=True)
class FloorPrior:
    """What is believed about the floor before looking at the photo.

    Attributes:
        gravity_cam: Reference unit gravity-down vector (camera frame).
        camera_height: Camera centre above the floor [m], > 0.
        sigma_pitch: 1-sigma of the pitch about it [rad].
        sigma_roll: 1-sigma of the roll [rad].
        sigma_log_height: 1-sigma of ``ln H`` (relative height error).
    """

    gravity_cam: tuple[float, float, float]
    camera_height: float
    sigma_pitch: float
    sigma_roll: float
    sigma_log_height: float

    def __post_init__(self) -> None:
        g = np.asarray(self.gravity_cam, dtype=np.float64).reshape(-1)
        if g.shape != (3,) or not np.all(np.isfinite(g)) or abs(float(np.linalg.norm(g)) - 1.0) > 1e-3:
            raise FloorFitError(f"gravity_cam: must be a unit 3-vector (camera frame), got {self.gravity_cam!r}")
        if not (math.isfinite(self.camera_height) and 0 < self.camera_height <= 100):
            raise FloorFitError(f"camera_height: must be within 0..100 m, got {self.camera_height!r}")
        for key in ("sigma_pitch", "sigma_roll", "sigma_log_height"):
            v = getattr(self, key)
            if not (isinstance(v, (int, float)) and math.isfinite(v) and v > 0):
                raise FloorFitError(f"{key}: must be a finite number > 0, got {v!r}")


UNKNOWN_POSE_PRIOR = dict(camera_height=1.5, sigma_pitch=math.radians(20.0), sigma_roll=math.radians(8.0),
                          sigma_log_height=0.5)
"""The prior of a photo whose pose is not given: a level camera 1.5 m up (a handheld photo, a car's
camera; 0.9-2.5 m within 1 sigma), pitch +-20 deg, roll +-8 deg. Only a starting point: contacts
and the depth map's floor decide."""


@dataclass(frozen=True)
class Contact:
    """Where one object touches the floor, as its size prior says.

    Attributes:
        uv: The box's bottom-centre pixel [px].
        depth: Optical-axis depth of that floor point [m] (size-prior centre depth minus the half footprint).
        rel_sigma: Its relative 1-sigma (size spread, box pixels, footprint).
        label: The object's class (for notes).
    """

    uv: tuple[float, float]
    depth: float
    rel_sigma: float
    label: str = ""

    def __post_init__(self) -> None:
        if not (len(self.uv) == 2 and all(math.isfinite(float(v)) for v in self.uv)):
            raise FloorFitError(f"contact uv: must be two finite pixel coordinates, got {self.uv!r}")
        if not (math.isfinite(self.depth) and self.depth > 0):
            raise FloorFitError(f"contact depth: must be a finite number > 0 [m], got {self.depth!r}")
        if not (math.isfinite(self.rel_sigma) and self.rel_sigma > 0):
            raise FloorFitError(f"contact rel_sigma: must be a finite number > 0, got {self.rel_sigma!r}")


@dataclass(frozen=True)
class DepthPlane:
    """The floor plane found in the metric depth map (camera frame).

    Attributes:
        gravity_cam: Unit plane normal pointing down (away from the camera).
        camera_height: Camera centre's distance to the plane [m] (in the depth map's scale).
        n_inliers: Depth points on the plane.
        inlier_share: Their share of the sampled lower-image points.
        sigma_angle: 1-sigma of the normal's direction [rad] (inlier spread, with a floor for the depth
            model's own distortion, :data:`MIN_PLANE_ANGLE_SIGMA`).
        sigma_log_height: 1-sigma of ``ln`` of the support point's height over the plane (the depth
            scale's uncertainty dominates).
        support_point: The inliers' centroid [m] (camera frame): the height is measured there, so a
            tilted candidate floor meets it lower or higher (the plane's pitch and height errors are
            correlated through it, not independent).
    """

    gravity_cam: tuple[float, float, float]
    camera_height: float
    n_inliers: int
    inlier_share: float
    sigma_angle: float
    sigma_log_height: float
    support_point: tuple[float, float, float] = (0.0, 0.0, 0.0)


@dataclass(frozen=True)
class FloorEstimate:
    """The fitted floor: gravity and camera height, with the covariance of ``(pitch, roll, ln H)``.

    Attributes:
        gravity_cam: Unit gravity-down vector (camera frame).
        camera_height: Camera centre above the floor [m].
        reference: The prior's gravity ``g0`` the angles are measured from.
        angles: ``(pitch, roll)`` [rad] relative to ``reference``.
        covariance: 3x3 covariance of ``(pitch, roll, ln H)``.
        n_contacts: Object contacts used.
        plane: The depth map's plane, when it was used.
        note: How it was obtained.
    """

    gravity_cam: tuple[float, float, float]
    camera_height: float
    reference: tuple[float, float, float]
    angles: tuple[float, float]
    covariance: tuple[tuple[float, float, float], ...]
    n_contacts: int
    plane: DepthPlane | None
    note: str

    @property
    def sigma_pitch(self) -> float:
        """1-sigma of the pitch [rad]."""
        return math.sqrt(self.covariance[0][0])

    @property
    def sigma_roll(self) -> float:
        """1-sigma of the roll [rad]."""
        return math.sqrt(self.covariance[1][1])

    @property
    def sigma_height(self) -> float:
        """1-sigma of the camera height [m]."""
        return self.camera_height * math.sqrt(self.covariance[2][2])

    @property
    def pitch_deg(self) -> float:
        """Downward tilt of the optical axis against the horizon [deg] (from the gravity vector)."""
        g = self.gravity_cam
        return math.degrees(math.atan2(g[2], math.hypot(g[0], g[1])))

    @property
    def roll_deg(self) -> float:
        """Roll about the optical axis [deg] (from the gravity vector)."""
        g = self.gravity_cam
        return math.degrees(math.atan2(g[0], g[1]))


COMMON_SIZE_SIGMA = 0.08
"""Relative 1-sigma of a size error all of a photo's contacts share: class means can be off together (a
street of SUVs against the catalog's 1.50 m car is +15 %; KITTI's sedans are 1.56 m). Without it 27
nuScenes contacts would pin the camera height to 8 % and call the given pose wrong."""

MIN_PLANE_ANGLE_SIGMA = math.radians(2.0)
"""A depth model's floor is never flatter than this (blurry, warped near the borders): the plane's
normal is known at best to 2 deg, however many points it has."""
MIN_PLANE_LOG_HEIGHT_SIGMA = 0.1
"""The plane's height is in the depth map's scale, fitted from the objects: at best 10 %."""
NORMAL_MAX_TILT_DEG = 60.0
"""A depth point whose surface normal (from its lattice neighbours) is tilted more than this from the
prior gravity is on a wall or an object's face, not a floor candidate (wide: a learned map's noise
tilts a floor's local normals by tens of degrees; a wall is at 90)."""
BELOW_COST = 4.0
"""MSAC cost of a depth point lying below a candidate floor (beyond the tolerance), against 1 for any
other outlier: the floor is the lowest surface in view, so box tops with the floor seen past them lose."""
MAX_BELOW_SHARE = 0.1
BELOW_REL = 0.25
"""A plane with MAX_BELOW_SHARE of the points (at least 10) more than BELOW_REL of its height below it is
not the floor (the floor seen past a line of boxes whose tops it is): no plane."""
MIN_PLANE_ROWS = 3
"""Distinct lattice rows a floor plane's inliers must span (one row's points lie on a plane through the
camera centre whatever the scene)."""
MIN_PLANE_HEIGHT_REL = 0.05
"""A plane passing closer to the camera than this share of its support's distance is seen edge-on
(grazing): its tilt and height are not told by the points."""
PLANE_MIN_TOL = 0.005
PLANE_MIN_TOL_REL = 0.005
"""The depth map's noise floor: a point ``|X|`` metres away is within ``0.5 cm + 0.5 % |X|`` of its
surface at best (a simulator's render; a learned map's own spread re-selects wider, up to the RANSAC
tolerance)."""


def _rotate(g0: np.ndarray, pitch: float, roll: float) -> np.ndarray:
    """``R_z(roll) R_x(pitch) g0``: gravity after pitching the camera by ``pitch`` and rolling by ``roll`` [rad]."""
    cp, sp, cr, sr = math.cos(pitch), math.sin(pitch), math.cos(roll), math.sin(roll)
    x, y, z = g0
    y, z = cp * y + sp * z, -sp * y + cp * z
    x, y = cr * x - sr * y, sr * x + cr * y
    return np.array([x, y, z])


def rotate_gravity(g: Sequence[float], pitch: float, roll: float) -> np.ndarray:
    """Gravity (camera frame) after pitching the camera by ``pitch`` (about x) and rolling it by ``roll``
    (about the optical axis) [rad], as the fit's angles are defined."""
    return _rotate(np.asarray(g, dtype=np.float64), pitch, roll)


def _rays(uv: np.ndarray, intr: Intrinsics) -> np.ndarray:
    """Rays ``(x_n, y_n, 1)`` (N x 3) through undistorted pixels."""
    p = intr.undistort_pixels(np.asarray(uv, dtype=np.float64).reshape(-1, 2))
    return np.stack([(p[:, 0] - intr.cx) / intr.fx, (p[:, 1] - intr.cy) / intr.fy, np.ones(len(p))], axis=1)


def plane_from_depth(depth_m: np.ndarray, intr: Intrinsics, prior_gravity: Sequence[float],
                     exclude: np.ndarray | None = None, *, max_tilt_deg: float = 35.0, grid: int = 48,
                     iterations: int = 300, tol_rel: float = 0.04, seed: int = 0) -> DepthPlane | None:
    """The floor plane of a metric depth map (H x W, metres along the optical axis; NaN / <= 0 invalid).

    Points on a ``grid`` x ``grid`` lattice of the image's lower half (below the principal point),
    outside ``exclude`` (H x W bool: the detected objects' boxes), are back-projected. RANSAC (fixed
    ``seed``: the same photo gives the same plane) keeps the plane of least truncated squared residual
    (MSAC, tolerance ``tol_rel * |X| + 2 cm``) whose normal lies within ``max_tilt_deg`` of
    ``prior_gravity`` and which passes below the camera; it is refitted to its inliers (least squares,
    SVD), re-selected within three robust residual scales (never tighter than the map's noise floor,
    :data:`PLANE_MIN_TOL`, nor wider than the tolerance). Its sigmas come from how well the inliers pin
    it down (the residual RMS over the support's extent: a narrow strip of floor is uncertain). ``None``
    with fewer than 30 valid points, fewer than 25 inliers or inliers under 20 % of the points.
    """
    d = np.asarray(depth_m, dtype=np.float64)
    if d.ndim != 2:
        raise FloorFitError(f"depth_m: must be H x W, got shape {d.shape}")
    h, w = d.shape
    if (w, h) != (intr.width, intr.height):
        raise FloorFitError(f"depth_m: {w}x{h} does not match the intrinsics' {intr.width}x{intr.height} image")
    g0 = np.asarray(prior_gravity, dtype=np.float64)
    g0 = g0 / np.linalg.norm(g0)
    v0 = int(min(max(intr.cy, 0.3 * h), 0.8 * h))
    us = np.linspace(0.02 * w, 0.98 * w, grid).astype(int)
    vs = np.linspace(v0, h - 2, max(grid // 2, 8)).astype(int)
    uu, vv = np.meshgrid(us, vs)
    z = d[vv, uu]
    ok = np.isfinite(z) & (z > 0)
    # the surface's own normal on the lattice (central differences of the back-projected points): a
    # wall or a box's face is no floor, however close to the floor its foot lies
    lattice = _rays(np.stack([uu.ravel(), vv.ravel()], axis=1), intr).reshape(*uu.shape, 3) * np.where(
        ok, z, np.nan)[..., None]
    normal = np.cross(np.gradient(lattice, axis=1), np.gradient(lattice, axis=0))
    cos_n = np.abs(normal @ g0) / np.maximum(np.linalg.norm(normal, axis=-1), 1e-12)
    ok &= ~(cos_n < math.cos(math.radians(NORMAL_MAX_TILT_DEG)))  # NaN normals (a lattice edge) stay
    uu, vv, z, ok = uu.ravel(), vv.ravel(), z.ravel(), ok.ravel()
    if exclude is not None:
        ok &= ~np.asarray(exclude, dtype=bool)[vv, uu]
    if int(ok.sum()) < 30:
        return None
    pts = _rays(np.stack([uu[ok], vv[ok]], axis=1), intr) * z[ok, None]
    n_pts = len(pts)
    rng = np.random.default_rng(seed)
    dist = np.linalg.norm(pts, axis=1)
    tol = tol_rel * dist + 0.02
    tight = PLANE_MIN_TOL_REL * dist + PLANE_MIN_TOL
    cos_max = math.cos(math.radians(max_tilt_deg))
    best: tuple[float, np.ndarray] | None = None
    for _ in range(iterations):
        a, b, c = pts[rng.choice(n_pts, 3, replace=False)]
        n = np.cross(b - a, c - a)
        nn = float(np.linalg.norm(n))
        if nn < 1e-9:
            continue
        n /= nn
        if float(n @ g0) < 0:
            n = -n
        if float(n @ g0) < cos_max:
            continue
        hh = float(n @ a)
        if hh <= 0:
            continue
        # MSAC: the truncated squared residual, so the plane the points lie ON beats a tilted one that
        # merely keeps the floor and a wall's foot within the tolerance band
        res = pts @ n - hh
        r2 = np.minimum(res**2, tol**2) / tol**2
        # the floor is the lowest surface the camera sees: a point well below a candidate (the floor
        # seen past a line of boxes whose tops the candidate is) counts against it BELOW_COST times
        cost = float(r2.sum()) + (BELOW_COST - 1.0) * float(np.count_nonzero(res > tol))
        if best is None or cost < best[0]:
            best = (cost, np.abs(pts @ n - hh) <= tol)
    if best is None or int(best[1].sum()) < 25 or int(best[1].sum()) < 0.2 * n_pts:
        return None
    rows = vv[ok]
    inl = best[1]
    for _ in range(3):  # refit on the inliers, then re-select them within the map's own noise
        q = pts[inl]
        c = q.mean(axis=0)
        _, s, vt = np.linalg.svd(q - c, full_matrices=False)
        n = vt[2] if float(vt[2] @ g0) > 0 else -vt[2]
        hh = float(n @ c)
        if hh <= 0 or float(n @ g0) < cos_max:
            return None
        res = pts @ n - hh
        scale = 1.4826 * float(np.median(np.abs(res[inl])))  # robust residual scale of the inliers
        inl = np.abs(res) <= np.clip(3.0 * scale, tight, tol)
        if int(inl.sum()) < 25:
            return None
    q = pts[inl]
    c = q.mean(axis=0)
    _, s, vt = np.linalg.svd(q - c, full_matrices=False)
    n = vt[2] if float(vt[2] @ g0) > 0 else -vt[2]
    hh = float(n @ c)
    if hh <= 0 or float(n @ g0) < cos_max:
        return None
    # points of fewer than three image rows lie on planes through the camera centre (one row's rays
    # span one): such a "floor" tells neither tilt nor height; nor does a plane the camera nearly lies in
    if len(np.unique(rows[inl])) < MIN_PLANE_ROWS or hh < MIN_PLANE_HEIGHT_REL * float(np.linalg.norm(c)):
        return None
    # the floor is the lowest surface in view: a plane with many points far below it is box tops, a desk
    # (a floor point's depth error e moves it e * H off the floor: BELOW_REL is a 25 % depth error)
    below = pts @ n - hh > np.maximum(BELOW_REL * hh, tight)
    if int(np.count_nonzero(below)) >= max(10, MAX_BELOW_SHARE * n_pts):
        return None
    res = q @ n - hh
    # how well the points pin the plane down: their residuals (a depth model's warp, a wall's foot, the
    # map's noise floor) are systematic, not independent, so they tilt the plane by about their RMS over
    # the support's RMS extent along its shorter axis (s[1] / sqrt(N)); a narrow strip of floor (a wall
    # or a stack of boxes close ahead) thus widens its own sigma, however many points it has
    spread = max(float(np.sqrt(np.mean(res**2))), 0.5 * float(np.mean(tight[inl])))
    extent = max(float(s[1]) / math.sqrt(len(q)), 1e-6)
    angle = max(math.atan2(spread, extent), MIN_PLANE_ANGLE_SIGMA)
    # the height is known where the points are (their centroid); the fit extrapolates it to the camera
    # along its own candidate floor, so a tilt error does not pass for a height error
    return DepthPlane(tuple(float(v) for v in n), hh, int(inl.sum()), float(inl.mean()), angle,  # type: ignore[arg-type]
                      math.hypot(MIN_PLANE_LOG_HEIGHT_SIGMA, spread / hh), tuple(float(v) for v in c))  # type: ignore[arg-type]


def _angles_of(g: np.ndarray, g0: np.ndarray) -> tuple[float, float]:
    """``(pitch, roll)`` with ``_rotate(g0, pitch, roll) ~ g`` (solved numerically, small angles)."""
    def res(x: np.ndarray) -> np.ndarray:
        return _rotate(g0, x[0], x[1]) - g
    sol = least_squares(res, np.zeros(2))
    return float(sol.x[0]), float(sol.x[1])


def fit_floor(prior: FloorPrior, contacts: Sequence[Contact], intr: Intrinsics,
              plane: DepthPlane | None = None, *, leave_out: int | None = None,
              robust: float = 1.5) -> FloorEstimate:
    """The floor from ``prior``, ``contacts`` and the depth map's ``plane`` (module docstring).

    Robust least squares (Cauchy loss at ``robust`` sigmas: a misdetected or half-hidden object's
    contact, read as a wrong size, loses its pull instead of tilting the floor) on the normalised residuals; the covariance is the inverse of the Gauss-Newton
    Hessian at the solution. ``leave_out``: index of a contact to ignore.
    """
    g0 = np.asarray(prior.gravity_cam, dtype=np.float64)
    use = [c for i, c in enumerate(contacts) if i != leave_out]
    rays = _rays(np.array([c.uv for c in use]), intr) if use else np.zeros((0, 3))
    log_z = np.array([math.log(c.depth) for c in use])
    sig = np.array([c.rel_sigma for c in use])
    lh0 = math.log(prior.camera_height)
    plane_ang = None
    if plane is not None:
        plane_ang = _angles_of(np.asarray(plane.gravity_cam), g0)

    def residuals(x: np.ndarray) -> np.ndarray:
        pitch, roll, lh, common = x
        out = [pitch / prior.sigma_pitch, roll / prior.sigma_roll, (lh - lh0) / prior.sigma_log_height,
               common / COMMON_SIZE_SIGMA]
        if plane is not None and plane_ang is not None:
            # the plane's height where its points are: the candidate floor's distance below them
            below = float(np.asarray(plane.support_point) @ _rotate(g0, pitch, roll))
            h_support = plane.camera_height if not any(plane.support_point) else max(below, 1e-3)
            out += [(pitch - plane_ang[0]) / plane.sigma_angle, (roll - plane_ang[1]) / plane.sigma_angle,
                    (lh - math.log(h_support)) / plane.sigma_log_height]
        if len(use):
            g = _rotate(g0, pitch, roll)
            gr = np.maximum(rays @ g, 1e-3)
            out += list((lh - np.log(gr) - log_z - common) / sig)
        return np.asarray(out, dtype=np.float64)

    x0 = np.array([0.0, 0.0, lh0, 0.0])
    if plane_ang is not None:
        x0 = np.array([plane_ang[0], plane_ang[1], lh0, 0.0])
    sol = least_squares(residuals, x0, loss="cauchy", f_scale=robust, x_scale=[0.1, 0.1, 0.3, 0.1])
    J = sol.jac
    try:
        cov = np.linalg.inv(J.T @ J)[:3, :3]  # the common size scale marginalised out
    except np.linalg.LinAlgError:
        cov = np.diag([prior.sigma_pitch**2, prior.sigma_roll**2, prior.sigma_log_height**2])
    cov = 0.5 * (cov + cov.T)
    pitch, roll, lh = (float(v) for v in sol.x[:3])
    g = _rotate(g0, pitch, roll)
    g = g / np.linalg.norm(g)
    parts = [f"{len(use)} object contact{'s' if len(use) != 1 else ''}"]
    if plane is not None:
        parts.append(f"depth-map floor ({plane.n_inliers} points, {plane.inlier_share:.0%} of the lower image)")
    est = FloorEstimate(tuple(float(v) for v in g), math.exp(lh), tuple(float(v) for v in g0),  # type: ignore[arg-type]
                        (pitch, roll), tuple(tuple(float(v) for v in row) for row in cov),  # type: ignore[arg-type]
                        len(use), plane, "")
    note = (f"floor from the photo: pitch {est.pitch_deg:.1f} +- {math.degrees(est.sigma_pitch):.1f} deg, roll "
            f"{est.roll_deg:.1f} +- {math.degrees(est.sigma_roll):.1f} deg, camera {est.camera_height:.2f} +- "
            f"{est.sigma_height:.2f} m up ({', '.join(parts)})")
    return FloorEstimate(est.gravity_cam, est.camera_height, est.reference, est.angles, est.covariance,
                         est.n_contacts, plane, note)


def contact_sigma(floor: FloorEstimate, uv: Sequence[float], intr: Intrinsics) -> float:
    """Relative 1-sigma of the floor distance at pixel ``uv`` [px] that the floor's own uncertainty
    causes (its full covariance propagated: pitch and height errors that cancel for the contacts the
    floor was fitted to do not add up). ``inf`` when the ray misses the floor."""
    g0 = np.asarray(floor.reference, dtype=np.float64)
    r = _rays(np.asarray(uv, dtype=np.float64).reshape(1, 2), intr)[0]
    pitch, roll = floor.angles

    def log_t(p: float, q: float) -> float:
        gr = float(r @ _rotate(g0, p, q))
        return -math.log(gr) if gr > 1e-3 else float("inf")

    eps = 1e-4
    base = log_t(pitch, roll)
    if not math.isfinite(base):
        return float("inf")
    grad = np.array([(log_t(pitch + eps, roll) - log_t(pitch - eps, roll)) / (2 * eps),
                     (log_t(pitch, roll + eps) - log_t(pitch, roll - eps)) / (2 * eps), 1.0])
    if not np.all(np.isfinite(grad)):
        return float("inf")
    return float(math.sqrt(max(grad @ np.asarray(floor.covariance) @ grad, 0.0)))


def disagreement(given: FloorPrior, fitted: FloorEstimate) -> float:
    """Mahalanobis distance [sigmas] between the given pose and the floor fitted from the photo (with a
    wide prior), on ``(pitch, roll, ln H)`` with both covariances."""
    d = np.array([fitted.angles[0], fitted.angles[1],
                  math.log(fitted.camera_height) - math.log(given.camera_height)])
    C = np.asarray(fitted.covariance) + np.diag([given.sigma_pitch**2, given.sigma_roll**2, given.sigma_log_height**2])
    return float(math.sqrt(max(d @ np.linalg.solve(C, d), 0.0)))


__all__ = ["Contact", "DepthPlane", "FloorEstimate", "FloorFitError", "FloorPrior", "MIN_PLANE_ANGLE_SIGMA",
           "UNKNOWN_POSE_PRIOR", "contact_sigma", "disagreement", "fit_floor", "plane_from_depth", "rotate_gravity"]
