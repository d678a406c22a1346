"""Where to look from so that a goal not seen yet becomes plannable: the next look of a chain.

World frame (z up) [m], headings counter-clockwise from +x [rad]. A goal in unknown space is
refused until the cells the planner needs around it are seen free: for a floor goal the walking
column within the robot's radius (plus the danger band the take-off layer keeps clear) up to the
landing height; for a hover goal the cells within the flying radius. These are the goal's
**needed** cells. The unknown space around the goal (within :data:`NEIGHBOURHOOD` in plan, up to
:data:`NEIGHBOURHOOD_TOP` above the floor) is its **neighbourhood**: seeing it opens the seen-free
air the next look can hover in.

**Candidates** are the cells the robot can reach from its start (the planner's per-cell costs,
:func:`planner.search_viewpoints.path_costs`): on the floor the camera stands at
``robot.camera_height``; hovering, it rides ``robot.camera_height`` above the hover point. Each
candidate faces the goal (the robot turns in place: a ``TURN`` segment).

**What a candidate sees.** The simulated and MorphoGear's default camera is fixed and level: a
cell is in view when its bearing from the camera is within half the horizontal field of view of
the heading, its elevation within half the vertical field of view (so from a camera ``h`` above a
point the floor shows only beyond ``h / tan(half_vfov)``), and its distance within
:data:`planner.view_rays.MIN_RANGE` .. ``VIEW_RANGE``; and when the straight line to it crosses no occupied cell,
mapped object or unlabelled obstacle (sampled every half cell; unknown cells do not block: that is
what the look is for). These are the rules of the search's ray casting
(:func:`planner.search_viewpoints.view_gain`, whose path costs and blocking cells are reused here), aimed
at the cells that matter: one ray per cell (:mod:`planner.view_rays`) instead of its fan of five
elevation rays, too sparse for the few small cells a goal needs.

**Score.** ``(NEED_WEIGHT x needed cells seen + neighbourhood seen) / (path cost + COST0)``, the
neighbourhood cells weighted by ``1 / (1 + distance from the goal)``; a candidate that sees needed
cells always wins over one that does not (then the goal is plannable after the look, or nearly).
A candidate within :data:`REPEAT_DISTANCE` of where the robot already captured from, facing within
:data:`REPEAT_YAW` of that capture's heading, is never suggested: that view was had.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Iterable, Sequence

import numpy as np

from scipy import ndimage

from planner.astar import AStarSearcher
from planner.cspace import cube_ball, dilate
from planner.flight_body import flight_dilate
from planner.grid import Closed, CostWeights, GridError, PlanningGrid, build_grid
from planner.search_viewpoints import UNKNOWN, blocking_cells, path_costs
from planner.view_rays import VIEW_RANGE, in_view, line_of_sight, wrap as _wrap

Vec3 = tuple[float, float, float]

NEIGHBOURHOOD = 2.5
"""Radius in plan [m] of the goal's neighbourhood."""
NEIGHBOURHOOD_TOP = 2.5
"""Height above the floor [m] up to which the neighbourhood counts."""
NEED_WEIGHT = 4.0
"""Weight of a needed cell (against a cell around a spot to open: 1)."""
NEAR_WEIGHT = 0.25
"""Weight of an unknown neighbourhood cell next to the goal (falls as ``1 / (1 + d)`` with distance)."""
FLOOR_WEIGHT = 3.0
"""Weight of a needed cell within the walking body's height when choosing spots (the floor is the hard part)."""
UNKNOWN_PENALTY = 10.0
"""How much dearer unknown space is than seen-free space on the route to a spot (on top of the
planner's own unseen-cell cost): the route opens as little unknown space as it can."""
LANDING_TOP = 1.0
"""Height above the floor [m] up to which a floor goal's column must be seen (the landing descent)."""
REPEAT_DISTANCE = 0.75
"""A candidate this close [m] to an earlier capture's camera ..."""
REPEAT_YAW = math.radians(45.0)
"""... facing within this of its heading [rad] is not suggested again."""
COST0 = 2.0
"""Added to the path cost in the score [cost·m] (two metres of walking): near spots are not free."""
MAX_SCORED = 250
"""Candidates whose lines of sight are cast (the best by field-of-view count per cost)."""
MAX_NEIGHBOURS = 400
"""Neighbourhood cells sampled (evenly) for the score."""
WIDEN_HEADINGS = 8
"""Headings tried (evenly round) when only the edge of where the robot can go is left to look at."""


