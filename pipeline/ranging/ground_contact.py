"""Ground-contact ranging: how far an object standing on the floor is, from where it touches it.

Camera frame throughout (OpenCV: x right, y down, z forward) [m]; pixels [px]. The floor is the plane
``g . X = H``: ``g`` the unit gravity-down vector in the camera frame, ``H`` the camera centre's
height above the floor [m] (camera mount + robot pose; a captures or bench sample's
``camera_height``).

For an object standing on the floor whose box bottom is not cut by the image border, the ray through
the bottom-centre pixel ``(u_c, y2)`` meets the floor at ``P = H / (g . r) * r`` (``r = K^-1 [u, v,
1]``): the footprint's nearest point. The object's centre is behind it by the expected half depth of
the footprint along the view and above it by half the object's height:
``C = P + half * e_h - (h / 2) * g`` with ``e_h`` the horizontal direction of ``P``.

Error model of the centre's optical-axis depth ``z`` (documented in the README): for a ray at angle
``theta`` below the horizon, the floor distance is ``d = H / tan(theta)``, so

- a pitch error ``sigma_pitch`` [rad] moves it by ``|dd/dtheta| sigma_pitch = (d^2 + H^2) / H *
  sigma_pitch`` (about ``d^2 / H * sigma_pitch``);
- the bottom edge's pixel error ``sigma_v`` [px] acts like a pitch error of ``sigma_v / f``;
- an error ``sigma_H`` of the camera height, and the floor under the object not being exactly the
  plane (``sigma_floor``: slopes, thresholds, a rug), scale it: ``d / H * sqrt(sigma_H^2 + sigma_floor^2)``;
- the half depth of a footprint of unknown yaw adds its own spread (``half_sigma``).

:func:`ground_contact_cue` evaluates these derivatives numerically on the real geometry (any pitch and
roll) and adds them in quadrature:
``sigma_z^2 = (dz/dtheta)^2 (sigma_pitch^2 + (sigma_v / f)^2) + (dz/dH)^2 (sigma_H^2 + sigma_floor^2)
+ (dz/dhalf)^2 half_sigma^2``.

A box cut by the *bottom* border gives no contact point, but a bound (:func:`border_bound`): the contact
lies below the border, hence nearer than the floor seen at the border row.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Sequence

import numpy as np

from pipeline.camera.floor_fit import FloorEstimate, contact_sigma
from pipeline.ranging.distance import Box, DistanceError, Truncation, check_box
from pipeline.ranging.fusion import Cue
from pipeline.camera.geometry import Intrinsics
from pipeline.ranging.placement import gravity_basis

MIN_DEPRESSION = math.radians(0.5)
"""Rays less than this below the horizon [rad] do not meet the floor usefully (the distance diverges)."""


@dataclass(frozen=True)
class GroundModel:
    """What is known about the floor under the camera.

    Attributes:
        gravity_cam: Unit gravity-down vector, camera frame.
        camera_height: Camera centre above the floor [m], > 0.
        sigma_pitch: 1-sigma of the camera's pitch (and roll) knowledge [rad].
        sigma_height: 1-sigma of ``camera_height`` [m].
        sigma_floor: 1-sigma of the floor under an object differing from the plane [m].
        sigma_px: 1-sigma of a box's bottom edge [px] (at least; 2 % of the box height is used when larger).
    """

    gravity_cam: tuple[float, float, float]
    camera_height: float
    sigma_pitch: float = 0.01
    sigma_height: float = 0.03
    sigma_floor: float = 0.05
    sigma_px: float = 1.5
    floor: FloorEstimate | None = None
    """The floor as fitted from the photo (:mod:`pipeline.camera.floor_fit`); when set, its covariance of
    (pitch, roll, ln H) replaces ``sigma_pitch`` and ``sigma_height`` in the contact's sigma."""
    widened: str = ""
    """Why this floor is less certain than the given pose says (the photo disagrees with it, the ground
    under the objects is uneven); the contact cue carries it as its ``down_weighted`` reason."""

    def __post_init__(self) -> None:
        g = np.asarray(self.gravity_cam, dtype=np.float64).reshape(-1)
        if g.shape != (3,) or not np.all(np.isfinite(g)) or abs(float(np.linalg.norm(g)) - 1.0) > 1e-3:
            raise DistanceError(f"gravity_cam: must be a unit 3-vector (camera frame), got {self.gravity_cam!r}")
        if not (math.isfinite(self.camera_height) and 0 < self.camera_height <= 100):
            raise DistanceError(f"camera_height: must be within 0..100 m (above the floor), got {self.camera_height!r}")
        for key in ("sigma_pitch", "sigma_height", "sigma_floor", "sigma_px"):
            v = getattr(self, key)
            if not (math.isfinite(v) and v >= 0):
                raise DistanceError(f"{key}: must be a finite number >= 0, got {v!r}")


def floor_point(uv: Sequence[float], gravity_cam: Sequence[float], camera_height: float,
                intr: Intrinsics) -> np.ndarray | None:
    """Camera-frame point [m] where the ray through pixel ``uv`` meets the floor ``g . X = H``;
    ``None`` when the ray is less than :data:`MIN_DEPRESSION` below the horizon."""
    p = intr.undistort_pixels(np.asarray(uv, dtype=np.float64))[0]
    r = np.array([(p[0] - intr.cx) / intr.fx, (p[1] - intr.cy) / intr.fy, 1.0])
    g = np.asarray(gravity_cam, dtype=np.float64)
    gr = float(g @ r)
    if gr <= math.sin(MIN_DEPRESSION) * float(np.linalg.norm(r)):
        return None
    return camera_height / gr * r


