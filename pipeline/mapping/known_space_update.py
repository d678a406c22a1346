"""One capture's update of the known space: rays from the camera through a (scaled) depth map.

For every sampled pixel the ray from the camera centre is cast through the world grid of a
:class:`~pipeline.mapping.known_space.KnownSpace` (OctoMap's free-space update):

- cells the ray passes before the depth surface, less its uncertainty ``sigma(z)``, are *seen free*
  (a miss), up to ``max_range`` [m] of depth;
- cells in the band ``z - sigma .. z + sigma`` around the surface (at least the cell the surface
  point falls in) are *occupied* (a hit), unless the surface is the **floor** (the point lies at most
  ``floor_band`` [m] above the grid's floor: the floor is the grid's bottom face, not an obstacle)
  or a **side face of the grid** (within ``sigma + 0.02`` m of the grid's x/y/z limits: the room's
  walls and ceiling stand there; the workspace already bounds the planner);
- cells behind the band keep what they held; each cell changes at most once per capture, a hit
  winning over a miss (:meth:`KnownSpace.updated`).

Depth is the distance along the optical axis [m] (camera frame z, OpenCV optical frame x right,
y down, z forward); ``camera`` is the pose ``world <- camera``. Pixels with no reading (``<= 0``, NaN
or inf) are skipped; readings beyond ``max_range`` mark free up to ``max_range`` and no hit. Lens
distortion is ignored (the sampled pixels are taken as undistorted). Pixels are sampled every
``pixel_step`` pixels in both directions (default :func:`default_pixel_step`: rays about half a
cell apart at 8 m), ray samples every quarter cell: a ray can skip the corner of a cell, which
then stays as it was (never wrongly free).

Where no depth model runs, :func:`box_depth` makes the depth map from the mapped objects' boxes and
the floor: rays are free up to the first mapped box (or the floor, or ``max_range``); such a map
cannot see what the detector missed. :func:`explained_share` says how much of a capture's near depth
the mapped objects explain (the capture panel warns when it is low).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from typing import Sequence

import numpy as np
from numba import njit

from pipeline.camera.geometry import Intrinsics, Pose
from pipeline.mapping.known_space import EXPLAINED_TOLERANCE, KnownSpace, KnownSpaceError, box_contains
from pipeline.scene import SceneObject

MAX_RANGE = 8.0
"""Depth [m] beyond which a reading only marks free space up to this range (no hit)."""

FLOOR_BAND = 0.10
"""Surfaces at most this high [m] above the floor are the floor (not obstacles), for a depth with noise
(a depth model's scaled map): nearer the floor its noise cannot tell a surface from the floor."""

FLOOR_BAND_EXACT = 0.02
"""The same for exact depth (the simulator's render, noise 0): a 5 cm sports mat is an obstacle, not floor
(the robot's body touches it when it walks or lands there)."""

EDGE_TOLERANCE = 0.02
"""Surfaces within this [m] (plus their sigma) of the grid's side faces are the room's walls."""

NEAR_RANGE = 4.0
"""Depth [m] up to which :func:`explained_share` counts a capture's surfaces."""

LOW_EXPLAINED = 0.5
"""Below this share of near depth explained, a capture deserves a warning (see :func:`explained_share`)."""


@dataclass(frozen=True)
class DepthNoise:
    """1-sigma depth uncertainty ``sigma(z) = absolute + relative * z`` [m] of a depth reading ``z`` [m]."""

    relative: float = 0.0
    absolute: float = 0.0

    def __post_init__(self) -> None:
        for name in ("relative", "absolute"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) or v < 0:
                raise KnownSpaceError(f"noise.{name}: must be a finite number >= 0, got {v!r}")
        if self.relative >= 1.0:
            raise KnownSpaceError(f"noise.relative: must be < 1 (a fraction of the depth), got {self.relative}")


@dataclass(frozen=True)
class CaptureUpdate:
    """What one capture did to the known space.

    Attributes:
        space: The updated known space.
        rays: Pixels cast.
        hits: Rays whose surface marked occupied cells.
        floor_hits: Rays that ended on the floor.
        free_cells: Cells this capture saw free (not occupied).
        occupied_cells: Cells this capture saw occupied.
        seconds: Wall time of the update [s].
    """

    space: KnownSpace
    rays: int
    hits: int
    floor_hits: int
    free_cells: int
    occupied_cells: int
    seconds: float


def default_pixel_step(intrinsics: Intrinsics, resolution: float, max_range: float = MAX_RANGE) -> int:
    """Pixel stride so neighbouring rays are at most half a cell apart at ``max_range``, and at
    most about 40 000 rays are cast."""
    step = max(1, int(intrinsics.fx * (resolution / 2.0) / max_range))
    while (intrinsics.width // step) * (intrinsics.height // step) > 40_000:
        step += 1
    return step


def _check_pose(camera: Pose) -> tuple[np.ndarray, np.ndarray]:
    if not isinstance(camera, Pose):
        raise KnownSpaceError(f"camera: must be a Pose (world <- camera), got {type(camera).__name__}")
    t = np.asarray(camera.translation, dtype=np.float64)
    if not np.all(np.isfinite(t)):
        raise KnownSpaceError(f"camera.translation: must be finite, got {tuple(t)}")
    return camera.rotation.as_matrix(), t


def _sample_rays(depth: np.ndarray, intrinsics: Intrinsics, camera: Pose, step: int
                 ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """World ray directions (optical-axis component 1) ``(N, 3)``, depths ``(N,)`` [m] of the sampled
    pixels with a reading, and the camera centre [m]."""
    R, t = _check_pose(camera)
    h, w = depth.shape
    off = step // 2
    vs = np.arange(off, h, step)
    us = np.arange(off, w, step)
    z = depth[np.ix_(vs, us)].astype(np.float64).reshape(-1)
    uu, vv = np.meshgrid(us.astype(np.float64), vs.astype(np.float64))
    ok = np.isfinite(z) & (z > 0)
    dc = np.stack([(uu.reshape(-1)[ok] - intrinsics.cx) / intrinsics.fx,
                   (vv.reshape(-1)[ok] - intrinsics.cy) / intrinsics.fy, np.ones(int(ok.sum()))], axis=1)
    return dc @ R.T, z[ok], t


@njit(cache=True)
def _cast(mark, origin, res, nx, ny, nz, cam, dirs, depth, sig_rel, sig_abs, max_range, floor_band, edge_tol):
    """Mark bit 1 (free) / bit 2 (occupied) of ``mark`` [nx*ny*nz] for every ray; returns
    ``(hits, floor_hits)``."""
    hits = 0
    floor_hits = 0
    x0 = origin[0]
    y0 = origin[1]
    z0 = origin[2]
    x1 = x0 + nx * res
    y1 = y0 + ny * res
    z1 = z0 + nz * res
    for r in range(dirs.shape[0]):
        dx = dirs[r, 0]
        dy = dirs[r, 1]
        dz = dirs[r, 2]
        dlen = math.sqrt(dx * dx + dy * dy + dz * dz)
        zr = depth[r]
        sig = sig_abs + sig_rel * zr
        far = zr > max_range
        z_free = max_range if far else zr - sig
        # free samples every quarter cell of ray length
        dt = 0.25 * res / dlen
        n = int(z_free / dt) if z_free > 0 else 0
        for s in range(1, n + 1):
            tt = s * dt
            px = cam[0] + dx * tt
            py = cam[1] + dy * tt
            pz = cam[2] + dz * tt
            if px < x0 or py < y0 or pz < z0 or px >= x1 or py >= y1 or pz >= z1:
                continue
            i = int((px - x0) / res)
            j = int((py - y0) / res)
            k = int((pz - z0) / res)
            if i >= nx or j >= ny or k >= nz:
                continue
            mark[(i * ny + j) * nz + k] |= 1
        if far:
            continue
        hx = cam[0] + dx * zr
        hy = cam[1] + dy * zr
        hz = cam[2] + dz * zr
        if hz <= z0 + floor_band:
            floor_hits += 1
            continue
        tol = sig * dlen + edge_tol
        if hx <= x0 + tol or hy <= y0 + tol or hx >= x1 - tol or hy >= y1 - tol or hz >= z1 - tol:
            continue
        hits += 1
        ta = max(zr - sig, 0.0)
        tb = zr + sig
        m = int((tb - ta) / dt) + 1
        for s in range(m + 1):
            tt = zr if s == m else ta + s * dt
            if tt > tb:
                tt = tb
            px = cam[0] + dx * tt
            py = cam[1] + dy * tt
            pz = cam[2] + dz * tt
            if px < x0 or py < y0 or pz < z0 + floor_band or px >= x1 or py >= y1 or pz >= z1:
                continue
            i = int((px - x0) / res)
            j = int((py - y0) / res)
            k = int((pz - z0) / res)
            if i >= nx or j >= ny or k >= nz:
                continue
            mark[(i * ny + j) * nz + k] |= 2
    return hits, floor_hits


def capture_update(space: KnownSpace, depth_m: np.ndarray, intrinsics: Intrinsics, camera: Pose, *,
                   noise: DepthNoise = DepthNoise(), pixel_step: int | None = None, max_range: float = MAX_RANGE,
                   floor_band: float | None = None) -> CaptureUpdate:
    """Update ``space`` with one capture's metric depth map (see the module docstring).

    Args:
        space: The known space before the capture.
        depth_m: ``H x W`` depth along the optical axis [m] (a metric or scaled depth model's output,
            or the simulator's rendered depth); must match ``intrinsics``' size.
        intrinsics: The capture's camera [px].
        camera: ``world <- camera`` pose (OpenCV optical frame).
        noise: The depth's 1-sigma uncertainty (0 for the simulator's exact depth).
        pixel_step: Sample every n-th pixel (default :func:`default_pixel_step`).
        max_range: Readings farther than this [m] mark free space up to it only.
        floor_band: Surfaces this close [m] above the floor are floor (default :data:`FLOOR_BAND_EXACT`
            for exact depth, ``noise`` 0; else :data:`FLOOR_BAND`).

    Raises:
        KnownSpaceError: Bad arguments (naming the field).
    """
    t0 = time.perf_counter()
    if not isinstance(intrinsics, Intrinsics):
        raise KnownSpaceError(f"intrinsics: must be an Intrinsics, got {type(intrinsics).__name__}")
    d = np.asarray(depth_m)
    if d.ndim != 2 or d.shape != (intrinsics.height, intrinsics.width):
        raise KnownSpaceError(f"depth: must be {intrinsics.height} x {intrinsics.width} (the intrinsics' size), "
                              f"got shape {d.shape}")
    if not np.issubdtype(d.dtype, np.number):
        raise KnownSpaceError(f"depth: must be numbers [m], got {d.dtype}")
    if floor_band is None:
        floor_band = FLOOR_BAND_EXACT if noise.relative == 0 and noise.absolute == 0 else FLOOR_BAND
    for name, v in (("max_range", max_range), ("floor_band", floor_band)):
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) or v < 0:
            raise KnownSpaceError(f"{name}: must be a finite number >= 0 [m], got {v!r}")
    step = default_pixel_step(intrinsics, space.resolution, max_range) if pixel_step is None else pixel_step
    if isinstance(step, bool) or not isinstance(step, (int, np.integer)) or step < 1:
        raise KnownSpaceError(f"pixel_step: must be a whole number >= 1, got {pixel_step!r}")
    dirs, z, cam = _sample_rays(d, intrinsics, camera, int(step))
    nx, ny, nz = space.shape
    mark = np.zeros(nx * ny * nz, dtype=np.uint8)
    hits, floor_hits = _cast(mark, np.asarray(space.origin, dtype=np.float64), float(space.resolution), nx, ny, nz,
                             cam, np.ascontiguousarray(dirs), np.ascontiguousarray(z), float(noise.relative),
                             float(noise.absolute), float(max_range), float(floor_band), EDGE_TOLERANCE)
    mark = mark.reshape(nx, ny, nz)
    occupied = (mark & 2) > 0
    free = ((mark & 1) > 0) & ~occupied
    new = space.updated(free, occupied)
    return CaptureUpdate(new, len(z), int(hits), int(floor_hits), int(free.sum()), int(occupied.sum()),
                         time.perf_counter() - t0)


def box_depth(objects: Sequence[SceneObject], intrinsics: Intrinsics, camera: Pose, floor: float = 0.0,
              max_range: float = MAX_RANGE, pixel_step: int = 1) -> np.ndarray:
    """A depth map [m] (optical axis) made from the mapped objects' boxes and the floor plane at
    height ``floor`` [m], for captures without a depth model: each pixel gets the depth of the first
    box or floor its ray meets, ``max_range + 1`` when it meets neither within ``max_range`` (free
    up to ``max_range``). Only every ``pixel_step``-th pixel (as :func:`capture_update` samples them,
    same offset) is computed; the others are 0 (no reading)."""
    R, t = _check_pose(camera)
    h, w = intrinsics.height, intrinsics.width
    out = np.zeros((h, w), dtype=np.float32)
    off = pixel_step // 2
    vs = np.arange(off, h, pixel_step)
    us = np.arange(off, w, pixel_step)
    uu, vv = np.meshgrid(us.astype(np.float64), vs.astype(np.float64))
    dc = np.stack([(uu - intrinsics.cx) / intrinsics.fx, (vv - intrinsics.cy) / intrinsics.fy, np.ones_like(uu)],
                  axis=-1).reshape(-1, 3)
    dw = dc @ R.T  # world direction per unit of optical depth
    best = np.full(len(dw), max_range + 1.0)
    with np.errstate(divide="ignore", invalid="ignore"):
        tf = (floor - t[2]) / dw[:, 2]
    best = np.where((tf > 0) & np.isfinite(tf), np.minimum(best, tf), best)
    for obj in objects:
        if obj.frame != "world":
            continue
        wdt, hgt, lng = obj.size
        c, s = math.cos(obj.yaw), math.sin(obj.yaw)
        axes = np.array([[c, s, 0.0], [-s, c, 0.0], [0.0, 0.0, 1.0]])  # rows: length, width, up
        half = np.array([lng / 2, wdt / 2, hgt / 2])
        o = axes @ (t - np.asarray(obj.position))
        dl = dw @ axes.T
        with np.errstate(divide="ignore", invalid="ignore"):
            t1 = (-half - o) / dl
            t2 = (half - o) / dl
        lo = np.nanmax(np.minimum(t1, t2), axis=1)
        hi = np.nanmin(np.maximum(t1, t2), axis=1)
        inside = np.all(np.abs(o) <= half)
        enter = np.where(inside, 0.0, lo)
        ok = (hi >= np.maximum(enter, 0.0)) & (enter > 0)
        best = np.where(ok & (enter < best), enter, best)
    out[np.ix_(vs, us)] = best.reshape(len(vs), len(us)).astype(np.float32)
    return out


@dataclass(frozen=True)
class DepthExplained:
    """How much of a capture's near depth the mapped objects explain.

    Attributes:
        share: Explained near pixels / near pixels (1.0 when there are none).
        near_pixels: Sampled pixels whose surface lies within ``near`` [m] of depth, inside the
            grid, not floor and not the grid's side faces (walls).
        explained_pixels: Those whose surface lies in some mapped object's box grown by the tolerance.
    """

    share: float
    near_pixels: int
    explained_pixels: int

    @property
    def low(self) -> bool:
        """Below :data:`LOW_EXPLAINED` with enough near pixels to tell (at least 50)."""
        return self.near_pixels >= 50 and self.share < LOW_EXPLAINED


def explained_share(depth_m: np.ndarray, intrinsics: Intrinsics, camera: Pose, objects: Sequence[SceneObject],
                    bounds_min: Sequence[float], bounds_max: Sequence[float], *, near: float = NEAR_RANGE,
                    tolerance: float = EXPLAINED_TOLERANCE, floor_band: float = FLOOR_BAND,
                    pixel_step: int = 4, noise: DepthNoise = DepthNoise()) -> DepthExplained:
    """The share of the photo's near depth surfaces that lie in a mapped object's box grown by
    ``tolerance`` [m]; surfaces are the sampled pixels' depth points (world [m]) within ``near`` m,
    inside ``bounds_min``..``bounds_max`` and above the floor band. Points on or beyond the
    workspace's faces, within :data:`EDGE_TOLERANCE` plus the depth's ``noise`` sigma along the ray
    (the rule of :func:`capture_update`), are the room's walls, floor and ceiling: the workspace
    explains them, they do not count. A low share (:attr:`DepthExplained.low`) means the depth
    sees obstacles the detector did not name. ``noise``: the depth's 1-sigma uncertainty (0 for the
    simulator's exact depth, a depth model's relative sigma otherwise)."""
    d = np.asarray(depth_m)
    if d.ndim != 2 or d.shape != (intrinsics.height, intrinsics.width):
        raise KnownSpaceError(f"depth: must be {intrinsics.height} x {intrinsics.width}, got shape {d.shape}")
    dirs, z, cam = _sample_rays(d, intrinsics, camera, max(1, int(pixel_step)))
    keep = z <= near
    pts = cam + dirs[keep] * z[keep, None]
    sigma = (float(noise.absolute) + float(noise.relative) * z[keep]) * np.linalg.norm(dirs[keep], axis=1)
    tol = (EDGE_TOLERANCE + sigma)[:, None]  # [m] per point: a wall read up to its sigma inside is a wall
    lo = np.asarray(bounds_min, dtype=np.float64)
    hi = np.asarray(bounds_max, dtype=np.float64)
    inside = (np.all((pts > lo + tol) & (pts < hi - tol), axis=1)
              & (pts[:, 2] > lo[2] + np.maximum(floor_band, tol[:, 0])))
    pts = pts[inside]
    if len(pts) == 0:
        return DepthExplained(1.0, 0, 0)
    hit = np.zeros(len(pts), dtype=bool)
    for obj in objects:
        if obj.frame == "world":
            hit |= box_contains(obj, pts, tolerance)
    n = len(pts)
    e = int(hit.sum())
    return DepthExplained(e / n, n, e)


__all__ = ["CaptureUpdate", "DepthExplained", "DepthNoise", "FLOOR_BAND", "FLOOR_BAND_EXACT", "LOW_EXPLAINED", "MAX_RANGE", "NEAR_RANGE",
           "box_depth", "capture_update", "default_pixel_step", "explained_share"]
