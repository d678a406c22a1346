"""The search core of the Aerial-Ground A*: 26-connected A* over a 3D cost grid.

Grid ``cost[nx, ny, nz]`` holds per-cell traversal costs [1/m] (``inf`` = impassable), cell
``(i, j, k)`` with ``k = 0`` the ground layer. A move between neighbouring cells ``a`` and ``b``
costs exactly what ``skimage.graph.MCP_Geometric`` charges:
``step_length * (cost[a] + cost[b]) / 2`` with ``step_length = resolution * sqrt(dx² + dy² + dz²)``
[m]; the start cell contributes only through its first move (the path cost of ``start == goal``
is 0). As in MCP, any of the 26 moves is allowed when its destination is passable, unless
``no_corner_cutting`` is set.

The heuristic is first ``min_cost * resolution * octile(a, goal)`` where ``octile`` is the 3D
octile distance (in cells) and ``min_cost`` the smallest finite cost in the grid. When that is not
enough (more than :func:`default_layer_budget` expansions, typically when the only way is to
fly), the search builds the per-goal layer-aware heuristic of :mod:`planner.heuristic` and
continues with it (the open list re-keyed; the closed cells kept).

The compiled kernel (numba, :mod:`planner.astar_kernel`) keeps flat C-order indices in an indexed binary heap (each open cell
once, decrease-key through a cell -> heap-slot map; measured about 2x faster than lazy deletion,
which pops every stale duplicate through a deeper heap). The per-cell buffers (g-scores, parent
moves, heap slots, open/closed stamps) live in an :class:`AStarSearcher` and are reused between
calls on grids of the same size: a generation stamp marks which entries belong to the current
search, so a search touches only the cells it visits (no per-call O(grid) reset).
"""

from __future__ import annotations

import heapq
import math
import threading
from dataclasses import dataclass
from typing import Sequence

import numpy as np

from planner.astar_kernel import _move_table, _moves, _MoveTable, _rekey, _search, _swept, _trace, octile_distance
from planner.heuristic import LayerHeuristic, build_layer_heuristic

__all__ = [
    "AStarResult",
    "AStarSearcher",
    "astar",
    "default_layer_budget",
    "dijkstra_reference",
    "min_finite_cost",
    "octile_distance",
]

_MAX_GEN = (1 << 30) - 1  # stamps 2*gen and 2*gen+1 must fit int32
_HEAP_START = 4096
LAYER_BUDGET_MIN = 256  # the default budget of octile expansions is at least this (see layer_budget)
_NEVER = np.iinfo(np.int64).max
_MARGIN = 1.0 - 1e-9  # the layer-aware bound times this: still consistent, safe against rounding
_NO_LAYER = LayerHeuristic(np.zeros(1), np.zeros(1, np.int64), np.zeros(0, np.int64), np.zeros((0, 3)),
                           np.zeros(1), 0.0, 0)  # placeholder tables while the octile bound is used


@dataclass(frozen=True)
class AStarResult:
    """Outcome of a search.

    Attributes:
        path: int64 ``[K, 3]`` cell indices from start to goal inclusive; ``[0, 3]`` when no path.
        cost: Path cost (sum of edge costs) [cost · m]; ``inf`` when no path.
        expanded: Cells taken off the open list and expanded (goal included).
        found: Whether the goal was reached.
        heuristic: ``"octile"``, or ``"layer"`` when the search switched to the layer-aware
            heuristic (:mod:`planner.heuristic`) after its budget of expansions.
    """

    path: np.ndarray
    cost: float
    expanded: int
    found: bool
    heuristic: str = "octile"


# --------------------------------------------------------------------------- Python API


def _as_cost(cost: np.ndarray) -> np.ndarray:
    arr = np.asarray(cost)
    if arr.ndim != 3:
        raise ValueError(f"cost must be a 3D array [nx, ny, nz], got shape {arr.shape}")
    if 0 in arr.shape:
        raise ValueError(f"cost grid {arr.shape} is empty")
    if arr.dtype != np.float64 or not arr.flags.c_contiguous:
        arr = np.ascontiguousarray(arr, dtype=np.float64)
    return arr


