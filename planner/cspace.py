"""Configuration-space helpers of the planning grid: distances from cell centres to oriented boxes,
cube-distance dilation of obstacle cells, floating objects, the workspace's edges.

World frame (z up) [m]. A cell obstacle is the cell's cube; the distance from a cell centre to
another cell's cube is ``resolution * sqrt(sum(max(|d| - 1/2, 0)^2))`` for the index offset ``d``,
so :func:`dilate` closes exactly the cells whose centre lies within ``radius`` of an obstacle cell
(its surface). Object boxes use their exact oriented box (:func:`box_distance`), grown in plan by
their mapping margin when asked (:func:`planner.map_uncertainty.object_margin`).

Space outside the workspace is closed (nothing there was ever mapped): its faces are obstacles like
any other, and the robot keeps its radius from them (:func:`edge_closed`, :func:`edge_gaps`): in plan
from the walls ``x = min/max``, ``y = min/max`` (walking and flying), and in the air from the top
``z = max`` by its flying radius or its height, whichever is larger (the body reaches ``height``
above its origin). The floor is no edge: the robot stands on it. The faces are exact (the
operator's bounds, not a mapped estimate), so no danger band is added beyond them.
"""

from __future__ import annotations

import math
from typing import Any, Sequence

import numpy as np
from scipy import ndimage

from pipeline.scene import SceneObject

FLOAT_TOL = 0.10
"""An object whose bottom is more than this [m] above the floor, with no object under it within this
of its bottom, is *floating* (a mapping error or a shelf): the column beneath it is closed unless seen free."""


def box_distance(obj: SceneObject, pts: np.ndarray, horizontal: bool = False, pad: float = 0.0) -> np.ndarray:
    """Distance [m] from world points ``(N, 3)`` to ``obj``'s oriented box (0 inside); with
    ``horizontal`` only x, y count (distance to the box's footprint). ``pad`` [m] grows the footprint
    in plan (the box's Minkowski sum with a horizontal disc: its mapping margin,
    :func:`planner.map_uncertainty.object_margin`); its height is unchanged."""
    p = np.asarray(pts, dtype=np.float64).reshape(-1, 3)
    w, h, l = obj.size
    c, s = math.cos(obj.yaw), math.sin(obj.yaw)
    d = p - np.asarray(obj.position)
    along = np.maximum(np.abs(c * d[:, 0] + s * d[:, 1]) - l / 2, 0.0)
    across = np.maximum(np.abs(-s * d[:, 0] + c * d[:, 1]) - w / 2, 0.0)
    plan = np.hypot(along, across)
    if pad > 0:
        plan = np.maximum(plan - pad, 0.0)
    if horizontal:
        return plan
    up = np.maximum(np.abs(d[:, 2]) - h / 2, 0.0)
    return np.hypot(plan, up)


def _window(axis: np.ndarray, lo: float, hi: float) -> np.ndarray:
    return np.nonzero((axis >= lo) & (axis <= hi))[0]


def _pads(objects: Sequence[SceneObject], pads: Sequence[float] | None) -> list[float]:
    if pads is None:
        return [0.0] * len(objects)
    if len(pads) != len(objects):
        raise ValueError(f"pads: expected one per object ({len(objects)}), got {len(pads)}")
    return [float(v) for v in pads]


