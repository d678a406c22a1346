"""Where to look from: a reachable seen-free spot from which the camera can see a point not seen yet.

Given the planner's costs, :func:`suggest_viewpoint` is the look of :func:`planner.goal_look.next_look`
(the goal's own cells seen with the real camera model, hover spots included). The rest of this module
is the simpler rule used with only a passable mask:

World frame (z up) [m]. Candidates are the passable cells of the planning grid joined to the
robot's start (face-connected, as the A* moves without corner cutting): on the floor layer the
camera stands at ``robot.camera_height`` above the floor; in the air it rides that high above the cell's centre. A
candidate sees the target when

- the target lies between :data:`MIN_RANGE` and :data:`MAX_RANGE` from the camera,
- its elevation from the camera is within the camera's half vertical field of view (the robot
  turns to face it: any heading), and
- the straight line to it crosses no object, no unlabelled obstacle and no column under a floating
  object (sampled every half cell; unknown cells on the way do not block: that is what the look
  is for).

The best candidate is the one with the least ``distance from the robot x layer weight + half the
distance to the target`` (walking spots preferred: flying costs three times as much, as the
planner's flight layers do).

When no reachable spot sees the target (e.g. the floor just behind a wall taller than the camera:
a level camera never looks down more than its half field of view), :func:`frontier_spot` gives the
next place to Look around: the reachable cell at the edge of what was seen nearest the target.
"""

from __future__ import annotations

import math
from typing import Sequence

import numpy as np
from scipy import ndimage

from planner.cspace import dilate
from planner.goal_look import next_look
from planner.grid import Closed, PlanningGrid

MIN_RANGE = 0.5
"""Nearest a viewpoint may be to the target [m] (the mapper drops objects closer to the camera)."""

MAX_RANGE = 5.0
"""Farthest a viewpoint may be from the target [m] (objects far away map poorly)."""

FLIGHT_WEIGHT = 3.0
"""How much dearer a viewpoint in the air is per metre from the robot."""

MAX_CANDIDATES = 600
"""Best-scored candidates whose line of sight is checked."""

_BLOCKING = (Closed.OBJECT, Closed.UNLABELLED, Closed.SURFACE, Closed.BENEATH)
_FACES = ndimage.generate_binary_structure(3, 1)


def frontier_spot(grid: PlanningGrid, passable: np.ndarray, start_cell: Sequence[int],
                  target: Sequence[float]) -> tuple[float, float, float] | None:
    """Where to Look around next when no reachable spot sees ``target``: the reachable cell next to
    unknown space (a frontier: within the robot's radius and a cell of unknown cells) nearest the target, ties to the
    one nearest the robot (camera position, world [m]); ``None`` when the robot reaches no frontier."""
    ws = grid.workspace
    s = tuple(int(v) for v in start_cell)
    if grid.reason is None or not passable[s]:
        return None
    lab, _ = ndimage.label(passable, _FACES)
    reach = lab == lab[s]
    unknown = grid.reason == Closed.UNKNOWN
    # within the robot's radius and a cell of unknown space (nearer cells are closed for its size)
    near_unknown = dilate(unknown, max(grid.robot.radius, grid.robot.flying_radius) + ws.resolution,
                          ws.resolution) & reach
    idx = np.argwhere(near_unknown)
    if len(idx) == 0:
        return None
    eyes = ws.centers(idx)
    ground = idx[:, 2] == 0
    eyes[ground, 2] = ws.floor + grid.robot.camera_height
    t = np.asarray([float(v) for v in target])
    here = ws.centers(np.array([s]))[0]
    score = np.linalg.norm(eyes - t, axis=1) + 0.25 * np.linalg.norm(eyes - here, axis=1)
    best = eyes[int(np.argmin(score))]
    return (float(best[0]), float(best[1]), float(best[2]))


def suggest_viewpoint(grid: PlanningGrid, passable: np.ndarray, start_cell: Sequence[int],
                      target: Sequence[float]) -> tuple[float, float, float] | None:
    """The camera position (world [m]) of the best reachable viewpoint that sees ``target``, or
    ``None`` when no reachable spot does (then: Look around, or the next look of a chain).

    Args:
        grid: The planning grid.
        passable: The planner's per-cell cost [1/m] (``inf`` impassable): the look of
            :func:`planner.goal_look.next_look` (hover spots included, scored by the goal's cells it
            sees with the real camera, occlusion included), when it sees any of them; or
            ``bool [nx, ny, nz]`` cells the robot may be in: the nearest spot whose line of sight to the
            target point is clear (no gain).
        start_cell: The robot's cell (must be passable).
        target: The point to see (world [m]).
    """
    if np.asarray(passable).dtype != bool:
        looks = next_look(grid, np.asarray(passable, dtype=np.float64), start_cell, target)
        return looks[0].eye if looks and looks[0].sees > 0 else None
    ws = grid.workspace
    s = tuple(int(v) for v in start_cell)
    if not passable[s]:
        return None
    lab, _ = ndimage.label(passable, _FACES)
    reach = lab == lab[s]
    idx = np.argwhere(reach)
    if len(idx) == 0:
        return None
    eyes = ws.centers(idx)
    ground = idx[:, 2] == 0
    eyes[ground, 2] = ws.floor
    eyes[:, 2] += grid.robot.camera_height  # the camera rides on the robot, hovering too
    t = np.asarray([float(v) for v in target])
    d = t - eyes
    dist = np.linalg.norm(d, axis=1)
    elev = np.abs(np.arctan2(d[:, 2], np.hypot(d[:, 0], d[:, 1])))
    ok = (dist >= MIN_RANGE) & (dist <= MAX_RANGE) & (elev <= grid.robot.camera_half_vfov)
    if not ok.any():
        return None
    idx, eyes, dist, ground = idx[ok], eyes[ok], dist[ok], ground[ok]
    here = ws.centers(np.array([s]))[0]
    weight = np.where(ground, 1.0, FLIGHT_WEIGHT)
    score = np.linalg.norm(eyes - here, axis=1) * weight + 0.5 * dist
    order = np.argsort(score, kind="stable")[:MAX_CANDIDATES]
    blocking = np.isin(grid.reason, [int(c) for c in _BLOCKING]) if grid.reason is not None else \
        grid.state == 2
    tcell = ws.cell_of(t)
    if tcell is not None:  # the target's own cell may hold what is to be seen
        blocking = blocking.copy()
        blocking[tcell] = False
    # every candidate's line of sight at once: samples every half cell (at most MAX_RANGE long)
    e = eyes[order]
    m = int(math.ceil(MAX_RANGE / (ws.resolution / 2.0))) + 1
    f = np.linspace(0.0, 1.0, m)
    pts = e[:, None, :] + f[None, :, None] * (t - e)[:, None, :]  # [N, m, 3]
    cells = np.floor((pts - np.asarray(ws.min)) / ws.resolution).astype(np.int32)
    nx, ny, nz = ws.shape
    i, j, k = cells[..., 0], cells[..., 1], cells[..., 2]
    inside = (i >= 0) & (j >= 0) & (k >= 0) & (i < nx) & (j < ny) & (k < nz)
    flat = np.where(inside, (i * ny + j) * nz + k, 0)
    blocked = (blocking.ravel()[flat] & inside).any(axis=1)
    free = np.nonzero(~blocked)[0]
    if len(free) == 0:
        return None
    best = e[free[0]]
    return (float(best[0]), float(best[1]), float(best[2]))


__all__ = ["FLIGHT_WEIGHT", "MAX_RANGE", "MIN_RANGE", "frontier_spot", "suggest_viewpoint"]
