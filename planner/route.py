"""Multi-stop routes: a candidate segment planned from the last registered node.

The operator adds goals one at a time. Each goal gets a *candidate* path (red in the console)
planned from the end of the *registered* path (green), or from the start. The candidate can be
registered, discarded, and the last registered segment undone. Positions are world frame [m].

Planning never raises for operator mistakes: :class:`PlanResult` carries ``ok`` and a message
(goal outside the workspace, inside an obstacle, too close to one for the robot's radius, not seen
yet with where to look from, no path); the route's state is then unchanged.

One rule for the goal check, the route and the goal: the planning grid's configuration space
(:func:`planner.grid.build_grid`). A goal is the centre of its cell (on the floor for the ground
layer): that cell is what is checked and planned to, and :attr:`PlanResult.goal` says where the goal
ended up. The robot's own cells at :attr:`Route.start` are free by definition (a robot mapped
inside an object can still leave it; :attr:`Route.start_warning` names the object).
"""

from __future__ import annotations

import math
import threading
import time
from dataclasses import dataclass, field
from typing import Any, Sequence

import numpy as np

from planner.astar import AStarSearcher, min_finite_cost
from planner.clearance import crowding
from planner.cspace import box_distance, edge_blockers, edge_gaps
from planner.grid import Closed, CostWeights, PlanningGrid
from planner.landing_spot import no_landing
from planner.mission import Mission, count_text, mission_from_cells
from planner.goal_look import next_look
from planner.no_path import no_path_text
from planner.viewpoint import frontier_spot, suggest_viewpoint

Vec3 = tuple[float, float, float]


@dataclass(frozen=True)
class PlanResult:
    """Outcome of one planning request."""

    ok: bool
    message: str
    cells: np.ndarray = field(default_factory=lambda: np.zeros((0, 3), dtype=np.int64))
    cost: float = math.inf
    expanded: int = 0
    seconds: float = 0.0
    goal: Vec3 | None = None  # where the goal ended up: its cell's centre (floor for the ground layer) [m]
    unseen: np.ndarray | None = None  # bool per path cell: not seen free (only with unknown space allowed)
    unseen_m: float = 0.0  # metres of the path whose move ends in an unseen cell
    viewpoint: Vec3 | None = None  # goal not seen yet: a reachable spot to look from (camera position) [m]
    frontier: Vec3 | None = None  # ... when no reachable spot sees it: where to Look around next (camera position) [m]

    def points(self, grid: PlanningGrid) -> np.ndarray:
        """World points of the path (cell centres, ground cells on the floor) [m]."""
        return path_points(self.cells, grid)


def path_points(cells: np.ndarray, grid: PlanningGrid) -> np.ndarray:
    """Cell path -> world points [m]; ground-layer cells are put on the floor."""
    pts = grid.workspace.centers(cells)
    if len(pts):
        pts[np.asarray(cells)[:, 2] == 0, 2] = grid.workspace.floor
    return pts


def _lowest_cost(cost: np.ndarray) -> float | None:
    """The grid's smallest finite cost (the A* heuristic's scale), ``None`` when nothing is passable."""
    try:
        return min_finite_cost(cost)
    except ValueError:
        return None


def box_contains_xy(obj: Any, pts: np.ndarray, grow: float) -> np.ndarray:
    """Which world points ``(N, 3)`` [m] lie within ``obj``'s box grown by ``grow`` [m] on every side."""
    w, h, l = obj.size
    c, s = math.cos(obj.yaw), math.sin(obj.yaw)
    d = pts - np.asarray(obj.position)
    along = np.abs(c * d[:, 0] + s * d[:, 1])
    across = np.abs(-s * d[:, 0] + c * d[:, 1])
    return (along <= l / 2 + grow) & (across <= w / 2 + grow) & (np.abs(d[:, 2]) <= h / 2 + grow)


def _fmt(p: Sequence[float]) -> str:
    return "(" + ", ".join(f"{v:.2f}" for v in p) + ")"


