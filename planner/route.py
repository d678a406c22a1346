"""Multi-stop routes: a candidate segment planned from the last registered node.

The operator adds goals one at a time. Each goal gets a *candidate* path (red in the console)
planned from the end of the *registered* path (green), or from the start. The candidate can be
registered, discarded, and the last registered segment undone. Positions are world frame [m].

Planning never raises for operator mistakes: :class:`PlanResult` carries ``ok`` and a message
(goal outside the workspace, inside an obstacle, no path); the route's state is then unchanged.
"""

from __future__ import annotations

import math
import threading
import time
from dataclasses import dataclass, field
from typing import Any, Sequence

import numpy as np

from planner.astar import AStarSearcher, min_finite_cost
from planner.grid import CellState, CostWeights, PlanningGrid
from planner.mission import Mission, mission_from_cells

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
        self._cost = grid.cost(weights)
        self._min_cost = _lowest_cost(self._cost)
        self.no_corner_cutting = bool(no_corner_cutting)
        self._searcher = AStarSearcher()  # buffers reused by every plan on this route, whatever the thread
        self._search_lock = threading.Lock()
        self.start: Vec3 = (float(start[0]), float(start[1]), float(start[2]))
        self.registered: list[np.ndarray] = []
        self.candidate: PlanResult | None = None
        self.candidate_goal: Vec3 | None = None

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
        """The cell of a start/goal point, or ``None`` and the reason it cannot be used."""
        ws = self._grid.workspace
        cell = ws.cell_of(p)
        if cell is None:
            return None, f"{what} {_fmt(p)} is outside the workspace {_fmt(ws.min)}..{_fmt(ws.max)}"
        st = self._grid.state_at(cell)
        if st is CellState.OCCUPIED:
            owner = self._grid.owner_of(cell)
            return None, f"{what} {_fmt(p)} is inside an obstacle" + (f" ({owner})" if owner else "")
        if not math.isfinite(self._cost[cell]):
            return None, f"{what} {_fmt(p)} is in the take-off layer next to an obstacle; choose ground or a higher altitude"
        return cell, ""

    def plan(self, start: Sequence[float], goal: Sequence[float]) -> PlanResult:
        """Plan between two world points without changing the route."""
        s, why = self.check_point(start, "start")
        if s is None:
            return PlanResult(False, why)
        g, why = self.check_point(goal, "goal")
        if g is None:
            return PlanResult(False, why)
        t0 = time.perf_counter()
        with self._search_lock:
            res = self._searcher.search(self._cost, s, g, resolution=self._grid.workspace.resolution,
                                        min_cost=self._min_cost, no_corner_cutting=self.no_corner_cutting)
        dt = time.perf_counter() - t0
        if not res.found:
            return PlanResult(False, f"no path from {_fmt(start)} to {_fmt(goal)}: the goal is cut off by obstacles",
                              expanded=res.expanded, seconds=dt)
        return PlanResult(True, f"path of {len(res.path)} cells, cost {res.cost:.2f}", res.path.astype(np.int64),
                          float(res.cost), int(res.expanded), dt)

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
        self.clear()

    def set_grid(self, grid: PlanningGrid, weights: CostWeights | None = None) -> list[str]:
        """Swap in a rebuilt grid; keep registered segments that stay passable, replan the candidate.

        Returns messages about what changed (dropped segments, candidate replanned/dropped).
        """
        self._grid = grid
        if weights is not None:
            self._weights = weights
        self._cost = grid.cost(self._weights)
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
        self.registered = [np.asarray(seg, dtype=np.int64).reshape(-1, 3) for seg in data.get("registered", [])]
        shape = np.array(self._grid.state.shape)
        self.registered = [s for s in self.registered if len(s) and np.all((s >= 0) & (s < shape))]
        self.candidate = None
        self.candidate_goal = tuple(data["candidate_goal"]) if data.get("candidate_goal") else None  # type: ignore[assignment]
        return self.set_grid(self._grid)
