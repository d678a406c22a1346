"""Where to look next when searching for an object: scored viewpoints on the floor and in the air.

World frame (z up) [m], headings counter-clockwise from +x [rad]. The known space comes in as a
``uint8 [nx, ny, nz]`` state array on the planning grid's cells (0 unknown, 1 seen free,
2 occupied: :class:`pipeline.mapping.known_space.KnownState`'s values; the planner does not import
that module).

**Candidates.** Cells the robot can reach from its start with the planner's own costs (a Dijkstra
over the grid's per-cell costs, face moves: the A*'s cost without its diagonals, so walking stays
cheaper than flying: ``CostWeights``' ground 1, take-off 12, flight 3 per metre) that lie within
:data:`FRONTIER_CELLS` cells of unknown space (the frontiers of the known space): on the floor the
camera stands at ``robot.camera_height``; in the air it hovers at the cell's centre. With
``seen_only`` (the default) a candidate must itself be seen free.

**Gain.** From each candidate, rays fan out over the full turn (every :data:`AZ_STEP_DEG`) and
over the camera's vertical field of view (the camera is level: its pitch is 0), marching every
half cell up to :data:`MAX_RANGE`; a ray stops at the first occupied cell (seen occupied or a
mapped object: occlusion) and counts the unknown cells it crosses, each sample weighted by the
volume it stands for (``r² dΩ dr``: unknown volume in view [m³]) and by where the target can be:
unknown space below the target's top (plus a cell) counts fully, higher (ceiling) only
:data:`HIGH_WEIGHT`. The heading is the one whose 62 deg horizontal field of view holds the most.

**Score.** ``gain / (cost + COST0)``: unknown target-height volume seen per unit of path cost, a
capture counting as :data:`COST0` of path cost.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Sequence

import numpy as np
from scipy import ndimage
from scipy.sparse import csr_matrix
from scipy.sparse.csgraph import dijkstra

from pipeline.scene import SceneObject
from planner.grid import Closed, PlanningGrid
from planner.search_rays import per_azimuth
from planner.view_rays import line_of_sight

UNKNOWN, FREE, OCCUPIED = 0, 1, 2

MAX_RANGE = 5.0
"""Farthest distance counted from a viewpoint [m] (objects far away map poorly)."""
MIN_RANGE = 0.5
"""Nearest distance counted [m] (the mapper drops objects this close)."""
AZ_STEP_DEG = 10.0
"""Azimuth step of the gain's rays [deg]."""
EL_RAYS = 5
"""Rays over the vertical field of view."""
HFOV = math.radians(62.0)
"""The camera's horizontal field of view [rad] (the simulated 640 x 480 camera, fx = 525 px)."""
HIGH_WEIGHT = 0.15
"""Weight of unknown space above where the target can be (the ceiling) against floor level."""
FRONTIER_CELLS = 2
"""A candidate lies within this many cells of unknown space."""
COST0 = 20.0
"""Added to the path cost in the score [cost·m]: what one capture is worth in path cost (twenty metres of
walking, under seven of flying). Near spots are not free: a view of a few cubic metres next to the
robot does not win over one of many times that across the room (the capture budget is small). Chosen
on ``bench/search.py`` (the first 20 random rooms and the paper's, noise run): 2 found 84 %, 8 84 %, 20 95 %."""
MAX_CANDIDATES = 200
"""Candidates scored (evenly subsampled beyond that)."""


class SearchViewpointError(ValueError):
    """Bad inputs (shapes, start, heights); the message names the field."""


@dataclass(frozen=True)
class Viewpoint:
    """A place to look from.

    Attributes:
        goal: Where the planner goes (world [m]): a floor point (z = floor) or a hover point.
        eye: Camera position (world [m]).
        yaw: Heading to face [rad] (world, counter-clockwise from +x).
        mode: ``walk`` (on the floor) or ``fly`` (hovering).
        gain: Weighted unknown volume in the camera's view from there [m³].
        cost: The planner's path cost to get there [cost·m].
        score: ``gain / (cost + COST0)``.
        why: One line for the operator.
    """

    goal: tuple[float, float, float]
    eye: tuple[float, float, float]
    yaw: float
    mode: str
    gain: float
    cost: float
    score: float
    why: str