class Route:
    """A multi-stop path under construction on one grid.

    Args:
        grid: The planning grid.
        start: Where the robot stands (world [m]).
        weights: The Aerial-Ground cost weights.
        no_corner_cutting: Forbid diagonal moves that sweep past an impassable cell (default: the
            robot never squeezes between two obstacles that touch at a corner, and never climbs
            diagonally past an obstacle right above its take-off spot).
    """

    def __init__(self, grid: PlanningGrid, start: Sequence[float], weights: CostWeights = CostWeights(),
                 no_corner_cutting: bool = True) -> None:
        self._grid = grid
        self._weights = weights
        self.start: Vec3 = (float(start[0]), float(start[1]), float(start[2]))
        self.start_warning = ""
        self._last_frontier: Vec3 | None = None
        self._cost = self._own_cost()
        self._min_cost = _lowest_cost(self._cost)
        self.no_corner_cutting = bool(no_corner_cutting)
        self._searcher = AStarSearcher()  # buffers reused by every plan on this route, whatever the thread
        self._search_lock = threading.Lock()
        self.registered: list[np.ndarray] = []
        self.candidate: PlanResult | None = None
        self.candidate_goal: Vec3 | None = None

    def _own_cost(self) -> np.ndarray:
        """The grid's cost with the robot's own cells at :attr:`start` opened (free by definition: the
        cells within its radius that are closed as unseen or under a floating object, and when the
        robot's own cell is closed, every one of them); sets :attr:`start_warning` when they overlap
        an object."""
        cost = self._grid.cost(self._weights)
        self.start_warning = ""
        p = self.start
        if not all(math.isfinite(v) for v in p) or self._grid.workspace.cell_of(p) is None:
            return cost
        cell = self._grid.workspace.cell_of(p)
        own = self._grid.own_cells(p) & ~np.isfinite(cost)
        if self._grid.reason is not None and math.isfinite(cost[cell]):
            # the body's volume is free whatever the map says (unseen, under a floating object), but a
            # cell closed for clearance stays closed: opening it would let the robot move closer to
            # an obstacle; only a robot already stranded (its own cell closed) may use those to leave
            body_free = np.isin(self._grid.reason, [int(Closed.UNKNOWN), int(Closed.BENEATH)])
            own &= body_free if self._grid.edge is None else body_free & ~self._grid.edge  # never nearer the edge
        if own.any():
            base = self._grid.cost(CostWeights(self._weights.ground, self._weights.takeoff, self._weights.flight,
                                               self._weights.danger, False))
            layer = np.full(cost.shape[2], self._weights.flight)
            layer[0] = self._weights.ground
            if cost.shape[2] > 1:
                layer[1] = self._weights.takeoff
            opened = np.where(np.isfinite(base), base, np.broadcast_to(layer, cost.shape))
            cost[own] = opened[own]
        hit = self._grid.objects_at(p)
        if hit:
            # the robot stands there, so these objects cannot (a mapping error): around them, plan as
            # if they were not there, so the robot can walk out
            try:
                alt = self._grid.without(o.id for o in hit).cost(self._weights)
            except (TypeError, ValueError):  # a grid made elsewhere without its build arguments: own cells only
                alt = None
            if alt is not None:
                near = np.zeros(cost.shape, dtype=bool)
                reach = max(self._grid.robot.radius, self._grid.robot.flying_radius) + 0.5
                pts = self._grid.workspace.centers(np.argwhere(np.ones(cost.shape, dtype=bool)))
                for o in hit:
                    near |= box_contains_xy(o, pts, reach).reshape(cost.shape)
                fix = near & ~np.isfinite(cost) & np.isfinite(alt)
                cost[fix] = alt[fix]
            names = ", ".join(f"{o.label} '{o.id}'" for o in hit[:3]) + (" ..." if len(hit) > 3 else "")
            self.start_warning = (f"the robot at {_fmt(p)} overlaps {names} on the map: its own cells are taken as "
                                  "free (it stands there); check the map or move the object")
        return cost

    # --- state ---------------------------------------------------------------------------------
    @property
    def grid(self) -> PlanningGrid:
        return self._grid

    @property
    def weights(self) -> CostWeights:
        return self._weights

    @property
    def cost_array(self) -> np.ndarray:
        return self._cost

    def last_node(self) -> Vec3:
        """Where the next candidate starts [m]: end of the registered path, else the start."""
        if self.registered:
            return tuple(path_points(self.registered[-1][-1:], self._grid)[0])  # type: ignore[return-value]
        return self.start

    def registered_cells(self) -> np.ndarray:
        """All registered segments joined (shared join nodes once), K x 3."""
        if not self.registered:
            return np.zeros((0, 3), dtype=np.int64)
        parts = [self.registered[0]] + [seg[1:] for seg in self.registered[1:]]
        return np.concatenate(parts, axis=0)

    def registered_points(self) -> np.ndarray:
        return path_points(self.registered_cells(), self._grid)

    # --- planning ------------------------------------------------------------------------------
    def check_point(self, p: Sequence[float], what: str) -> tuple[tuple[int, int, int] | None, str]:
        """The cell of a start/goal point, or ``None`` and the reason it cannot be used (the same
        configuration-space rule as the route; see :meth:`why_closed`)."""
        cell, why = self._locate(p, what)
        if cell is None:
            return None, why
        if not math.isfinite(self._cost[cell]):
            return None, self.why_closed(cell, p, what)
        return cell, ""

    def _locate(self, p: Sequence[float], what: str) -> tuple[tuple[int, int, int] | None, str]:
        """The cell of a point (passable or not), or ``None`` and why (not 3 finite numbers, outside)."""
        ws = self._grid.workspace
        try:
            if len(p) != 3 or not all(math.isfinite(float(v)) for v in p):
                return None, f"{what} {tuple(p)!r} must be 3 finite numbers [m]"
        except (TypeError, ValueError):
            return None, f"{what} {p!r} must be 3 finite numbers [m]"
        cell = ws.cell_of(p)
        if cell is None:
            return None, f"{what} {_fmt(p)} is outside the workspace {_fmt(ws.min)}..{_fmt(ws.max)}"
        return cell, ""

    def why_closed(self, cell: Sequence[int], p: Sequence[float], what: str = "goal") -> str:
        """Why the robot cannot be in ``cell`` (the point ``p`` [m] asked for), in the operator's words."""
        return self._refusal(cell, p, what)[0]

    def _near_unknown(self, c: tuple[int, int, int]) -> bool:
        """Whether unknown (closed) cells lie within the robot's radius (plus a cell) of cell ``c``."""
        g = self._grid
        if g.reason is None:
            return False
        n = int(math.ceil(max(g.robot.radius, g.robot.flying_radius) / g.workspace.resolution)) + 1
        lo = [max(0, c[a] - n) for a in range(3)]
        hi = [min(g.reason.shape[a], c[a] + n + 1) for a in range(3)]
        if c[2] == 0:
            hi[2] = max(hi[2], min(g.reason.shape[2], g.walk_layers() + n))
        return bool(np.any(g.reason[lo[0]:hi[0], lo[1]:hi[1], lo[2]:hi[2]] == Closed.UNKNOWN))

    def _refusal(self, cell: Sequence[int], p: Sequence[float], what: str) -> tuple[str, Vec3 | None]:
        """The refusal text for a closed cell and, for space not seen yet, where to look from."""
        g = self._grid
        c = (int(cell[0]), int(cell[1]), int(cell[2]))
        why = g.reason_at(c)
        here = f"{what} {_fmt(p)}"
        if why is Closed.OBJECT:
            owner = g.owner_of(c)
            if owner is None and c[2] == 0 and g.owner is not None:
                col = g.owner[c[0], c[1], :g.walk_layers()]
                owner = next((g.owners[int(i)] for i in col if i >= 0), None)
            return f"{here} is inside an obstacle" + (f" ({owner})" if owner else ""), None
        edge = self._edge_refusal(c, p, here)
        if edge:
            return edge, None
        if why is Closed.UNKNOWN:
            look = self.look_for(p)
            if look is not None and look.sees > 0:
                return (f"{here} is not seen yet: look from {_fmt(look.eye)} m (go there and capture towards it: "
                        "Go look), or Look around"), look.eye
            if look is not None:
                self._last_frontier = look.eye
                return (f"{here} is not seen yet and no seen-free spot the robot can reach sees it: next look from "
                        f"{_fmt(look.eye)} m {'hovering' if look.mode == 'fly' else 'on the floor'} (it opens the "
                        "space the goal can be seen from: Go look), or Look around there"), None
            edge = self.frontier_for(p)
            self._last_frontier = edge
            if edge is not None:
                return (f"{here} is not seen yet and no seen-free spot the robot can reach sees it: Look around, "
                        f"or go to {_fmt(edge)} m (the edge of what was seen nearest it) and Look around there"), None
            return f"{here} is not seen yet and no seen-free spot the robot can reach sees it: Look around", None
        if why is Closed.UNLABELLED:
            return (f"{here} is inside an unlabelled obstacle (the depth map saw a surface there that no mapped "
                    "object explains)"), None
        if why is Closed.SURFACE:
            obj, _ = g.nearest_object(g.workspace.centers(np.array([c]))[0])
            near = f" (near {obj.label} '{obj.id}')" if obj is not None else ""
            return f"{here} is on a surface the depth map saw{near}", None
        if why is Closed.BENEATH:
            return (f"{here} is under an object mapped floating ({', '.join(g.floating) or 'unnamed'}): the floor "
                    "beneath it is closed until a capture sees it free"), None
        if why is Closed.CLEARANCE:
            r = g.robot.radius if c[2] == 0 else g.robot.flying_radius
            centre = self._end_point(c)
            obj, dist = g.nearest_object(g.workspace.centers(np.array([c]))[0])
            if obj is not None and dist <= 1e-9:
                return (f"{here} is under {obj.label} '{obj.id}' (lower than the robot's {g.robot.height:.2f} m "
                        "height): choose a point further away"), None
            crowd = crowding(g, c)
            if crowd is not None:
                obj, pad = crowd[0], crowd[2]
                flat = c[2] == 0
                dist = float(box_distance(obj, g.workspace.centers(np.array([c])), horizontal=flat)[0])
                d_goal = float(box_distance(obj, np.array([[float(v) for v in p]]), horizontal=flat)[0])
                near = "inside" if d_goal <= 1e-9 else f"{d_goal:.2f} m from"
                extra = f" and {pad:.2f} m for where it may really be (2 sigma of its mapped place)" if pad > 0 else ""
                body = ""
                if not flat and dist > r + pad + 1e-9:  # only the body's height above the cell reaches it
                    body = f"; the robot's {g.robot.flying_height:.2f} m body above that cell reaches it"
                return (f"{here} is {near} {obj.label} '{obj.id}' (its cell centre {_fmt(centre)}: {dist:.2f} m); "
                        f"the robot needs {r:.2f} m around it (its radius){extra}{body}: choose a point further away"), None
            if self._near_unknown(c):
                vp = self.viewpoint_for(p)
                look = (f"look from {_fmt(vp)} m (go there and capture towards it), or Look around" if vp is not None
                        else "Look around")
                return (f"{here} is within the robot's {r:.2f} m radius of space not seen yet: {look}"), vp
            return (f"{here} (its cell centre {_fmt(centre)}) is within the robot's {r:.2f} m radius of an unlabelled "
                    "obstacle (a surface the depth map saw that no mapped object explains)"), None
        if c[2] == 1:
            return f"{here} is in the take-off layer next to an obstacle; choose ground or a higher altitude", None
        return f"{here} cannot be used (closed cell)", None

    def _edge_refusal(self, c: tuple[int, int, int], p: Sequence[float], here: str) -> str:
        """The refusal for a cell too near the workspace's edge (the grid's rule: its centre within the
        robot's radius of a wall, or its height of the top; :func:`planner.cspace.edge_blockers`), or "".
        Names the face, the goal's and its cell centre's distance to it, and what the robot needs."""
        g = self._grid
        if g.edge is None or not g.edge[c]:
            return ""
        ws, ground = g.workspace, c[2] == 0
        faces = edge_blockers(ws.min, ws.max, ws.centers(np.array([c]))[0], ground, g.robot)
        if not faces:
            return ""
        gap, need, face = faces[0]
        mine = {f: d for d, _, f in edge_gaps(ws.min, ws.max, [float(v) for v in p], ground, g.robot)}[face]
        at = f"{mine:.2f} m from" if mine > 1e-9 else "at or beyond"
        also = "".join(f"; also {d:.2f} m from {f}" for d, _, f in faces[1:])
        size = "radius" if need in (g.robot.radius, g.robot.flying_radius) else "height"
        return (f"{here} is {at} the workspace's {face} (its cell centre {_fmt(self._end_point(c))}: "
                f"{gap:.2f} m{also}); the robot needs {need:.2f} m from it (its {size}): choose a point further in")

    def viewpoint_for(self, target: Sequence[float]) -> Vec3 | None:
        """A reachable seen-free spot (camera position, world [m]) from which ``target`` can be seen,
        or ``None`` (see :mod:`planner.viewpoint`)."""
        s = self._grid.workspace.cell_of(self.start)
        if s is None or not math.isfinite(self._cost[s]):
            return None
        return suggest_viewpoint(self._grid, self._cost, s, target)

    def look_for(self, target: Sequence[float], avoid: Sequence[Any] = ()) -> Any:
        """The next look towards ``target`` not seen yet (a :class:`planner.goal_look.Look`: where to go,
        the camera position, the heading), or ``None``; ``avoid``: ``(camera position, heading)`` of
        earlier captures (see :func:`planner.goal_look.next_look`)."""
        s = self._grid.workspace.cell_of(self.start)
        if s is None or not math.isfinite(self._cost[s]):
            return None
        looks = next_look(self._grid, self._cost, s, target, avoid=avoid)
        return looks[0] if looks else None

    def frontier_for(self, target: Sequence[float]) -> Vec3 | None:
        """The reachable spot at the edge of what was seen nearest ``target`` (camera position, world
        [m]), or ``None`` (see :func:`planner.viewpoint.frontier_spot`)."""
        s = self._grid.workspace.cell_of(self.start)
        if s is None or not math.isfinite(self._cost[s]):
            return None
        return frontier_spot(self._grid, np.isfinite(self._cost), s, target)

    def snapped(self, p: Sequence[float]) -> Vec3 | None:
        """Where a goal at ``p`` (world [m]) ends up: its cell's centre, on the floor for the ground
        layer; ``None`` outside the workspace or not 3 finite numbers."""
        cell, _ = self._locate(p, "goal")
        return None if cell is None else self._end_point(cell)

    def _end_point(self, cell: Sequence[int]) -> Vec3:
        pt = path_points(np.array([cell], dtype=np.int64), self._grid)[0]
        return (float(pt[0]), float(pt[1]), float(pt[2]))

    def plan(self, start: Sequence[float], goal: Sequence[float]) -> PlanResult:
        """Plan between two world points without changing the route."""
        s, why = self.check_point(start, "start")
        if s is None:
            return PlanResult(False, why)
        g, why = self._locate(goal, "goal")
        if g is None:
            return PlanResult(False, why)
        if not math.isfinite(self._cost[g]):
            self._last_frontier = None
            text, vp = self._refusal(g, goal, "goal")
            return PlanResult(False, text, viewpoint=vp, frontier=self._last_frontier)
        t0 = time.perf_counter()
        res = self._search(s, g, no_landing(self._grid))  # lands only where Build lets it (landing_spot)
        dt = time.perf_counter() - t0
        if not res.found:  # the same search without the landing rule names the landing it refuses
            ungated = self._search(s, g, None) if no_landing(self._grid).any() else None
            return PlanResult(False, no_path_text(self._grid, start, goal, ungated), expanded=res.expanded, seconds=dt)
        cells = res.path.astype(np.int64)
        end = self._end_point(g)
        unseen, unseen_m = self.unseen_part(cells)
        msg = f"path of {count_text(len(cells), 'cell')}, cost {res.cost:.2f}"
        moved = math.dist(end, (float(goal[0]), float(goal[1]), float(goal[2])))
        if moved > 0.01:
            msg += f"; goal snapped to {_fmt(end)} ({moved:.2f} m away)"
        if unseen_m > 0 and unseen is not None:
            idx = np.nonzero(unseen)[0]
            pts = path_points(cells[[idx[0], idx[-1]]], self._grid)
            msg += f"; {unseen_m:.2f} m of it through unseen space (between {_fmt(pts[0])} and {_fmt(pts[1])})"
        return PlanResult(True, msg, cells, float(res.cost), int(res.expanded), dt, end, unseen, unseen_m)

    def _search(self, s: Sequence[int], g: Sequence[int], no_land: np.ndarray | None) -> Any:
        with self._search_lock:
            return self._searcher.search(self._cost, s, g, resolution=self._grid.workspace.resolution,
                                         min_cost=self._min_cost, no_corner_cutting=self.no_corner_cutting,
                                         no_land=no_land)

    def unseen_part(self, cells: np.ndarray) -> tuple[np.ndarray | None, float]:
        """Per path cell whether it is unseen, and the metres of moves ending in unseen cells."""
        uns = self._grid.unseen
        if uns is None or len(cells) == 0:
            return None, 0.0
        flags = uns[cells[:, 0], cells[:, 1], cells[:, 2]].copy()
        if len(cells) < 2:
            return flags, 0.0
        steps = np.linalg.norm(np.diff(cells, axis=0), axis=1) * self._grid.workspace.resolution
        return flags, float(steps[flags[1:]].sum())

    def propose(self, goal: Sequence[float]) -> PlanResult:
        """Plan a candidate from the last node to ``goal``; on failure the old candidate stays."""
        res = self.plan(self.last_node(), goal)
        if res.ok:
            self.candidate = res
            self.candidate_goal = (float(goal[0]), float(goal[1]), float(goal[2]))
        return res

    def register(self) -> bool:
        """Append the candidate to the registered path; False if there is none."""
        if self.candidate is None:
            return False
        self.registered.append(self.candidate.cells)
        self.candidate = None
        self.candidate_goal = None
        return True

    def discard(self) -> None:
        self.candidate = None
        self.candidate_goal = None

    def undo(self) -> bool:
        """Remove the last registered segment; False if there is none."""
        if not self.registered:
            return False
        self.registered.pop()
        self.discard()
        return True

    def clear(self) -> None:
        self.registered.clear()
        self.discard()

    def set_start(self, start: Sequence[float]) -> None:
        """Move the start (e.g. to the robot's pose); clears the route."""
        self.start = (float(start[0]), float(start[1]), float(start[2]))
        self._cost = self._own_cost()
        self._min_cost = _lowest_cost(self._cost)
        self.clear()

    def set_grid(self, grid: PlanningGrid, weights: CostWeights | None = None) -> list[str]:
        """Swap in a rebuilt grid; keep registered segments that stay passable, replan the candidate.

        Returns messages about what changed (dropped segments, candidate replanned/dropped).
        """
        self._grid = grid
        if weights is not None:
            self._weights = weights
        self._cost = self._own_cost()
        self._min_cost = _lowest_cost(self._cost)
        notes: list[str] = []
        for n, seg in enumerate(self.registered):
            if not np.all(np.isfinite(self._cost[seg[:, 0], seg[:, 1], seg[:, 2]])):
                dropped = len(self.registered) - n
                del self.registered[n:]
                notes.append("1 registered segment now crosses obstacles and was removed" if dropped == 1 else
                             f"{dropped} registered segments now cross obstacles and were removed")
                break
        if self.candidate_goal is not None:
            goal = self.candidate_goal
            self.discard()
            res = self.propose(goal)
            notes.append("candidate replanned" if res.ok else f"candidate dropped: {res.message}")
        return notes

    def mission(self) -> Mission:
        """The registered path as a mission (raises MissionError when empty)."""
        return mission_from_cells(self.registered_cells(), self._grid)

    # --- persistence ---------------------------------------------------------------------------
    def to_dict(self) -> dict[str, Any]:
        return {
            "start": list(self.start),
            "registered": [seg.tolist() for seg in self.registered],
            "candidate_goal": None if self.candidate_goal is None else list(self.candidate_goal),
        }

    def restore(self, data: dict[str, Any]) -> list[str]:
        """Load :meth:`to_dict` output onto the current grid; returns notes like :meth:`set_grid`."""
        self.start = tuple(float(v) for v in data["start"])  # type: ignore[assignment]
        self._cost = self._own_cost()
        self.registered = [np.asarray(seg, dtype=np.int64).reshape(-1, 3) for seg in data.get("registered", [])]
        shape = np.array(self._grid.state.shape)
        self.registered = [s for s in self.registered if len(s) and np.all((s >= 0) & (s < shape))]
        self.candidate = None
        self.candidate_goal = tuple(data["candidate_goal"]) if data.get("candidate_goal") else None  # type: ignore[assignment]
        return self.set_grid(self._grid)
