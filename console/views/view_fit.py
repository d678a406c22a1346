"""Camera poses that fit the whole workspace (its flight volume, not only its floor) into a picture.

:func:`fit_view` looks along a given direction and moves the camera back until every corner of the
workspace box, and any extra point (the robot), falls inside a chosen part of the picture with a
margin; the point looked at is moved so that the box sits in the middle of that part. The default
view (:func:`default_view`) looks from behind the start side and above, as an operator standing at
the door would; a phone's view fits the room into the upper part of its screen, above the controls.

Frames: world z up [m]; the returned ``(position, look_at, up)`` are what viser's cameras take.
"""

from __future__ import annotations

import math
from typing import Sequence

import numpy as np

from planner.grid import Workspace

Vec3 = tuple[float, float, float]

DEFAULT_DIRECTION = (-0.33, -0.8, 0.64)
"""From the room towards the default camera (world): behind the start side (-y), a little to the
left (-x), and above (about 40 degrees down)."""

DEFAULT_ASPECT = 0.75
"""The default view is fitted for a picture this wide per its height: the 3D view between the panels of
a 1280 x 720 window (572 x 720 px), so it fits every window from there up."""

DEFAULT_FOV = 75.0 * math.pi / 180.0
"""viser's default vertical field of view [rad]."""


def _corners(workspace: Workspace, extra: Sequence[Sequence[float]] = ()) -> np.ndarray:
    (x0, y0, z0), (x1, y1, z1) = workspace.min, workspace.max
    c = np.array([[x, y, z] for x in (x0, x1) for y in (y0, y1) for z in (z0, z1)], dtype=np.float64)
    more = np.asarray(extra, dtype=np.float64).reshape(-1, 3)
    return np.vstack([c, more[np.all(np.isfinite(more), axis=1)]]) if len(more) else c


def _basis(direction: Sequence[float]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Camera axes (OpenCV: x right, y down, z forward) for a camera looking along ``-direction``, z up."""
    back = np.asarray(direction, dtype=np.float64)
    n = float(np.linalg.norm(back))
    if not (math.isfinite(n) and n > 1e-9):
        raise ValueError(f"direction: must be a non-zero finite vector, got {tuple(direction)!r}")
    fwd = -back / n
    right = np.cross(fwd, (0.0, 0.0, 1.0))
    if np.linalg.norm(right) < 1e-6:  # straight down: +y up in the picture
        right = np.array([1.0, 0.0, 0.0])
    right /= np.linalg.norm(right)
    down = np.cross(fwd, right)
    return right, down, fwd


def fit_view(workspace: Workspace, direction: Sequence[float], fov: float, aspect: float,
             extra: Sequence[Sequence[float]] = (), frame: tuple[float, float, float, float] = (0.0, 0.0, 1.0, 1.0),
             margin: float = 0.06) -> tuple[Vec3, Vec3, Vec3]:
    """A camera looking along ``-direction`` whose picture shows the whole workspace box and ``extra``.

    Args:
        workspace: The box to show (all eight corners: the flight volume).
        direction: From the room towards the camera (world), any length.
        fov: Vertical field of view [rad], in (0, pi).
        aspect: Picture width / height, > 0.
        extra: More world points [m] to keep in the picture (e.g. the robot); non-finite rows are skipped.
        frame: The part of the picture to fit into, ``(left, top, right, bottom)`` as fractions of
            its width and height (e.g. ``(0, 0, 1, 0.5)``: the upper half).
        margin: Room left inside ``frame`` on every side, as a fraction of the picture's height.

    Returns:
        ``(position, look_at, up)`` (world [m]; ``up`` is +z).
    """
    if not (math.isfinite(fov) and 0.0 < fov < math.pi):
        raise ValueError(f"fov: must be in (0, pi) rad, got {fov!r}")
    if not (math.isfinite(aspect) and aspect > 0.0):
        raise ValueError(f"aspect: must be > 0, got {aspect!r}")
    left, top, right_f, bottom = (float(v) for v in frame)
    if not (0.0 <= left < right_f <= 1.0 and 0.0 <= top < bottom <= 1.0):
        raise ValueError(f"frame: must be (left, top, right, bottom) with 0 <= left < right <= 1 and 0 <= top < bottom <= 1, got {frame!r}")
    pts = _corners(workspace, extra)
    right, down, fwd = _basis(direction)
    t = math.tan(fov / 2)
    # the frame in normalised image coordinates (x / z, y / z) with the margin taken off
    m = 2 * t * margin
    nx0, nx1 = (2 * left - 1) * t * aspect + m, (2 * right_f - 1) * t * aspect - m
    ny0, ny1 = (2 * top - 1) * t + m, (2 * bottom - 1) * t - m
    if nx1 <= nx0 or ny1 <= ny0:
        raise ValueError(f"frame: too small for the margin {margin}")
    target = pts[:8].mean(axis=0)
    dist = 1.0

    def spans(eye: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
        rel = pts - eye
        z = rel @ fwd
        if np.any(z <= 1e-6):
            return None
        return (rel @ right) / z, (rel @ down) / z, z

    for _ in range(40):  # fit the box's size into the frame, then centre it there, until it settles
        lo, hi = 0.05, 1000.0
        for _ in range(60):
            mid = (lo + hi) / 2
            uvz = spans(target - fwd * mid)
            if uvz is not None and np.ptp(uvz[0]) <= nx1 - nx0 and np.ptp(uvz[1]) <= ny1 - ny0:
                hi = mid
            else:
                lo = mid
        dist = hi
        uvz = spans(target - fwd * dist)
        assert uvz is not None
        u, v, z = uvz
        du = ((u.min() + u.max()) - (nx0 + nx1)) / 2  # how far the box sits off the frame's centre
        dv = ((v.min() + v.max()) - (ny0 + ny1)) / 2
        if abs(du) < 1e-4 and abs(dv) < 1e-4:
            break
        depth = float(z.min())  # the nearest point moves most: never overshoots, so it settles
        target = target + right * du * depth + down * dv * depth
    eye = target - fwd * dist
    return (tuple(float(v) for v in eye), tuple(float(v) for v in target), (0.0, 0.0, 1.0))  # type: ignore[return-value]


def default_view(workspace: Workspace, fov: float = DEFAULT_FOV, aspect: float = DEFAULT_ASPECT) -> tuple[Vec3, Vec3, Vec3]:
    """The console's default view: the whole workspace from behind the start side and above
    (:data:`DEFAULT_DIRECTION`), fitted for a picture ``aspect`` wide per its height."""
    return fit_view(workspace, DEFAULT_DIRECTION, fov, aspect)


def in_picture(position: Sequence[float], look_at: Sequence[float], fov: float, aspect: float,
               point: Sequence[float]) -> tuple[float, float] | None:
    """Where a world point lands in the picture of a camera at ``position`` looking at ``look_at``
    (z up): ``(x, y)`` as fractions of the width and height (0..1 inside; y down), ``None`` behind it."""
    eye = np.asarray(position, dtype=np.float64)
    right, down, fwd = _basis(eye - np.asarray(look_at, dtype=np.float64))
    rel = np.asarray(point, dtype=np.float64) - eye
    z = float(rel @ fwd)
    if z <= 1e-9:
        return None
    t = math.tan(fov / 2)
    return (0.5 + float(rel @ right) / z / (2 * t * aspect), 0.5 + float(rel @ down) / z / (2 * t))


__all__ = ["DEFAULT_ASPECT", "DEFAULT_DIRECTION", "DEFAULT_FOV", "default_view", "fit_view", "in_picture"]