class GoalLookError(ValueError):
    """Bad inputs (target, start cell); the message names the field."""


@dataclass(frozen=True)
class Look:
    """The next look towards a goal.

    Attributes:
        goal: Where the robot goes (world [m]): a floor point (z = floor) or a hover point.
        eye: Camera position there (world [m]).
        yaw: Heading to face [rad] (towards the goal).
        mode: ``walk`` (on the floor) or ``fly`` (hovering).
        sees: Share of the goal's needed unknown cells in view from there [0..1].
        needed: How many needed cells are unknown now.
        gain: Weighted neighbourhood cells in view.
        cost: The planner's path cost to get there [cost·m].
        why: One line for the operator.
    """

    goal: Vec3
    eye: Vec3
    yaw: float
    mode: str
    sees: float
    needed: int
    gain: float
    cost: float
    why: str


def known_state(grid: PlanningGrid) -> np.ndarray:
    """Known-space states on the grid's cells (``uint8``: 0 unknown, 1 seen free, 2 occupied): from the
    known space the grid was built with, else from its reasons (closed as unknown: 0; else 1)."""
    known = (grid.build or {}).get("known")
    ws = grid.workspace
    if known is not None:
        try:
            st, _ = known.planning_view(ws.min, ws.shape, ws.resolution, grid.objects)
            return np.asarray(st, dtype=np.uint8)
        except ValueError:
            pass
    st = np.ones(ws.shape, dtype=np.uint8)
    if grid.reason is not None:
        st[grid.reason == Closed.UNKNOWN] = UNKNOWN
    return st


def needed_cells(grid: PlanningGrid, state: np.ndarray, target: Sequence[float]) -> np.ndarray:
    """Indices ``[K, 3]`` of the unknown cells that keep ``target`` (world [m]) closed: for a floor
    goal the column within the walking radius plus the danger band and a half cell in plan, up to
    :data:`LANDING_TOP` (and the body height); in the air the cells within the flying radius plus a cell."""
    ws = grid.workspace
    xs, ys, zs = ws.axes()
    t = [float(v) for v in target]
    rb = grid.robot
    unknown = np.asarray(state) == UNKNOWN
    if t[2] - ws.floor < ws.resolution:
        reach = max(rb.radius, rb.flying_radius) + 0.25 + ws.resolution / 2
        plan = np.hypot(xs[:, None] - t[0], ys[None, :] - t[1]) <= reach
        top = ws.floor + max(LANDING_TOP, rb.height) + ws.resolution / 2
        mask = plan[:, :, None] & (zs <= top)[None, None, :]
    else:
        r = rb.flying_radius + ws.resolution
        mask = ((xs[:, None, None] - t[0]) ** 2 + (ys[None, :, None] - t[1]) ** 2
                + (zs[None, None, :] - t[2]) ** 2) <= r * r
    return np.argwhere(mask & unknown)


