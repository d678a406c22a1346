"""The flying robot's body in the planning grid: a sphere round its origin and its full height above it.

World frame (z up) [m]. In the air the robot is planned as the union of

- the sphere of ``robot.flying_radius`` around its origin (the propellers' disc with a safety margin,
  taken round: below the origin too), and
- the vertical cylinder of the same radius from the origin up to ``robot.flying_height`` above it (the
  body the simulator flies is ``SimConfig.body_height`` = 0.45 m above the origin,
  :mod:`console.link.sim_contact`; ``flying_height = 0``, the default robot's, leaves the sphere alone).

A flight cell is closed when an obstacle comes within this body at the cell's centre: with
``flying_height = 0.45`` an object whose underside is 0.40 m above a hover cell closes it, one at 0.50 m does not
(beyond the body's top and the sphere). :func:`flight_gaps` measures the gap from the body to mapped
boxes (each grown in plan by its mapping margin, :mod:`planner.map_uncertainty`); :func:`flight_dilate`
closes the cells near obstacle cells (their cubes), the same body.

Both are exact for vertical prisms: the gap between a box and the cylinder is
``hypot(max(d_plan - r, 0), d_z)`` (the footprints' distance in plan, the height ranges' gap), and to the
sphere ``max(d - r, 0)`` (``d`` the centre's distance to the box); the body's gap is the smaller.
"""

from __future__ import annotations

import math
from typing import Any, Sequence

import numpy as np
from scipy import ndimage

from pipeline.scene import SceneObject
from planner.cspace import box_distance
from planner.map_uncertainty import margins


def _body(robot: Any) -> tuple[float, float]:
    """``(radius, height)`` [m] of the flying body (``robot.flying_height``: 0 for the sphere alone)."""
    return float(robot.flying_radius), float(getattr(robot, "flying_height", 0.0))


def flight_gaps(objects: Sequence[SceneObject], axes: tuple[np.ndarray, np.ndarray, np.ndarray], robot: Any,
                reach: float, pads: Sequence[float] | None = None) -> np.ndarray:
    """``float [nx, ny, nz]``: the gap [m] between the flying body at each cell centre (``axes`` [m]) and
    the nearest object's box (0: they touch or overlap; ``inf`` beyond ``reach`` [m]). ``pads`` [m] grow
    each footprint in plan (default: the objects' mapping margins)."""
    xs, ys, zs = (np.asarray(a, dtype=np.float64) for a in axes)
    r, height = _body(robot)
    pad_of = margins(objects) if pads is None else [float(v) for v in pads]
    if len(pad_of) != len(objects):
        raise ValueError(f"pads: expected one per object ({len(objects)}), got {len(pad_of)}")
    gap = np.full((len(xs), len(ys), len(zs)), np.inf)
    for obj, pad in zip(objects, pad_of):
        w, h, l = obj.size
        cx, cy, cz = obj.position
        lo, hi = cz - h / 2, cz + h / 2
        rxy = math.hypot(w, l) / 2 + pad + r + reach
        ix = np.nonzero(np.abs(xs - cx) <= rxy)[0]
        iy = np.nonzero(np.abs(ys - cy) <= rxy)[0]
        iz = np.nonzero((zs >= lo - max(height, r) - reach) & (zs <= hi + r + reach))[0]
        if ix.size == 0 or iy.size == 0 or iz.size == 0:
            continue
        gx, gy = np.meshgrid(xs[ix], ys[iy], indexing="ij")
        plan = box_distance(obj, np.stack([gx.ravel(), gy.ravel(), np.zeros(gx.size)], axis=1), horizontal=True,
                            pad=pad).reshape(gx.shape)[:, :, None]
        z = zs[iz][None, None, :]
        sphere = np.hypot(plan, np.maximum(np.abs(z - cz) - h / 2, 0.0)) - r
        dz = np.maximum(np.maximum(lo - (z + height), z - hi), 0.0)
        cylinder = np.hypot(np.maximum(plan - r, 0.0), dz)
        d = np.maximum(np.minimum(sphere, cylinder), 0.0)
        sub = np.ix_(ix, iy, iz)
        gap[sub] = np.minimum(gap[sub], d)
    gap[gap > reach + 1e-9] = np.inf
    return gap


def body_gap(obj: SceneObject, point: Sequence[float], robot: Any, pad: float = 0.0) -> float:
    """The gap [m] between the flying body at ``point`` (world [m]) and ``obj``'s box grown by ``pad``
    [m] in plan (0: they touch or overlap)."""
    p = [float(v) for v in point]
    one = (np.array([p[0]]), np.array([p[1]]), np.array([p[2]]))
    g = float(flight_gaps([obj], one, robot, math.inf, [pad])[0, 0, 0])
    return g


def flight_ball(robot: Any, resolution: float, gap: float) -> np.ndarray:
    """``bool`` structuring element (odd sides, origin at the centre) of the index offsets ``o`` whose
    cell cube comes within ``gap`` [m] of the flying body at the centre cell's centre."""
    r, height = _body(robot)
    res = float(resolution)
    n = int(math.ceil((r + gap) / res + 0.5))
    m = max(n, int(math.ceil((height + gap) / res + 0.5)))
    i = np.arange(-n, n + 1)[:, None, None]
    j = np.arange(-n, n + 1)[None, :, None]
    k = np.arange(-m, m + 1)[None, None, :]
    plan = res * np.hypot(np.maximum(np.abs(i) - 0.5, 0.0), np.maximum(np.abs(j) - 0.5, 0.0))
    vert = res * np.maximum(np.abs(k) - 0.5, 0.0)
    sphere = np.hypot(plan, vert) - r
    dz = np.maximum(np.maximum((k - 0.5) * res - height, -(k + 0.5) * res), 0.0)
    cylinder = np.hypot(np.maximum(plan - r, 0.0), dz)
    ball = np.minimum(sphere, cylinder) <= gap + 1e-9
    ball[n, n, m] = True
    return ball


def flight_dilate(mask: np.ndarray, robot: Any, resolution: float, gap: float = 0.0) -> np.ndarray:
    """``bool [nx, ny, nz]``: the cells where the flying body (at the cell's centre) comes within ``gap``
    [m] of a ``mask`` cell's cube (the mask included)."""
    if not mask.any():
        return np.zeros_like(mask, dtype=bool)
    ball = flight_ball(robot, resolution, gap)
    # scipy dilates by the Minkowski sum (out[x] when mask[x - b]); the body at x meets mask[x + o]
    return ndimage.binary_dilation(mask, structure=ball[::-1, ::-1, ::-1])


__all__ = ["body_gap", "flight_ball", "flight_dilate", "flight_gaps"]