def object_distances(objects: Sequence[SceneObject], axes: tuple[np.ndarray, np.ndarray, np.ndarray], reach: float,
                     z_band: tuple[float, float] | None = None, pads: Sequence[float] | None = None
                     ) -> tuple[np.ndarray, np.ndarray]:
    """Distance [m] from every cell centre to the nearest object and that object's index (-1: none
    within ``reach`` [m]; distances beyond ``reach`` are ``inf``).

    With ``z_band = (z0, z1)`` the result is 2D ``[nx, ny]``: horizontal distance from the column's
    centre to the footprints of the objects whose height range overlaps ``z0..z1`` (a walking robot's
    cylinder); else 3D ``[nx, ny, nz]`` Euclidean distances. Each object's footprint is grown by its
    ``pads`` entry [m] (default none; the planner passes the mapping margins,
    :func:`planner.map_uncertainty.object_margin`, when its robot has ``mapping_margin``).
    """
    xs, ys, zs = axes
    shape = (len(xs), len(ys)) if z_band is not None else (len(xs), len(ys), len(zs))
    dist = np.full(shape, np.inf)
    near = np.full(shape, -1, dtype=np.int32)
    for n, (obj, pad) in enumerate(zip(objects, _pads(objects, pads))):
        w, h, l = obj.size
        cx, cy, cz = obj.position
        if z_band is not None and not (cz - h / 2 < z_band[1] and cz + h / 2 > z_band[0]):
            continue
        rxy = math.hypot(w, l) / 2 + reach + pad
        ix = _window(xs, cx - rxy, cx + rxy)
        iy = _window(ys, cy - rxy, cy + rxy)
        if ix.size == 0 or iy.size == 0:
            continue
        if z_band is not None:
            gx, gy = np.meshgrid(xs[ix], ys[iy], indexing="ij")
            pts = np.stack([gx.ravel(), gy.ravel(), np.zeros(gx.size)], axis=1)
            d = box_distance(obj, pts, horizontal=True, pad=pad).reshape(gx.shape)
            sub = np.ix_(ix, iy)
        else:
            iz = _window(zs, cz - h / 2 - reach, cz + h / 2 + reach)
            if iz.size == 0:
                continue
            gx, gy, gz = np.meshgrid(xs[ix], ys[iy], zs[iz], indexing="ij")
            d = box_distance(obj, np.stack([gx.ravel(), gy.ravel(), gz.ravel()], axis=1), pad=pad).reshape(gx.shape)
            sub = np.ix_(ix, iy, iz)
        cur = dist[sub]
        better = d < cur
        dist[sub] = np.where(better, d, cur)
        near[sub] = np.where(better, n, near[sub])
    dist[dist > reach + 1e-9] = np.inf
    return dist, near


def cube_ball(radius: float, resolution: float, dims: int) -> np.ndarray:
    """Structuring element: the index offsets whose cell cube lies within ``radius`` [m] of the
    centre cell's centre (always the centre itself)."""
    r = int(math.ceil(radius / resolution + 0.5))
    rng = np.arange(-r, r + 1)
    grids = np.meshgrid(*([rng] * dims), indexing="ij")
    d2 = sum(np.maximum(np.abs(g) - 0.5, 0.0) ** 2 for g in grids)
    ball = resolution * np.sqrt(d2) <= radius + 1e-9
    ball[(r,) * dims] = True
    return ball


def dilate(mask: np.ndarray, radius: float, resolution: float) -> np.ndarray:
    """Cells whose centre lies within ``radius`` [m] of a ``mask`` cell's cube (the mask included)."""
    if not mask.any():
        return np.zeros_like(mask, dtype=bool)
    ball = cube_ball(radius, resolution, mask.ndim)
    if ball.size == 1:
        return mask.astype(bool, copy=True)
    return ndimage.binary_dilation(mask, structure=ball)


def floating_objects(objects: Sequence[SceneObject], floor: float, tol: float = FLOAT_TOL) -> list[int]:
    """Indices of objects whose bottom is more than ``tol`` [m] above ``floor`` with no other object
    holding it up (another object's top within ``tol`` of its bottom, footprints overlapping)."""
    out = []
    for n, o in enumerate(objects):
        bottom = o.position[2] - o.size[1] / 2
        if bottom <= floor + tol:
            continue
        ro = math.hypot(o.size[0], o.size[2]) / 2
        held = False
        for m, p in enumerate(objects):
            if m == n:
                continue
            top = p.position[2] + p.size[1] / 2
            if abs(top - bottom) > tol and not (p.position[2] - p.size[1] / 2 < bottom < top):
                continue
            rp = math.hypot(p.size[0], p.size[2]) / 2
            if math.dist(o.position[:2], p.position[:2]) < ro + rp:
                held = True
                break
        if not held:
            out.append(n)
    return out