def path_costs(grid: PlanningGrid, cost: np.ndarray, start_cell: Sequence[int]) -> np.ndarray:
    """Least path cost [cost·m] from ``start_cell`` to every cell over face moves (``inf`` where
    unreachable). ``cost`` is the planner's per-cell cost [1/m] (``inf`` impassable); a move costs
    ``resolution * (c_a + c_b) / 2`` as in the A*."""
    c = np.asarray(cost, dtype=np.float64)
    shape = c.shape
    s = tuple(int(v) for v in start_cell)
    if len(s) != 3 or not all(0 <= s[a] < shape[a] for a in range(3)):
        raise SearchViewpointError(f"start_cell: must be a cell of the grid {shape}, got {start_cell!r}")
    ok = np.isfinite(c)
    ok[s] = True
    c = np.where(np.isfinite(c), c, 0.0)
    n = c.size
    flat = np.arange(n).reshape(shape)
    rows, cols, vals = [], [], []
    res = grid.workspace.resolution
    for axis in range(3):
        a = [slice(None)] * 3
        b = [slice(None)] * 3
        a[axis] = slice(0, -1)
        b[axis] = slice(1, None)
        both = ok[tuple(a)] & ok[tuple(b)]
        fa, fb = flat[tuple(a)][both], flat[tuple(b)][both]
        w = res * (c[tuple(a)][both] + c[tuple(b)][both]) / 2.0 + 1e-9
        rows += [fa, fb]
        cols += [fb, fa]
        vals += [w, w]
    g = csr_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))), shape=(n, n))
    d = dijkstra(g, directed=True, indices=int(flat[s]))
    return np.asarray(d).reshape(shape)


def _ray_dirs() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Unit directions ``[A, E, 3]``, their azimuths ``[A]`` and the solid angle per ray [sr]."""
    half = 0.42  # the camera's half vertical field of view [rad] (RobotModel.camera_half_vfov)
    az = np.radians(np.arange(0.0, 360.0, AZ_STEP_DEG))
    el = np.linspace(-half, half, EL_RAYS)
    ca, sa = np.cos(az)[:, None], np.sin(az)[:, None]
    ce, se = np.cos(el)[None, :], np.sin(el)[None, :]
    d = np.stack([ca * ce, sa * ce, np.broadcast_to(se, (len(az), len(el)))], axis=-1)
    d_omega = math.radians(AZ_STEP_DEG) * (2 * half / max(EL_RAYS - 1, 1)) * np.cos(el)
    return d, az, d_omega


def view_gain(state: np.ndarray, blocking: np.ndarray, grid: PlanningGrid, eyes: np.ndarray,
              target_top: float, looked: np.ndarray | None = None,
              yaw: float | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Gain [m³] and best heading [rad] for each camera position ``eyes`` ``[N, 3]`` (world [m]),
    and the unknown cells the last eye's best heading (or ``yaw``) has in view (``bool``, grid shape).

    ``state``: known-space states; ``blocking``: ``bool`` cells that stop a ray (occupied, mapped
    objects); ``target_top``: world z [m] below which unknown space counts fully; ``looked``: cells
    already in view of an earlier capture that stayed unknown (they count no more)."""
    ws = grid.workspace
    res = ws.resolution
    dirs, az, d_omega = _ray_dirs()
    step = res / 2.0
    r = np.arange(MIN_RANGE, MAX_RANGE + 1e-9, step)
    nx, ny, nz = ws.shape
    lo = np.asarray(ws.min, dtype=np.float64)
    unknown = (state == UNKNOWN)
    if looked is not None:
        unknown = unknown & ~np.asarray(looked, dtype=bool)
    unknown = unknown.ravel()
    blocked = blocking.ravel()
    in_view = np.zeros(nx * ny * nz, dtype=bool)
    zc = ws.min[2] + (np.arange(nz) + 0.5) * res
    zweight = np.where(zc <= target_top + res, 1.0, HIGH_WEIGHT)
    A, E = dirs.shape[:2]
    eyes = np.ascontiguousarray(np.asarray(eyes, dtype=np.float64).reshape(-1, 3))
    vol = (r ** 2 * step)[None, :] * d_omega[:, None]  # [E, R]: the volume each sample stands for [m³]
    per_az = per_azimuth(eyes, np.ascontiguousarray(dirs), r, np.ascontiguousarray(vol), unknown, blocked,
                         np.ascontiguousarray(zweight, dtype=np.float64), lo, float(res), nx, ny, nz)  # [N, A]
    half_w = int(round(math.degrees(HFOV / 2) / AZ_STEP_DEG))
    window = sum(np.roll(per_az, s_, axis=1) for s_ in range(-half_w, half_w + 1))  # the camera's 62 deg
    if yaw is None:
        best = np.argmax(window, axis=1) if len(eyes) else np.zeros(0, dtype=np.int64)
    else:
        best = np.full(len(eyes), int(round(math.degrees(yaw) / AZ_STEP_DEG)) % A)
    gains = window[np.arange(len(eyes)), best] if len(eyes) else np.zeros(0)
    yaws = (az[best] + math.pi) % (2 * math.pi) - math.pi
    if len(eyes):  # the last eye's unknown cells in view (the same samples, in numpy: one eye)
        sector = (np.arange(best[-1] - half_w, best[-1] + half_w + 1)) % A
        pts = eyes[-1] + dirs[sector][:, :, None, :] * r[None, None, :, None]
        cell = np.floor((pts - lo) / res).astype(np.int64)
        i, j, k = cell[..., 0], cell[..., 1], cell[..., 2]
        inside = (i >= 0) & (j >= 0) & (k >= 0) & (i < nx) & (j < ny) & (k < nz)
        flat = np.where(inside, (i * ny + j) * nz + k, 0)
        alive = np.cumsum(blocked[flat] | ~inside, axis=-1) == 0  # before the first occupied cell or the edge
        in_view[flat[alive & unknown[flat]]] = True
    return gains, yaws, in_view.reshape(nx, ny, nz)


