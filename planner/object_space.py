"""The cells mapped objects close, or make dear, for the robot's body: walking and flying, in one pass.

World frame (z up) [m]. For each object its footprint distance in plan is measured once over a window of
cell centres and gives, with the object's mapping margin ``pad`` (:mod:`planner.map_uncertainty`):

- **walking** (the floor layer; objects overlapping the body's height above the floor): closed where the
  footprint grown by ``pad`` comes within ``robot.radius`` of the column's centre, dear (the danger band)
  where the mapped footprint comes within ``robot.radius + band``;
- **flying** (every layer; :mod:`planner.flight_body`: the flying-radius sphere and ``robot.flying_height``
  above the origin): closed where the body meets the box grown by ``pad`` in plan, dear where it comes
  within ``band`` of the mapped box.

The same rules as :func:`planner.cspace.object_distances` and :func:`planner.flight_body.flight_gaps`
(which measure one at a time), computed together for :func:`planner.grid.build_grid`.
"""

from __future__ import annotations

import math
from typing import Any, Sequence

import numpy as np

from pipeline.scene import SceneObject

TOL = 1e-9


def _contiguous(mask: np.ndarray) -> slice | None:
    idx = np.nonzero(mask)[0]
    return slice(int(idx[0]), int(idx[-1]) + 1) if idx.size else None


def object_cells(objects: Sequence[SceneObject], axes: tuple[np.ndarray, np.ndarray, np.ndarray], robot: Any,
                 band: float, pads: Sequence[float], floor: float
                 ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """``(air_closed, air_dear [nx, ny, nz], walk_closed, walk_dear [nx, ny])`` ``bool`` arrays: the cells
    (cell centres ``axes`` [m]) the objects close or put in the danger band of width ``band`` [m] for the
    flying body (every layer) and the walking body (the floor layer's columns, ``floor`` [m]); ``pads`` [m]
    one mapping margin per object."""
    xs, ys, zs = (np.asarray(a, dtype=np.float64) for a in axes)
    if len(pads) != len(objects):
        raise ValueError(f"pads: expected one per object ({len(objects)}), got {len(pads)}")
    rw, rf, walk_h = float(robot.radius), float(robot.flying_radius), float(robot.height)
    height = float(getattr(robot, "flying_height", 0.0))
    shape = (len(xs), len(ys), len(zs))
    air_closed, air_dear = np.zeros(shape, bool), np.zeros(shape, bool)
    walk_closed, walk_dear = np.zeros(shape[:2], bool), np.zeros(shape[:2], bool)
    for obj, pad in zip(objects, pads):
        w, h, l = obj.size
        cx, cy, cz = obj.position
        lo, hi = cz - h / 2, cz + h / 2
        rxy = math.hypot(w, l) / 2 + max(pad, band) + max(rw, rf)
        sx, sy = _contiguous(np.abs(xs - cx) <= rxy), _contiguous(np.abs(ys - cy) <= rxy)
        if sx is None or sy is None:
            continue
        c, s = math.cos(obj.yaw), math.sin(obj.yaw)
        dx, dy = xs[sx][:, None] - cx, ys[sy][None, :] - cy
        along = np.maximum(np.abs(c * dx + s * dy) - l / 2, 0.0)
        across = np.maximum(np.abs(-s * dx + c * dy) - w / 2, 0.0)
        plan = np.hypot(along, across)  # footprint distance in plan [m], as mapped
        grown = np.maximum(plan - pad, 0.0)
        if lo < floor + walk_h and hi > floor:  # overlaps the walking body's height
            walk_closed[sx, sy] |= grown <= rw + TOL
            walk_dear[sx, sy] |= plan <= rw + band + TOL
        sz = _contiguous((zs >= lo - max(height, rf) - band) & (zs <= hi + rf + band))
        if sz is None:
            continue
        z = zs[sz][None, None, :]
        up = np.maximum(np.abs(z - cz) - h / 2, 0.0)  # vertical gap of the origin to the box
        dz = np.maximum(np.maximum(lo - (z + height), z - hi), 0.0)  # of the body's height range to it

        def gap(p: np.ndarray) -> np.ndarray:
            p3 = p[:, :, None]
            return np.minimum(np.hypot(p3, up) - rf, np.hypot(np.maximum(p3 - rf, 0.0), dz))

        air_closed[sx, sy, sz] |= gap(grown) <= TOL
        air_dear[sx, sy, sz] |= gap(plan) <= band + TOL
    return air_closed, air_dear, walk_closed, walk_dear


__all__ = ["object_cells"]