EDGE_TOL = 1e-9
"""A cell is closed when its gap to an edge is at most the robot's need plus this [m] (the same
comparison as the clearance to objects)."""


def _top_need(robot: Any) -> float:
    """How far [m] the flying body reaches above its origin: its flying radius or its height."""
    return max(float(robot.flying_radius), float(robot.height))


def edge_gaps(lo: Sequence[float], hi: Sequence[float], point: Sequence[float], ground: bool,
              robot: Any) -> list[tuple[float, float, str]]:
    """The gaps between a robot at ``point`` (world [m]) and each face of the workspace ``lo..hi``
    [m], nearest first, as ``(gap, need, face)``: ``gap`` [m] from the point to the face, ``need``
    [m] the least gap the robot's body needs, ``face`` its name (``edge x = 5.00``, ``top z = 3.00``).

    ``ground``: the robot walks there (its footprint ``robot.radius`` in plan; the top face counts
    the floor-to-top height against ``robot.height``); else it flies (``robot.flying_radius`` in
    plan, :func:`_top_need` below the top). The floor is no face."""
    p = [float(v) for v in point]
    r = float(robot.radius if ground else robot.flying_radius)
    out = []
    for a, axis in ((0, "x"), (1, "y")):
        out.append((p[a] - float(lo[a]), r, f"edge {axis} = {float(lo[a]):.2f}"))
        out.append((float(hi[a]) - p[a], r, f"edge {axis} = {float(hi[a]):.2f}"))
    if ground:
        out.append((float(hi[2]) - float(lo[2]), float(robot.height), f"top z = {float(hi[2]):.2f}"))
    else:
        out.append((float(hi[2]) - p[2], _top_need(robot), f"top z = {float(hi[2]):.2f}"))
    out.sort(key=lambda g: g[0] - g[1])
    return out


def edge_blockers(lo: Sequence[float], hi: Sequence[float], point: Sequence[float], ground: bool,
                  robot: Any) -> list[tuple[float, float, str]]:
    """The faces of :func:`edge_gaps` the robot at ``point`` is too near (gap at most its need), the
    tightest first; empty when it keeps its size from every face."""
    return [g for g in edge_gaps(lo, hi, point, ground, robot) if g[0] <= g[1] + EDGE_TOL]


def edge_closed(lo: Sequence[float], hi: Sequence[float], axes: tuple[np.ndarray, np.ndarray, np.ndarray],
                robot: Any) -> np.ndarray:
    """``bool [nx, ny, nz]``: the cells whose centre (``axes`` [m]) is too near a workspace face for
    the robot (:func:`edge_blockers`, vectorised): layer 0 as walking, the others as flying."""
    xs, ys, zs = (np.asarray(v, dtype=np.float64) for v in axes)
    gx = np.minimum(xs - float(lo[0]), float(hi[0]) - xs)
    gy = np.minimum(ys - float(lo[1]), float(hi[1]) - ys)
    rf, rw = float(robot.flying_radius), float(robot.radius)
    out = (gx[:, None, None] <= rf + EDGE_TOL) | (gy[None, :, None] <= rf + EDGE_TOL) | \
        ((float(hi[2]) - zs)[None, None, :] <= _top_need(robot) + EDGE_TOL)
    out = np.broadcast_to(out, (len(xs), len(ys), len(zs))).copy()
    if len(zs):
        out[:, :, 0] = (gx[:, None] <= rw + EDGE_TOL) | (gy[None, :] <= rw + EDGE_TOL) | \
            (float(hi[2]) - float(lo[2]) <= float(robot.height) + EDGE_TOL)
    return out


__all__ = ["EDGE_TOL", "FLOAT_TOL", "box_distance", "cube_ball", "dilate", "edge_blockers", "edge_closed", "edge_gaps",
           "floating_objects", "object_distances"]