def blocking_cells(state: np.ndarray, grid: PlanningGrid) -> np.ndarray:
    """Cells that stop a line of sight: seen occupied, mapped objects, unlabelled obstacles."""
    b = np.asarray(state) == OCCUPIED
    if grid.reason is not None:
        b = b | (grid.reason == Closed.OBJECT) | (grid.reason == Closed.UNLABELLED)
    return b


def cells_in_view(state: np.ndarray, grid: PlanningGrid, eye: Sequence[float], yaw: float,
                  target_height: float) -> np.ndarray:
    """The unknown cells a camera at ``eye`` (world [m]) facing ``yaw`` [rad] has in view (``bool``)."""
    e = np.asarray([[float(v) for v in eye]])
    _, _, cells = view_gain(np.asarray(state), blocking_cells(state, grid), grid, e,
                            grid.workspace.floor + float(target_height), yaw=yaw)
    return cells


def _mode_words(mode: str) -> str:
    return "on the floor" if mode == "walk" else "hovering"


def score_viewpoints(state: np.ndarray, grid: PlanningGrid, cost: np.ndarray, start_cell: Sequence[int],
                     target_height: float, *, seen_only: bool = True, limit: int = 5,
                     max_candidates: int = MAX_CANDIDATES, looked: np.ndarray | None = None) -> list[Viewpoint]:
    """The best ``limit`` viewpoints, best first (empty when no reachable frontier is left).

    Args:
        state: Known-space states on the grid's cells (``uint8 [nx, ny, nz]``).
        grid: The planning grid (its ``reason`` names mapped-object cells; ``robot`` the camera height).
        cost: The planner's per-cell cost [1/m] (``Route.cost_array``).
        start_cell: The robot's cell.
        target_height: The target's height [m] (a robot dog: 0.4): unknown space up to it counts fully.
        seen_only: Candidates must be seen free (else any reachable passable cell).
        limit: How many to return.
        max_candidates: Candidates scored (evenly subsampled beyond).
        looked: Cells in view of earlier captures that stayed unknown (``bool``; they count no more:
            the camera could not see them after all, e.g. the mapper's own limits).
    """
    st = np.asarray(state)
    ws = grid.workspace
    if st.shape != ws.shape:
        raise SearchViewpointError(f"state: must have the grid's shape {ws.shape}, got {st.shape}")
    if not (isinstance(target_height, (int, float)) and math.isfinite(target_height) and 0 < target_height < 10):
        raise SearchViewpointError(f"target_height: must be finite and within 0..10 m, got {target_height!r}")
    dist = path_costs(grid, cost, start_cell)
    reach = np.isfinite(dist)
    unknown = st == UNKNOWN
    if looked is not None:
        unknown = unknown & ~np.asarray(looked, dtype=bool)
    near_unknown = ndimage.binary_dilation(unknown, ndimage.generate_binary_structure(3, 3),
                                           iterations=FRONTIER_CELLS)
    cand = reach & near_unknown
    if seen_only:
        cand &= st == FREE
    idx = np.argwhere(cand)
    if len(idx) == 0:
        return []
    if len(idx) > max_candidates:
        idx = idx[np.linspace(0, len(idx) - 1, max_candidates).round().astype(int)]
    eyes = ws.centers(idx)
    ground = idx[:, 2] == 0
    eyes[ground, 2] = ws.floor
    eyes[:, 2] += grid.robot.camera_height  # the camera rides on the robot, in the air too
    blocking = blocking_cells(st, grid)
    gains, yaws, _ = view_gain(st, blocking, grid, eyes, ws.floor + float(target_height), looked)
    costs = dist[tuple(idx.T)]
    scores = gains / (costs + COST0)
    order = np.argsort(-scores, kind="stable")[:max(1, int(limit))]
    out: list[Viewpoint] = []
    for n in order:
        if gains[n] <= 0:
            continue
        mode = "walk" if ground[n] else "fly"
        goal = ws.centers(idx[n:n + 1])[0]
        if ground[n]:
            goal[2] = ws.floor
        eye = eyes[n]
        why = (f"({eye[0]:.2f}, {eye[1]:.2f}, {eye[2]:.2f}) m {_mode_words(mode)}, facing "
               f"{math.degrees(yaws[n]) % 360:.0f}°: sees {gains[n]:.2f} m³ of unknown space where the target can be, "
               f"path cost {costs[n]:.1f} (score {scores[n]:.3f})")
        out.append(Viewpoint(tuple(float(v) for v in goal), tuple(float(v) for v in eye), float(yaws[n]), mode,
                             float(gains[n]), float(costs[n]), float(scores[n]), why))
    return out