def _check_cell(cost: np.ndarray, cell: Sequence[int], what: str) -> tuple[int, int, int]:
    try:
        if len(cell) != 3:
            raise TypeError
        c = tuple(int(v) for v in cell)
        if any(isinstance(v, (bool, np.bool_)) or int(v) != v for v in cell):
            raise TypeError
    except (TypeError, ValueError):
        raise ValueError(f"{what} must be 3 integer cell indices (i, j, k), got {cell!r}") from None
    if not all(0 <= c[a] < cost.shape[a] for a in range(3)):
        raise ValueError(f"{what} cell {c} is outside the grid {cost.shape}")
    v = cost[c]
    if not (v >= 0.0 and math.isfinite(v)):
        raise ValueError(f"{what} cell {c} is impassable (cost {v})")
    return c  # type: ignore[return-value]


def default_layer_budget(shape: tuple[int, int, int]) -> int:
    """Octile expansions before the layer-aware tables are built by default: about what the
    tables cost (one pass over the ``nx * ny * nz`` cells, about 1/128 of an expansion each, and
    a 2D Dijkstra over the ``nx * ny`` columns, about 1/8 each), so that a search that needs them
    spends at most about twice the best choice made in hindsight, and an easy one (the walk
    cases: the goal found within the budget) never pays for them."""
    nx, ny, nz = shape
    return max(LAYER_BUDGET_MIN, (nx * ny * nz) // 128 + (nx * ny) // 8)


def min_finite_cost(cost: np.ndarray) -> float:
    """Smallest finite cost of the grid; raises ValueError on NaN or negative costs or when
    every cell is impassable. Precompute it once per grid and pass it to :func:`astar`."""
    arr = _as_cost(cost)
    lo = float(arr.min())  # one vectorised pass: NaN propagates, inf never wins over a finite cost
    if not lo >= 0.0:
        raise ValueError("cost grid contains NaN or negative values; costs must be >= 0 or inf")
    if not math.isfinite(lo):
        raise ValueError("every cell of the cost grid is impassable")
    return float(lo)


class AStarSearcher:
    """A* with its per-cell buffers kept between calls (re-allocated when the grid size changes).

    Not thread-safe: use one searcher per thread (:func:`astar` does).
    """

    def __init__(self) -> None:
        self._size = -1
        self._gen = 0
        self._g = np.empty(0)
        self._state = np.empty(0, np.int32)
        self._parent = np.empty(0, np.int8)
        self._hpos = np.empty(0, np.int32)
        self._hk = np.empty((_HEAP_START, 2))
        self._hi = np.empty(_HEAP_START, np.int64)
        self._moves: dict[tuple[int, int, int], _MoveTable] = {}

    def release(self) -> None:
        """Drop the per-cell buffers (they are re-created on the next search)."""
        self.__init__()

    def _prepare(self, shape: tuple[int, int, int]) -> _MoveTable:
        size = shape[0] * shape[1] * shape[2]
        if size != self._size:
            self._size = size
            self._gen = 0
            self._g = np.empty(size)
            self._state = np.zeros(size, np.int32)
            self._parent = np.empty(size, np.int8)
            idx_type = np.int32 if size < 2**31 - 1 else np.int64  # flat cell index / heap slot
            self._hpos = np.empty(size, idx_type)
            self._hi = np.empty(self._hi.size, idx_type)
        self._gen += 1
        if self._gen > _MAX_GEN:
            self._state[:] = 0
            self._gen = 1
        mt = self._moves.get(shape)
        if mt is None:
            self._moves = {shape: _move_table(shape)}
            mt = self._moves[shape]
        return mt

    def search(
        self,
        cost: np.ndarray,
        start: Sequence[int],
        goal: Sequence[int],
        *,
        resolution: float = 1.0,
        heuristic_weight: float | None = None,
        min_cost: float | None = None,
        no_corner_cutting: bool = False,
        layer_heuristic: bool = True,
        layer_budget: int | None = None,
        no_land: np.ndarray | None = None,
    ) -> AStarResult:
        """Least-cost path from ``start`` to ``goal``; see :func:`astar`."""
        arr = _as_cost(cost)
        s = _check_cell(arr, start, "start")
        t = _check_cell(arr, goal, "goal")
        if not (resolution > 0 and math.isfinite(resolution)):
            raise ValueError(f"resolution must be a positive number [m], got {resolution}")
        w = 1.0 if heuristic_weight is None else float(heuristic_weight)
        if not (w >= 0 and math.isfinite(w)):
            raise ValueError(f"heuristic_weight must be >= 0, got {heuristic_weight}")
        mc = min_finite_cost(arr) if min_cost is None else float(min_cost)
        if not (mc >= 0 and math.isfinite(mc)):
            raise ValueError(f"min_cost must be a finite number >= 0, got {min_cost}")
        nx, ny, nz = arr.shape
        if layer_budget is None:
            budget = default_layer_budget((nx, ny, nz))
        elif (isinstance(layer_budget, (bool, np.bool_)) or not isinstance(layer_budget, (int, np.integer))
              or layer_budget < 0):
            raise ValueError(f"layer_budget must be an integer >= 0 (expansions), got {layer_budget!r}")
        else:
            budget = int(layer_budget)
        if not layer_heuristic or w == 0.0:
            budget = _NEVER
        gate = _no_land(no_land, (nx, ny))
        mt = self._prepare((nx, ny, nz))
        fs = (s[0] * ny + s[1]) * nz + s[2]
        ft = (t[0] * ny + t[1]) * nz + t[2]
        flat = arr.reshape(-1)
        hscale = w * mc * float(resolution)
        lay = False
        lh = _NO_LAYER
        n = 0
        expanded = 0
        while True:
            status, c, expanded, n, self._hk, self._hi = _search(
                flat, nx, ny, nz, fs, ft, float(resolution), hscale,
                bool(no_corner_cutting), gate is not _NO_GATE, gate, mt.flat, mt.dx, mt.dy, mt.dz, mt.swept, mt.n_swept,
                self._g, self._state, self._parent, self._hpos, self._gen, self._hk, self._hi, n, expanded,
                lay, w * _MARGIN, lh.d2, lh.rcol, lh.levels, lh.dw, lh.s, lh.mfres, lh.zg, budget)
            if status != 3:
                break
            # The octile bound was not enough within the budget: build the per-goal tables and
            # continue the same search with the stronger (consistent) heuristic.
            lh = build_layer_heuristic(arr, t, float(resolution))
            lay = True
            budget = _NEVER
            _rekey(self._hk, self._hi, self._hpos, n, nx, ny, nz, ft, hscale, w * _MARGIN, lh.d2, lh.rcol,
                   lh.levels, lh.dw, lh.s, lh.mfres, lh.zg)
        kind = "layer" if lay else "octile"
        if status != 1:
            return AStarResult(np.zeros((0, 3), np.int64), math.inf, int(expanded), False, kind)
        path = _trace(self._parent, fs, ft, ny, nz, mt.flat, mt.dx, mt.dy, mt.dz)
        return AStarResult(path, float(c), int(expanded), True, kind)


_NO_GATE = np.zeros(1, np.uint8)


def _no_land(mask: np.ndarray | None, plan: tuple[int, int]) -> np.ndarray:
    """``mask`` (``bool [nx, ny]``: ground cells where no landing may end) as the kernel's flat
    ``uint8`` array, or :data:`_NO_GATE` when there is none; raises ValueError on a wrong shape."""
    if mask is None:
        return _NO_GATE
    m = np.asarray(mask)
    if m.shape != plan:
        raise ValueError(f"no_land must be a bool array of the grid's plan shape {plan}, got shape {m.shape}")
    if not m.any():
        return _NO_GATE
    return np.ascontiguousarray(m.reshape(-1), dtype=np.uint8)


_local = threading.local()


def astar(
    cost: np.ndarray,
    start: tuple[int, int, int],
    goal: tuple[int, int, int],
    *,
    resolution: float = 1.0,
    heuristic_weight: float | None = None,
    min_cost: float | None = None,
    no_corner_cutting: bool = False,
    layer_heuristic: bool = True,
    layer_budget: int | None = None,
    no_land: np.ndarray | None = None,
) -> AStarResult:
    """Least-cost 26-connected path through ``cost[nx, ny, nz]`` from ``start`` to ``goal`` cells.

    Args:
        cost: Per-cell traversal cost [1/m], ``>= 0``; ``inf`` = impassable. Converted to a
            C-contiguous float64 array if it is not one already (a copy).
        start, goal: Cell indices ``(i, j, k)``; must be inside the grid and passable.
        resolution: Cell edge length [m].
        heuristic_weight: Multiplier of the heuristic; ``None``/1 gives optimal paths, ``w > 1``
            is weighted A* (cost at most ``w`` times the optimum, faster), 0 is Dijkstra.
        min_cost: The grid's smallest finite cost if already known (see
            :func:`min_finite_cost`); otherwise one pass over the grid computes it.
        no_corner_cutting: Forbid a diagonal move when any axis-aligned cell it sweeps past
            is impassable. Default off, which matches ``MCP_Geometric``'s moves.
        layer_heuristic: Allow the switch to the layer-aware heuristic (:mod:`planner.heuristic`).
        layer_budget: Expansions made with the octile bound alone before the per-goal tables of
            the layer-aware heuristic are built and the open list re-keyed (``None``:
            :func:`default_layer_budget`, about what the tables cost; 0: from the start).
        no_land: ``bool [nx, ny]``: ground cells ``(i, j, 0)`` no path may land on (no move from an air
            cell ``k >= 1`` down into them); walking through them and taking off from them stay allowed.
            Removing moves keeps both heuristics admissible and consistent (they bound every path).

    The first heuristic ``h(a) = min_cost * resolution * octile(a, goal)`` is consistent: octile is
    the shortest-path metric of the 26-lattice with move lengths ``sqrt(n)``, so it obeys the
    triangle inequality, and for one move ``a -> b`` of length ``L = resolution * octile(a, b)``,
    ``h(a) - h(b) <= min_cost * L <= L * (cost[a] + cost[b]) / 2 = edge(a, b)``; with
    ``h(goal) = 0`` it is also admissible. The layer-aware heuristic is the max of this one and
    a per-goal bound (consistent and admissible too, proof in :mod:`planner.heuristic`); a max of
    consistent heuristics is consistent. Switching mid-search keeps the path optimal: every
    closed cell already has its optimal g (the octile bound is consistent), and A* with a
    consistent heuristic from any such state closes the goal only at its optimal cost.

    Raises:
        ValueError: start/goal outside the grid or impassable, bad cost grid or parameters.
    """
    searcher = getattr(_local, "searcher", None)
    if searcher is None:
        searcher = _local.searcher = AStarSearcher()
    return searcher.search(cost, start, goal, resolution=resolution, heuristic_weight=heuristic_weight,
                           min_cost=min_cost, no_corner_cutting=no_corner_cutting,
                           layer_heuristic=layer_heuristic, layer_budget=layer_budget, no_land=no_land)


def dijkstra_reference(
    cost: np.ndarray,
    start: Sequence[int],
    goal: Sequence[int],
    resolution: float = 1.0,
    *,
    no_corner_cutting: bool = False,
    no_land: np.ndarray | None = None,
) -> AStarResult:
    """Plain pure-Python Dijkstra with the same moves and edge costs as :func:`astar` (``no_land`` too).

    Slow; meant for tests on small grids.
    """
    cost = np.asarray(cost, dtype=np.float64)
    s = _check_cell(cost, start, "start")
    t = _check_cell(cost, goal, "goal")
    shape = cost.shape
    moves = _moves()
    dist: dict[tuple[int, int, int], float] = {s: 0.0}
    prev: dict[tuple[int, int, int], tuple[int, int, int]] = {}
    done: set[tuple[int, int, int]] = set()
    heap: list[tuple[float, tuple[int, int, int]]] = [(0.0, s)]
    while heap:
        d, u = heapq.heappop(heap)
        if u in done:
            continue
        done.add(u)
        if u == t:
            path = [u]
            while path[-1] != s:
                path.append(prev[path[-1]])
            return AStarResult(np.array(path[::-1], dtype=np.int64), d, len(done), True)
        for m in moves:
            v = (u[0] + m[0], u[1] + m[1], u[2] + m[2])
            if not all(0 <= v[a] < shape[a] for a in range(3)) or not math.isfinite(cost[v]):
                continue
            if no_land is not None and v[2] == 0 and u[2] > 0 and no_land[v[0], v[1]]:
                continue
            if no_corner_cutting and any(
                not math.isfinite(cost[u[0] + c[0], u[1] + c[1], u[2] + c[2]]) for c in _swept(m)
            ):
                continue
            length = math.sqrt(sum((resolution * c) ** 2 for c in m))
            nd = d + length * 0.5 * (cost[u] + cost[v])
            if nd < dist.get(v, math.inf):
                dist[v] = nd
                prev[v] = u
                heapq.heappush(heap, (nd, v))
    return AStarResult(np.zeros((0, 3), np.int64), math.inf, len(done), False)