def _neighbourhood(grid: PlanningGrid, state: np.ndarray, target: Sequence[float],
                   skip: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Sampled unknown neighbourhood cells ``[M, 3]`` and their weights (``NEAR_WEIGHT / (1 + d)``,
    ``d`` the distance in plan from the goal [m])."""
    ws = grid.workspace
    xs, ys, zs = ws.axes()
    d = np.hypot(xs[:, None] - float(target[0]), ys[None, :] - float(target[1]))
    mask = (d <= NEIGHBOURHOOD)[:, :, None] & (zs <= ws.floor + NEIGHBOURHOOD_TOP)[None, None, :]
    mask &= np.asarray(state) == UNKNOWN
    if len(skip):
        mask[tuple(skip.T)] = False
    idx = np.argwhere(mask)
    if len(idx) > MAX_NEIGHBOURS:
        idx = idx[np.linspace(0, len(idx) - 1, MAX_NEIGHBOURS).round().astype(int)]
    w = NEAR_WEIGHT / (1.0 + d[idx[:, 0], idx[:, 1]]) if len(idx) else np.zeros(0)
    return idx, w


def _eyes_of(grid: PlanningGrid, idx: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Camera positions [m] of the robot in cells ``idx`` and which are on the floor."""
    ws = grid.workspace
    eyes = ws.centers(idx)
    ground = idx[:, 2] == 0
    eyes[ground, 2] = ws.floor
    eyes[:, 2] += grid.robot.camera_height
    return eyes, ground


def spots_to_open(grid: PlanningGrid, state: np.ndarray, target: Sequence[float], need: np.ndarray,
                  blocking: np.ndarray) -> tuple[np.ndarray, float]:
    """Where the robot *could* see the goal's needed cells from once the space there is seen: the unknown
    cells ``[K, 3]`` around the best such spots (within the flying radius and a half cell of the robot
    there), and the share of the needed cells the best spot sees. Spots are cells (every other one in
    plan) within :data:`VIEW_RANGE` of the goal, clear of what blocks by the robot's radius."""
    ws = grid.workspace
    if len(need) == 0:
        return np.zeros((0, 3), dtype=np.int64), 0.0
    rb = grid.robot
    # the flying body as the planner keeps it (the sphere and the body's height above the spot)
    clear = ~flight_dilate(blocking, rb, ws.resolution)
    clear[:, :, :2] = False  # hovering spots only: a floor spot needs its floor seen (the same problem)
    sub = np.zeros(ws.shape, dtype=bool)
    sub[::2, ::2, :] = True
    xs, ys, _ = ws.axes()
    near = (np.hypot(xs[:, None] - float(target[0]), ys[None, :] - float(target[1])) <= VIEW_RANGE)[:, :, None]
    idx = np.argwhere(clear & sub & near)
    if len(idx) == 0:
        return np.zeros((0, 3), dtype=np.int64), 0.0
    eyes, _ = _eyes_of(grid, idx)
    yaws = np.arctan2(float(target[1]) - eyes[:, 1], float(target[0]) - eyes[:, 0])
    nd = need if len(need) <= 40 else need[np.linspace(0, len(need) - 1, 40).round().astype(int)]
    fov = in_view(eyes, yaws, ws.centers(nd), rb.camera_half_vfov)
    rough = fov.sum(axis=1)
    cand = np.nonzero(rough >= max(1, 0.5 * rough.max()))[0]
    if len(cand) == 0:
        return np.zeros((0, 3), dtype=np.int64), 0.0
    low = np.where(nd[:, 2] < grid.walk_layers(), FLOOR_WEIGHT, 1.0)  # the floor is the hard part
    seen = line_of_sight(grid, blocking, eyes[cand], nd, fov[cand]) @ low
    best = seen.max()
    if best <= 0:
        return np.zeros((0, 3), dtype=np.int64), 0.0
    good = cand[seen >= 0.7 * best]
    return idx[good], float(best) / float(low.sum())


def cells_to_open(grid: PlanningGrid, cost: np.ndarray, start_cell: Sequence[int], state: np.ndarray,
                  spots: np.ndarray, weights: CostWeights = CostWeights()) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The unknown cells ``[K, 3]`` that keep the robot from the cheapest spot (see :func:`spots_to_open`):
    the route planned as if unknown space were passable (the planner's ``unknown="allow"`` grid, unknown
    cells :data:`UNKNOWN_PENALTY` times dearer; seen-free cells as ``cost`` says) to the cheapest spot; the unknown cells
    within the robot's radius (and a half cell) of its unseen part and of the spot. Returns the cells, their
    weights (``1 / (1 + s)``, ``s`` the route's length [m] from its first unseen cell: what blocks the next
    step counts most) and the first unseen stretch's cells (where to face)."""
    ws = grid.workspace
    empty = np.zeros((0, 3), dtype=np.int64)
    if len(spots) == 0:
        return empty, np.zeros(0), empty
    kw = dict(grid.build or {"robot": grid.robot})
    if kw.get("known") is None:
        return empty, np.zeros(0), empty
    kw["unknown"] = "allow"
    try:
        opt = build_grid(list(grid.objects), ws, **kw)
    except (GridError, ValueError):
        return empty, np.zeros(0), empty
    c = np.where(np.isfinite(cost), cost, UNKNOWN_PENALTY * opt.cost(weights))
    s = tuple(int(v) for v in start_cell)
    reach = path_costs(opt, c, s)[tuple(spots.T)]
    if not np.isfinite(reach).any():
        return empty, np.zeros(0), empty
    sp = spots[int(np.argmin(reach))]
    best = AStarSearcher().search(c, s, tuple(int(v) for v in sp), resolution=ws.resolution, no_corner_cutting=True)
    if not best.found:
        return empty, np.zeros(0), empty
    path = best.path.astype(np.int64)
    unknown = np.asarray(state) == UNKNOWN
    k = grid.walk_layers()
    on = ~np.isfinite(cost[tuple(path.T)]) if len(path) else np.zeros(0, dtype=bool)  # closed today
    # every cell the robot's body passes through on the unseen part, and at the spot
    mark = np.zeros(ws.shape, dtype=bool)
    first = int(np.argmax(on)) if on.any() else len(path) - 1
    step = np.r_[0.0, np.linalg.norm(np.diff(path, axis=0), axis=1) * ws.resolution]
    along = np.cumsum(step) - np.cumsum(step)[first]
    r = max(grid.robot.radius, grid.robot.flying_radius) + ws.resolution / 2
    order = np.full(ws.shape, np.inf)
    up = int(math.ceil(grid.robot.height / ws.resolution - 1e-9))  # the flying body's height above its cell
    for n in range(first, len(path)):
        i, j, z = path[n]
        if not (on[n] or n == len(path) - 1):
            continue
        mark[i, j, z] = True
        lo = z if z > 0 else 0
        hi = z + 1 + up if z > 0 else k
        order[i, j, lo:hi] = np.minimum(order[i, j, lo:hi], max(0.0, along[n]))
        mark[i, j, lo:hi] = True
    body = dilate(mark, r, ws.resolution) & unknown
    # each body cell takes the route position of the nearest marked cell (a dilation of the order)
    dist_order = ndimage.grey_erosion(np.where(np.isfinite(order), order, 1e9), footprint=cube_ball(r, ws.resolution, 3))
    cells = np.argwhere(body)
    w = 1.0 / (1.0 + np.minimum(dist_order[tuple(cells.T)], 1e3)) if len(cells) else np.zeros(0)
    stretch = cells[w >= 1.0 / (1.0 + 1.5)] if len(cells) else empty
    return cells, w, stretch


def _repeats(eyes: np.ndarray, yaws: np.ndarray, avoid: Sequence[tuple[Sequence[float], float]]) -> np.ndarray:
    bad = np.zeros(len(eyes), dtype=bool)
    for pos, yaw in avoid:
        p = np.asarray([float(v) for v in pos[:3]])
        near = np.linalg.norm(eyes - p, axis=1) <= REPEAT_DISTANCE
        bad |= near & (np.abs(_wrap(yaws - float(yaw))) <= REPEAT_YAW)
    return bad


def _some_look_sees(grid: PlanningGrid, blocking: np.ndarray, eyes: np.ndarray, need: np.ndarray,
                    target: Sequence[float], avoid: list) -> bool:
    """Whether any candidate camera ``eyes``, facing the target, sees a needed cell (then no chain is needed)."""
    if len(need) == 0 or len(eyes) == 0:
        return False
    yaws = np.arctan2(float(target[1]) - eyes[:, 1], float(target[0]) - eyes[:, 0])
    keep = ~_repeats(eyes, yaws, avoid) & (np.hypot(target[0] - eyes[:, 0], target[1] - eyes[:, 1]) >= 0.25)
    if not keep.any():
        return False
    fov = in_view(eyes[keep], yaws[keep], grid.workspace.centers(need), grid.robot.camera_half_vfov)
    return bool(fov.any() and line_of_sight(grid, blocking, eyes[keep], need, fov).any())


def next_look(grid: PlanningGrid, cost: np.ndarray, start_cell: Sequence[int], target: Sequence[float], *,
              state: np.ndarray | None = None, avoid: Iterable[tuple[Sequence[float], float]] = (),
              limit: int = 1) -> list[Look]:
    """The best ``limit`` looks towards ``target`` (world [m]), best first; empty when no reachable
    candidate sees anything of it or of its neighbourhood.

    Args:
        grid: The planning grid (unknown space closed: the candidates are seen free).
        cost: The planner's per-cell cost [1/m] (``Route.cost_array``; ``inf`` impassable).
        start_cell: The robot's cell.
        target: The goal not seen yet (world [m]; on the floor for a walking / landing goal).
        state: Known-space states on the grid's cells (default :func:`known_state`).
        avoid: ``(camera position [m], heading [rad])`` of earlier captures: not suggested again.
        limit: How many to return.
    """
    ws = grid.workspace
    t = [float(v) for v in target]
    if len(t) != 3 or not all(math.isfinite(v) for v in t):
        raise GoalLookError(f"target: must be 3 finite numbers [m], got {target!r}")
    st = known_state(grid) if state is None else np.asarray(state)
    if st.shape != ws.shape:
        raise GoalLookError(f"state: must have the grid's shape {ws.shape}, got {st.shape}")
    blocking = blocking_cells(st, grid)
    need = needed_cells(grid, st, t)
    dist = path_costs(grid, cost, start_cell)
    # cells opened only as the robot's own (free by definition where it is) are no place to go to
    ok = np.isfinite(dist) & np.isfinite(grid.cost(CostWeights()))
    ok[tuple(int(v) for v in start_cell)] = bool(np.isfinite(dist[tuple(int(v) for v in start_cell)]))
    idx = np.argwhere(ok)
    eyes, ground = _eyes_of(grid, idx)
    base = (idx, eyes, ground)
    empty = np.zeros((0, 3), dtype=np.int64)
    spots, spot_w, stretch = empty, np.zeros(0), empty
    if not _some_look_sees(grid, blocking, eyes, need, t, avoid := list(avoid)):
        # the chain: the space to open so that a later look sees the goal
        spots_at, _ = spots_to_open(grid, st, t, need, blocking)
        spots, spot_w, stretch = cells_to_open(grid, cost, start_cell, st, spots_at)
    if len(spots):
        fresh = ~(need[:, None, :] == spots[None, :, :]).all(axis=2).any(axis=0) if len(need) else \
            np.ones(len(spots), dtype=bool)
        spots, spot_w = spots[fresh], spot_w[fresh]
    nb, nb_w = _neighbourhood(grid, st, t, np.concatenate([need, spots]) if len(spots) else need)
    pts_i = np.concatenate([need, spots, nb]).astype(np.int64) if len(need) + len(spots) + len(nb) else \
        np.zeros((0, 3), dtype=np.int64)
    if len(pts_i) == 0:
        return _widen(grid, st, blocking, dist, *base, t, avoid, len(need))
    kind = np.concatenate([np.zeros(len(need)), np.ones(len(spots)), np.full(len(nb), 2)])
    weight = np.concatenate([np.full(len(need), NEED_WEIGHT), spot_w, nb_w])
    # two headings each: towards the goal, and towards the middle of the spots to open
    aims = [np.asarray(t[:2])] + ([ws.centers(stretch)[:, :2].mean(axis=0)] if len(stretch) else [])
    yaws = np.concatenate([np.arctan2(a[1] - eyes[:, 1], a[0] - eyes[:, 0]) for a in aims])
    idx, eyes, ground = (np.concatenate([v] * len(aims)) for v in (idx, eyes, ground))
    keep = ~_repeats(eyes, yaws, avoid) & (np.hypot(t[0] - eyes[:, 0], t[1] - eyes[:, 1]) >= 0.25)
    idx, eyes, yaws, ground = idx[keep], eyes[keep], yaws[keep], ground[keep]
    if len(idx) == 0:
        return _widen(grid, st, blocking, dist, *base, t, avoid, len(need))
    costs = dist[tuple(idx.T)]
    pts = ws.centers(pts_i)
    fov = in_view(eyes, yaws, pts, grid.robot.camera_half_vfov)
    is_need = kind == 0
    # the goal's own cells first, for every candidate (few cells: cheap), then the rest for the best
    need_seen = line_of_sight(grid, blocking, eyes, need, fov[:, is_need]) if len(need) else \
        np.zeros((len(eyes), 0), dtype=bool)
    n_need = need_seen.sum(axis=1)
    bound = (NEED_WEIGHT * n_need + fov[:, ~is_need] @ weight[~is_need]) / (costs + COST0) + 1e6 * (n_need > 0)
    top = np.argsort(-bound, kind="stable")[:MAX_SCORED]
    top = top[bound[top] > 0]
    if len(top) == 0:
        return _widen(grid, st, blocking, dist, *base, t, avoid, len(need))
    seen = np.zeros((len(top), len(pts_i)), dtype=bool)
    seen[:, is_need] = need_seen[top]
    seen[:, ~is_need] = line_of_sight(grid, blocking, eyes[top], pts_i[~is_need], fov[top][:, ~is_need])
    seen_need = seen[:, is_need].sum(axis=1)
    gain = seen[:, kind > 0] @ weight[kind > 0]
    score = (seen @ weight) / (costs[top] + COST0) + 1e6 * seen_need
    order = np.argsort(-score, kind="stable")
    out: list[Look] = []
    for o in order:
        if len(out) >= max(1, int(limit)) or (seen_need[o] == 0 and gain[o] <= 0):
            break
        n = top[o]
        mode = "walk" if ground[n] else "fly"
        goal = ws.centers(idx[n:n + 1])[0]
        if ground[n]:
            goal[2] = ws.floor
        if any(math.dist(goal, lk.goal) < 0.3 for lk in out):
            continue
        eye = eyes[n]
        share = float(seen_need[o]) / len(need) if len(need) else 0.0
        where = "on the floor" if mode == "walk" else "hovering"
        sees = (f"sees {100 * share:.0f} % of the {len(need)} unseen cells around the goal" if seen_need[o]
                else f"sees {int(seen[o, kind > 0].sum())} unseen cells near the goal (opening the space "
                     "from which the goal can be seen)")
        why = (f"({eye[0]:.2f}, {eye[1]:.2f}, {eye[2]:.2f}) m {where}, facing {math.degrees(yaws[n]) % 360:.0f}°: "
               f"{sees}; path cost {costs[n]:.1f}")
        out.append(Look(tuple(float(v) for v in goal), tuple(float(v) for v in eye), float(yaws[n]), mode, share,
                        int(len(need)), float(gain[o]), float(costs[n]), why))
    return out or _widen(grid, st, blocking, dist, *base, t, avoid, len(need))


def _widen(grid: PlanningGrid, st: np.ndarray, blocking: np.ndarray, dist: np.ndarray, idx: np.ndarray,
           eyes: np.ndarray, ground: np.ndarray, t: Sequence[float], avoid: list, n_need: int) -> list[Look]:
    """When no reachable candidate sees the goal, its neighbourhood or the chain's cells: the look (any of
    :data:`WIDEN_HEADINGS` headings) that sees most of the unknown cells at the edge of where the robot can go
    (within its radius and a cell of a reachable cell, up to :data:`NEIGHBOURHOOD_TOP`; weighted
    ``1 / (1 + d)``, ``d`` their distance in plan from the goal [m]): more room for the next look."""
    ws = grid.workspace
    rb = grid.robot
    _, _, zs = ws.axes()
    edge = dilate(np.isfinite(dist), max(rb.radius, rb.flying_radius) + ws.resolution, ws.resolution)
    edge &= (np.asarray(st) == UNKNOWN) & (zs <= ws.floor + NEIGHBOURHOOD_TOP)[None, None, :]
    cells = np.argwhere(edge)
    if len(cells) == 0 or len(idx) == 0:
        return []
    if len(cells) > MAX_NEIGHBOURS:
        cells = cells[np.linspace(0, len(cells) - 1, MAX_NEIGHBOURS).round().astype(int)]
    pts = ws.centers(cells)
    w = 1.0 / (1.0 + np.hypot(pts[:, 0] - t[0], pts[:, 1] - t[1]))
    # the air a take-off needs seen (the flying body and the danger band over the take-off layer) counts most
    w[(pts[:, 2] > ws.floor + ws.resolution) & (pts[:, 2] <= ws.floor + 2 * ws.resolution + rb.height
                                                + rb.flying_radius)] *= FLOOR_WEIGHT
    costs = dist[tuple(idx.T)]
    if len(idx) > MAX_SCORED:  # the cheapest to reach
        near = np.argsort(costs, kind="stable")[:MAX_SCORED]
        idx, eyes, ground, costs = idx[near], eyes[near], ground[near], costs[near]
    k = len(idx)
    yaws = np.repeat(2 * np.pi * np.arange(WIDEN_HEADINGS) / WIDEN_HEADINGS, k)
    idx, eyes, ground, costs = (np.concatenate([v] * WIDEN_HEADINGS) for v in (idx, eyes, ground, costs))
    keep = ~_repeats(eyes, yaws, avoid)
    idx, eyes, ground, costs, yaws = idx[keep], eyes[keep], ground[keep], costs[keep], yaws[keep]
    if len(idx) == 0:
        return []
    fov = in_view(eyes, yaws, pts, rb.camera_half_vfov)
    bound = (fov @ w) / (costs + COST0)
    top = np.argsort(-bound, kind="stable")[:MAX_SCORED]
    top = top[bound[top] > 0]
    if len(top) == 0:
        return []
    seen = line_of_sight(grid, blocking, eyes[top], cells, fov[top])
    gain = seen @ w
    b = int(np.argmax(gain / (costs[top] + COST0)))
    if gain[b] <= 0:
        return []
    n = top[b]
    goal = ws.centers(idx[n:n + 1])[0]
    if ground[n]:
        goal[2] = ws.floor
    mode, eye = ("walk" if ground[n] else "fly"), eyes[n]
    why = (f"({eye[0]:.2f}, {eye[1]:.2f}, {eye[2]:.2f}) m {'on the floor' if ground[n] else 'hovering'}, facing "
           f"{math.degrees(yaws[n]) % 360:.0f}°: sees {int(seen[b].sum())} unseen cells at the edge of where the "
           f"robot can go (nothing it reaches sees the goal yet: more room for the next look); path cost {costs[n]:.1f}")
    return [Look(tuple(float(v) for v in goal), tuple(float(v) for v in eye), float(yaws[n]), mode, 0.0, n_need,
                 float(gain[b]), float(costs[n]), why)]


def hidden_by(grid: PlanningGrid, state: np.ndarray, eye: Sequence[float], yaw: float,
              target: Sequence[float]) -> str:
    """Why the goal's needed cells stayed unseen from a camera at ``eye`` (world [m]) facing ``yaw``
    [rad]: the object (or obstacle) most lines of sight hit first, or the camera's field of view
    (``"below the camera's view from there"``); ``""`` when nothing needed is unseen."""
    need = needed_cells(grid, np.asarray(state), target)
    if len(need) == 0:
        return ""
    e = np.asarray([[float(v) for v in eye]])
    pts = grid.workspace.centers(need)
    fov = in_view(e, np.asarray([float(yaw)]), pts, grid.robot.camera_half_vfov)[0]
    blocking = blocking_cells(np.asarray(state), grid)
    ws = grid.workspace
    names: dict[str, int] = {}
    for p in pts[fov]:
        f = np.linspace(0.0, 1.0, int(math.ceil(np.linalg.norm(p - e[0]) / (ws.resolution / 2))) + 2)[:-1]
        for q in e[0] + f[:, None] * (p - e[0]):
            c = ws.cell_of(q)
            if c is not None and blocking[c]:
                owner = grid.owner_of(c) if grid.owner is not None else None
                key = owner or ("an unlabelled obstacle" if grid.reason is not None and grid.reason[c] == Closed.UNLABELLED
                                else "a surface the depth map saw")
                names[key] = names.get(key, 0) + 1
                break
    out_of_view = int((~fov).sum())
    if names and max(names.values()) >= out_of_view:
        return f"hidden by {max(names, key=names.get)}"  # type: ignore[arg-type]
    if out_of_view:
        below = pts[~fov][:, 2] < e[0, 2]
        return ("below the camera's view from there (a level camera sees the floor only farther away)"
                if below.mean() >= 0.5 else "outside the camera's view from there")
    return "not reached by the capture's rays"


__all__ = ["GoalLookError", "LANDING_TOP", "Look", "hidden_by", "in_view", "known_state", "line_of_sight",
           "needed_cells", "next_look"]