def confirm_viewpoint(state: np.ndarray, grid: PlanningGrid, cost: np.ndarray, start_cell: Sequence[int],
                      target: SceneObject, avoid: Sequence[Sequence[float]] = (), away: float = 0.5) -> Viewpoint | None:
    """Where to confirm a target seen once from: a reachable seen-free spot (floor or hover) whose
    level camera, turned to face the target's centre, has it between :data:`MIN_RANGE` and
    :data:`MAX_RANGE` and within its vertical field of view, with a clear line of sight (no occupied
    cell, mapped object or unlabelled obstacle on the way; the target's own cells excepted), farther
    than ``away`` [m] in plan from each spot in ``avoid`` (where confirming captures were taken). The
    least ``path cost + 2 x distance to the target`` wins (near views map small objects better);
    ``None`` when none. World frame [m], heading [rad]."""
    st = np.asarray(state)
    ws = grid.workspace
    if st.shape != ws.shape:
        raise SearchViewpointError(f"state: must have the grid's shape {ws.shape}, got {st.shape}")
    dist = path_costs(grid, cost, start_cell)
    idx = np.argwhere(np.isfinite(dist) & (st == FREE))
    if len(idx) == 0:
        return None
    centres = ws.centers(idx)
    ground = idx[:, 2] == 0
    eyes = centres.copy()
    eyes[ground, 2] = ws.floor
    eyes[:, 2] += grid.robot.camera_height
    for a in avoid:
        far = np.hypot(eyes[:, 0] - float(a[0]), eyes[:, 1] - float(a[1])) > away
        idx, centres, ground, eyes = idx[far], centres[far], ground[far], eyes[far]
    t = np.asarray(target.position, dtype=np.float64)
    d = t[None, :] - eyes
    flat = np.hypot(d[:, 0], d[:, 1])
    rng = np.hypot(flat, d[:, 2])
    ok = (rng >= MIN_RANGE) & (rng <= MAX_RANGE) & (np.abs(np.arctan2(d[:, 2], flat)) <= 0.92 * grid.robot.camera_half_vfov)
    idx, ground, eyes, rng = idx[ok], ground[ok], eyes[ok], rng[ok]
    if len(idx) == 0:
        return None
    costs = dist[tuple(idx.T)]
    rank = costs + 2.0 * rng
    order = np.argsort(rank, kind="stable")[:400]
    blocking = blocking_cells(st, grid).copy()
    if grid.owner is not None and target.id in grid.owners:  # the target's own cells do not hide it
        mine = grid.owner == grid.owners.index(target.id)
        blocking &= ~ndimage.binary_dilation(mine, iterations=1)  # its seen surface too (mapped a little off)
    tcell = ws.cell_of(tuple(t))
    if tcell is None:
        return None
    seen = line_of_sight(grid, blocking, eyes[order], np.asarray([tcell], dtype=np.int64))[:, 0]
    if not seen.any():
        return None
    n = order[int(np.argmax(seen))]
    goal = ws.centers(idx[n:n + 1])[0]
    if ground[n]:
        goal[2] = ws.floor
    eye = eyes[n]
    yaw = math.atan2(t[1] - eye[1], t[0] - eye[0])
    mode = "walk" if ground[n] else "fly"
    why = (f"({eye[0]:.2f}, {eye[1]:.2f}, {eye[2]:.2f}) m {_mode_words(mode)}, facing {math.degrees(yaw) % 360:.0f}°: "
           f"sees {target.id} {rng[n]:.1f} m away to confirm it, path cost {costs[n]:.1f}")
    return Viewpoint(tuple(float(v) for v in goal), tuple(float(v) for v in eye), float(yaw), mode, 0.0,
                     float(costs[n]), 0.0, why)


__all__ = ["COST0", "confirm_viewpoint", "blocking_cells", "cells_in_view", "MAX_RANGE", "SearchViewpointError", "Viewpoint", "path_costs", "score_viewpoints", "view_gain"]