def centre_from_contact(contact: np.ndarray, gravity_cam: Sequence[float], half_depth: float,
                        centre_height: float) -> np.ndarray:
    """Object centre [m]: ``half_depth`` [m] behind the floor point ``contact`` (horizontally, away from
    the camera) and ``centre_height`` [m] above it."""
    g = np.asarray(gravity_cam, dtype=np.float64)
    horiz = contact - float(contact @ g) * g
    n = float(np.linalg.norm(horiz))
    e_h = horiz / n if n > 1e-9 else np.zeros(3)
    return contact + half_depth * e_h - centre_height * g


def _tilted(gravity_cam: np.ndarray, angle: float) -> np.ndarray:
    """Gravity rotated by ``angle`` [rad] about the camera's horizontal x axis (a pitch change)."""
    e1, down, _ = gravity_basis(gravity_cam)
    return math.cos(angle) * down + math.sin(angle) * np.cross(e1, down)


def _centre_z(u: float, v: float, g: np.ndarray, H: float, intr: Intrinsics, half: float, hc: float) -> float | None:
    p = floor_point((u, v), g, H, intr)
    if p is None:
        return None
    return float(centre_from_contact(p, g, half, hc)[2])


def ground_contact_cue(
    box: Box,
    trunc: Truncation,
    ground: GroundModel,
    intr: Intrinsics,
    half_depth: float,
    half_sigma: float,
    centre_height: float,
) -> tuple[Cue, np.ndarray] | None:
    """The centre depth [m] of an object standing on the floor, with its sigma (see the module
    docstring), and the centre (camera frame [m]).

    Args:
        box: The object's 2D box [px].
        trunc: Which sides the border cuts; a cut bottom gives ``None`` (see :func:`border_bound`).
        ground: Gravity, camera height and their uncertainties.
        intr: Camera intrinsics.
        half_depth: Expected distance [m] from the footprint's nearest point to the centre along the view.
        half_sigma: Its 1-sigma [m].
        centre_height: Height of the centre above the floor [m] (half the object's height).

    ``None`` when the bottom is cut or the bottom ray does not meet the floor in front of the camera.
    """
    x1, y1, x2, y2 = check_box(box)
    if trunc.bottom:
        return None
    for key, v in (("half_depth", half_depth), ("half_sigma", half_sigma), ("centre_height", centre_height)):
        if not (math.isfinite(v) and v >= 0):
            raise DistanceError(f"{key}: must be a finite number >= 0 [m], got {v!r}")
    g = np.asarray(ground.gravity_cam, dtype=np.float64)
    H = ground.camera_height
    u = 0.5 * (x1 + x2)
    p = floor_point((u, y2), g, H, intr)
    if p is None:
        return None
    c = centre_from_contact(p, g, half_depth, centre_height)
    z = float(c[2])
    if not z > 0:
        return None
    eps = 1e-4
    dz = []
    zt = _centre_z(u, y2, _tilted(g, eps), H, intr, half_depth, centre_height)
    zt2 = _centre_z(u, y2, _tilted(g, -eps), H, intr, half_depth, centre_height)
    if zt is None or zt2 is None:
        return None
    d_theta = abs(zt - zt2) / (2 * eps)
    sigma_v = max(ground.sigma_px, 0.02 * (y2 - y1))
    z_h = _centre_z(u, y2, g, H * (1 + eps), intr, half_depth, centre_height)
    if z_h is None:
        return None
    d_h = abs(z_h - z) / (H * eps)
    e_h = c - p + centre_height * g
    d_half = abs(float(e_h[2]) / half_depth) if half_depth > 0 else 1.0
    if ground.floor is None:
        dz.append(d_theta * math.hypot(ground.sigma_pitch, sigma_v / intr.fy))
        dz.append(d_h * math.hypot(ground.sigma_height, ground.sigma_floor))
    else:  # the fitted floor's covariance, propagated to this pixel (floor-to-contact depth: ~ z - half)
        t = float(p[2])
        dz.append(math.hypot(t * contact_sigma(ground.floor, (u, y2), intr), d_theta * sigma_v / intr.fy))
        dz.append(d_h * ground.sigma_floor)
        if not all(math.isfinite(v) for v in dz):
            return None
    dz.append(d_half * half_sigma)
    sigma = math.sqrt(sum(v * v for v in dz))
    note = (f"floor at {float(np.linalg.norm(p)):.2f} m under the box bottom (row {y2:.0f}), camera {H:.2f} m up; "
            f"sigma: pitch/pixel {dz[0]:.2f} m, height {dz[1]:.2f} m, footprint {dz[2]:.2f} m")
    return Cue("ground_contact", z, max(sigma, 1e-3), note, ground.widened), c


def border_bound(
    box: Box,
    image_height: int,
    ground: GroundModel,
    intr: Intrinsics,
    half_depth: float,
    half_sigma: float,
    centre_height: float,
) -> tuple[float, float] | None:
    """``(bound, sigma)`` [m] on the centre depth of a floor-standing object whose box the *bottom*
    border cuts: its contact point lies below the last image row, so it is nearer than the floor seen
    there; the centre is at most that far plus the half depth. ``sigma`` holds the floor point's pitch,
    height and footprint errors (as in :func:`ground_contact_cue`). ``None`` when the border row does
    not see the floor (it is above the horizon)."""
    x1, _, x2, _ = check_box(box)
    row = float(image_height)
    fake = (x1, row - 10.0, x2, row)
    cue = ground_contact_cue(fake, Truncation(), ground, intr, half_depth, half_sigma, centre_height)
    if cue is None:
        return None
    return cue[0].distance, cue[0].sigma


__all__ = ["GroundModel", "MIN_DEPRESSION", "border_bound", "centre_from_contact", "floor_point", "ground_contact_cue"]
