"""Goals by object: where to stand beside an object, and whether the robot can get there.

Everything is in the world frame (z up) [m]. An object is reached by standing on the floor
beside it: the **approach cell** is the passable ground-layer cell (``k = 0``, finite cost)
whose centre is nearest to the object's footprint (its oriented box seen from above), at most
:data:`APPROACH_MAX` away, such that

- the straight line to the footprint's nearest point crosses no other object at the object's
  height (the robot reaches over nothing: not across a wall around the object, but it may stand
  beside a table to reach the box on it), and
- the point keeps the robot's radius (the grid's ``margin``) from every object's footprint (the
  console refuses goals closer than that).

Ties go to the cell nearest the start, then to the lowest cell index: the choice is
deterministic. These two checks use the scene's objects (``objects`` argument).

Reachability from a start point, with the Aerial-Ground A*'s own rules:

- ``walk``: an approach cell lies in the start's ground component (ground cells joined through
  faces; with ``no_corner_cutting`` a diagonal move needs both cells it sweeps past passable, so
  face-connectivity is exactly what the A* can walk). A robot in the air counts from the floor
  cell under it (it can come down there, or fly on);
- ``fly``: no approach cell can be walked to, but one lies in the start's 3D component of
  passable cells (the robot takes off, flies over and lands on free floor, then walks). The
  approach cell is then a *landing spot*: free floor (not within the margin of an obstacle)
  with a passable take-off cell above, if one lies within :data:`APPROACH_MAX`; else any
  passable floor cell (the A* lands where it can and walks the rest);
- ``none``: no approach cell can be used; :attr:`Approach.code` says why, checked in this order
  (:data:`REASONS`): ``outside_workspace`` (no grid cell within :data:`APPROACH_MAX` of it: the
  object lies outside the planning workspace, which has to be widened), ``no_free_floor`` (every
  floor cell within :data:`APPROACH_MAX` is occupied), ``start_cut_off`` (the robot's own
  component holds no floor), ``closed_in`` (passable floor lies beside it but neither walking nor
  flying gets there), ``cramped`` (floor lies beside it, outside every object, but none is
  passable for the robot's size: none keeps its radius from every obstacle, or part of it is not
  seen yet; or floor the robot gets to lies beside it, but none keeps the robot's radius from
  every object), ``walled_off`` (some such floor keeps the radius, but another
  object stands between each spot and the object), ``planner`` (the A* found no path where the
  components said there was one). When an unreachable object's centre lies outside the workspace
  the reason says so too.

The chosen approach cell is then planned with the A* (:meth:`planner.route.Route.plan`), which
gives the path cost and, for a flight, the landing spot of the resulting mission.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass
from typing import Sequence

import numpy as np
from scipy import ndimage
from scipy.spatial import cKDTree

from pipeline.scene import Scene, SceneObject

from planner.grid import CellState, Closed, PlanningGrid
from planner.mission import MissionError, SegmentKind, mission_from_cells
from planner.route import Route

APPROACH_MAX = 1.0
"""Farthest an approach cell's centre may be from the object's footprint [m]."""

REACH_TOL = 0.02
"""Height overlap [m] below which another object does not stand between the robot and an object."""

REACH_STEP = 0.02
"""Sampling step [m] along the line from an approach point to the object."""

REASONS = ("start_unusable", "outside_workspace", "no_free_floor", "start_cut_off", "closed_in", "cramped",
           "walled_off", "planner")
"""Codes of why an object cannot be reached (:attr:`Approach.code`); ``start_unusable`` goes with mode
``unknown`` (the robot's own position cannot be planned from), the others with mode ``none``."""

Vec3 = tuple[float, float, float]


class ObjectGoalError(ValueError):
    """No object matches a name, or the start cannot be used."""


@dataclass(frozen=True)
class Approach:
    """How the robot gets beside one object.

    Attributes:
        object_id: The object.
        mode: ``walk``, ``fly``, ``none`` or ``unknown`` (the start itself is unusable).
        goal: The approach point on the floor (world [m]), ``None`` when unreachable.
        gap: Distance from the approach point to the object's footprint [m].
        cost: A* path cost from the start [cost·m] (``inf`` when unreachable).
        planned: Motions of the A* path (``walk`` or ``walk+fly``): the cheapest path may fly even
            when walking is possible.
        landing: The landing spot on the floor (world [m]) when the A* path flies, else ``None``.
        reason: Why the object is unreachable, empty otherwise.
        code: The reason as one of :data:`REASONS`, empty when reachable.
    """

    object_id: str
    mode: str
    goal: Vec3 | None = None
    gap: float = math.inf
    cost: float = math.inf
    planned: str = ""
    landing: Vec3 | None = None
    reason: str = ""
    code: str = ""


def footprint(obj: SceneObject) -> np.ndarray:
    """The four corners ``[4, 2]`` of an object's footprint (world x, y [m]), counter-clockwise."""
    w, _, l = obj.size
    c, s = math.cos(obj.yaw), math.sin(obj.yaw)
    ax = np.array([c, s]) * l / 2  # length axis
    ay = np.array([-s, c]) * w / 2  # width axis
    ctr = np.array(obj.position[:2], dtype=np.float64)
    return np.array([ctr + ax + ay, ctr - ax + ay, ctr - ax - ay, ctr + ax - ay])


def footprint_distance(obj: SceneObject, xy: np.ndarray) -> np.ndarray:
    """Distance [m] from points ``xy [N, 2]`` (world) to an object's footprint rectangle (0 inside)."""
    w, _, l = obj.size
    c, s = math.cos(obj.yaw), math.sin(obj.yaw)
    d = np.asarray(xy, dtype=np.float64).reshape(-1, 2) - np.asarray(obj.position[:2])
    along = np.abs(c * d[:, 0] + s * d[:, 1]) - l / 2
    across = np.abs(-s * d[:, 0] + c * d[:, 1]) - w / 2
    return np.hypot(np.maximum(along, 0.0), np.maximum(across, 0.0))


def _norm(text: str) -> str:
    return re.sub(r"[\s_\-]+", " ", text.strip().lower())


def find_object(scene: Scene, name: str, near: Sequence[float] | None = None) -> SceneObject:
    """The object a person names: an id (exact, then case-insensitive) or a label.

    Labels match with spaces, ``_`` and ``-`` treated alike (``robot dog`` = ``robot_dog``); when
    several objects share the label, the one nearest ``near`` (world [m], horizontal) wins, else
    the first by id. Raises :class:`ObjectGoalError` listing what the scene holds.
    """
    text = name.strip()
    if not text:
        raise ObjectGoalError("object name is empty")
    for o in scene.objects:
        if o.id == text:
            return o
    for o in scene.objects:
        if o.id.lower() == text.lower():
            return o
    want = _norm(text)
    hits = [o for o in scene.objects if _norm(o.label) == want]
    if not hits and want.endswith("s"):
        hits = [o for o in scene.objects if _norm(o.label) == want[:-1]]
    if not hits:
        labels = sorted({o.label for o in scene.objects})
        known = ", ".join(labels[:20]) + (" ..." if len(labels) > 20 else "")
        raise ObjectGoalError(f"no object with id or label {name!r} in the scene"
                              + (f" (labels: {known})" if labels else " (the scene is empty)"))
    if near is not None:
        return min(hits, key=lambda o: (math.dist(o.position[:2], near[:2]), o.id))
    return min(hits, key=lambda o: o.id)


class Reachability:
    """Reachability of objects from one start on one grid (components computed once).

    Args:
        grid: The planning grid (world frame).
        start: Where the robot is (world [m]); on the floor or in the air.
        route: A route on ``grid`` whose cost weights and A* are used (default: a new one).
        objects: The scene's objects: an approach point keeps the robot's radius (the grid's
            ``margin``) from every one of their footprints, as the console demands of a goal.
    """

    def __init__(self, grid: PlanningGrid, start: Sequence[float], route: Route | None = None,
                 objects: Sequence[SceneObject] = ()) -> None:
        self.grid = grid
        self.objects = tuple(objects)
        self.route = route if route is not None else Route(grid, start)
        self.start: Vec3 = (float(start[0]), float(start[1]), float(start[2]))
        cost = self.route.cost_array
        passable = np.isfinite(cost)
        conn = 1 if self.route.no_corner_cutting else None
        self._ground_ok = passable[:, :, 0]
        s_cell, why = self.route.check_point(self.start, "robot")
        self.start_problem = why
        self._walk = np.zeros_like(self._ground_ok)
        self._all = np.zeros_like(passable)
        self._landable = np.zeros_like(self._ground_ok)
        if s_cell is None:
            return
        lab3, _ = ndimage.label(passable, ndimage.generate_binary_structure(3, conn or 3))
        self._all = lab3 == lab3[s_cell]
        if self._ground_ok[s_cell[0], s_cell[1]]:  # on the floor, or in the air above passable floor
            lab2, _ = ndimage.label(self._ground_ok, ndimage.generate_binary_structure(2, conn or 2))
            self._walk = lab2 == lab2[s_cell[0], s_cell[1]]
        if passable.shape[2] > 1:  # free floor with a passable take-off cell above, joined to the robot
            self._landable = (grid.state[:, :, 0] == CellState.FREE) & self._all[:, :, 0] & self._all[:, :, 1]
        ws = grid.workspace
        xs, ys, _ = ws.axes()
        self._xy = np.stack(np.meshgrid(xs, ys, indexing="ij"), axis=-1)  # [nx, ny, 2]
        self._axes = (xs, ys)
        # [m] from each ground cell's centre to the nearest footprint, where that is within the margin
        # (each object only updates the cells near it: linear in the objects, not objects x cells)
        clearance = np.full(self._xy.shape[:2], np.inf)
        for o in self.objects:
            win = self._window(o, grid.margin)
            clearance[win] = np.minimum(clearance[win], footprint_distance(o, self._xy[win].reshape(-1, 2))
                                        .reshape(self._xy[win].shape[:2]))
        self._clearance = clearance
        self._modes = [(mode, cand) for mode, cand in (
            ("walk", self._walk & self._ground_ok), ("fly", self._landable), ("fly", self._all[:, :, 0] & self._ground_ok))
            if cand.any()]  # the candidate floor of each mode, once for every object
        self._centres = cKDTree(np.array([o.position[:2] for o in self.objects])) if self.objects else None
        self._reach_r = max((math.hypot(o.size[0], o.size[2]) for o in self.objects), default=0.0)

    def _window(self, obj: SceneObject, pad: float) -> tuple[slice, slice]:
        """Index slices of the ground cells whose centres may lie within ``pad`` [m] of ``obj``'s footprint."""
        f = footprint(obj)
        xs, ys = self._axes
        i0 = int(np.searchsorted(xs, f[:, 0].min() - pad - 1e-9, side="left"))
        i1 = int(np.searchsorted(xs, f[:, 0].max() + pad + 1e-9, side="right"))
        j0 = int(np.searchsorted(ys, f[:, 1].min() - pad - 1e-9, side="left"))
        j1 = int(np.searchsorted(ys, f[:, 1].max() + pad + 1e-9, side="right"))
        return slice(i0, i1), slice(j0, j1)

    def approach(self, obj: SceneObject, plan: bool = True) -> Approach:
        """Where to stand beside ``obj`` and how to get there (see the module docstring)."""
        if self.start_problem:
            return Approach(obj.id, "unknown", reason=self.start_problem, code="start_unusable")
        ws = self.grid.workspace
        connected = False  # some floor the robot gets to lies within APPROACH_MAX
        roomy = False  # ... and some of it keeps the robot's radius from every object
        win = self._window(obj, APPROACH_MAX)  # only cells near the object can be approach cells
        offset = np.array([win[0].start, win[1].start])
        for mode, cand in self._modes:
            idx = np.argwhere(cand[win]) + offset  # row-major, as over the whole grid
            if not len(idx):
                continue
            pts = self._xy[idx[:, 0], idx[:, 1]]
            gap = footprint_distance(obj, pts)
            near = gap <= APPROACH_MAX + 1e-9
            if not near.any():
                continue
            connected = True
            idx, pts, gap = idx[near], pts[near], gap[near]
            to_start = np.hypot(pts[:, 0] - self.start[0], pts[:, 1] - self.start[1])
            order = np.lexsort((idx[:, 1], idx[:, 0], np.round(to_start, 6), np.round(gap, 6)))
            clear = [int(b) for b in order if self._clear(idx[b])]
            roomy = roomy or bool(clear)
            best = next((b for b in clear if self._in_reach(obj, pts[b])), None)
            if best is None:
                continue
            goal = (float(pts[best, 0]), float(pts[best, 1]), float(ws.floor))
            if not plan:
                return Approach(obj.id, mode, goal, float(gap[best]))
            return self._planned(obj.id, mode, goal, float(gap[best]))
        code, reason = self._why_not(obj, connected, roomy)
        return Approach(obj.id, "none", reason=reason, code=code)

    def _why_not(self, obj: SceneObject, connected: bool, roomy: bool) -> tuple[str, str]:
        """``(code, text)``: why no approach cell beside ``obj`` can be used (order: module docstring)."""
        ws = self.grid.workspace
        box = (f"x {ws.min[0]:.2f} to {ws.max[0]:.2f} m, y {ws.min[1]:.2f} to {ws.max[1]:.2f} m")
        win = self._window(obj, APPROACH_MAX)
        near = np.zeros(self._xy.shape[:2], dtype=bool)
        near[win] = footprint_distance(obj, self._xy[win].reshape(-1, 2)).reshape(self._xy[win].shape[:2]) \
            <= APPROACH_MAX + 1e-9
        x, y = obj.position[0], obj.position[1]
        if not near.any():
            return "outside_workspace", (f"it lies outside the planning workspace ({box}; its centre at "
                                         f"({x:.2f}, {y:.2f})): widen the workspace to plan there")
        r = f"{APPROACH_MAX:.1f} m"
        floor = near & self._floor_not_object()
        if not floor.any():
            code, text = "no_free_floor", f"no free floor within {r} of it: obstacles cover the floor around it"
        elif not self._all[:, :, 0].any() and not self._walk.any():
            code, text = "start_cut_off", "the robot's position is cut off from the floor"
        elif not (near & self._ground_ok).any():
            unseen = self.grid.reason is not None and bool(
                np.any(self.grid.reason[:, :, 0][floor] == Closed.UNKNOWN))
            code, text = "cramped", (f"no floor spot within {r} of it keeps the robot's {self.grid.margin:.2f} m "
                                     "radius from every obstacle (too cramped)"
                                     + ("; part of it is not seen yet: Look around" if unseen else ""))
        elif not connected:
            code, text = "closed_in", (f"the free floor within {r} of it cannot be reached by walking or by flying "
                                       "(closed in by obstacles)")
        elif not roomy:
            code, text = "cramped", (f"no floor spot within {r} of it that the robot gets to keeps the robot's "
                                     f"{self.grid.margin:.2f} m radius from every object (too cramped)")
        else:
            code, text = "walled_off", (f"another object stands between it and every floor spot within {r} that "
                                        f"the robot gets to with its {self.grid.margin:.2f} m radius clear (walled off)")
        if not (ws.min[0] <= x <= ws.max[0] and ws.min[1] <= y <= ws.max[1]):
            text += f"; its centre ({x:.2f}, {y:.2f}) lies outside the planning workspace ({box})"
        return code, text

    def _floor_not_object(self) -> np.ndarray:
        """Ground cells not inside an object (free, dangerous, or closed only by the robot's size or
        by what was not seen)."""
        if self.grid.reason is None:
            return self._ground_ok
        return self.grid.reason[:, :, 0] != Closed.OBJECT

    def _clear(self, cell: np.ndarray) -> bool:
        """Whether ground cell ``(i, j)``'s centre keeps the robot's radius from every object's footprint."""
        return bool(self._clearance[cell[0], cell[1]] >= self.grid.margin)

    def _in_reach(self, obj: SceneObject, xy: np.ndarray) -> bool:
        """Whether the straight line from ``xy`` (world [m]) to the nearest point of ``obj``'s
        footprint crosses no other object whose height range overlaps ``obj``'s by more than
        :data:`REACH_TOL` (a table under a box does not count; a wall around it does)."""
        w, _, l = obj.size
        c, s = math.cos(obj.yaw), math.sin(obj.yaw)
        d = xy - np.asarray(obj.position[:2])
        along = float(np.clip(c * d[0] + s * d[1], -l / 2, l / 2))
        across = float(np.clip(-s * d[0] + c * d[1], -w / 2, w / 2))
        target = np.asarray(obj.position[:2]) + along * np.array([c, s]) + across * np.array([-s, c])
        length = float(np.linalg.norm(target - xy))
        n = max(2, int(math.ceil(length / REACH_STEP)) + 1)
        line = xy[None, :] + np.linspace(0.0, 1.0, n)[:, None] * (target - xy)[None, :]
        lo, hi = obj.position[2] - obj.size[1] / 2, obj.position[2] + obj.size[1] / 2
        near = [] if self._centres is None else \
            self._centres.query_ball_point(xy, length + self._reach_r + 1e-6)  # the others can be nowhere else
        for other in (self.objects[k] for k in sorted(near)):
            if other.id == obj.id:
                continue
            o_lo, o_hi = other.position[2] - other.size[1] / 2, other.position[2] + other.size[1] / 2
            if min(hi, o_hi) - max(lo, o_lo) <= REACH_TOL:
                continue
            if math.dist(other.position[:2], xy) > length + math.hypot(other.size[0], other.size[2]):
                continue
            if np.any(footprint_distance(other, line) <= 0.0):
                return False
        return True

    def _planned(self, oid: str, mode: str, goal: Vec3, gap: float) -> Approach:
        res = self.route.plan(self.start, goal)
        if not res.ok:  # components say yes; the A* disagrees only on a corner case: say so
            return Approach(oid, "none", reason=res.message, code="planner")
        flies = bool(np.any(res.cells[:, 2] > 0))
        landing: Vec3 | None = None
        if flies:
            try:
                lands = [s for s in mission_from_cells(res.cells, self.grid).segments if s.kind is SegmentKind.LAND]
                landing = tuple(float(v) for v in lands[-1].spot) if lands else None  # type: ignore[assignment]
            except MissionError:
                landing = None
        return Approach(oid, mode, goal, gap, float(res.cost), "walk+fly" if flies else "walk", landing)


def goal_beside(scene: Scene, grid: PlanningGrid, name: str, start: Sequence[float],
                route: Route | None = None) -> tuple[SceneObject, Approach]:
    """The object ``name`` (id or label) and the approach goal beside it, from ``start`` (world [m]).

    Raises :class:`ObjectGoalError` when nothing matches, or the object cannot be reached (the
    message says why).
    """
    obj = find_object(scene, name, near=start)
    app = Reachability(grid, start, route, scene.objects).approach(obj)
    if app.goal is None:
        raise ObjectGoalError(f"{obj.label} {obj.id!r} cannot be reached: {app.reason}")
    return obj, app


__all__ = ["APPROACH_MAX", "REASONS", "Approach", "ObjectGoalError", "Reachability", "find_object", "footprint",
           "footprint_distance", "goal_beside"]
