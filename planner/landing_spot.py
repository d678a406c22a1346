"""Where the robot may land: one rule for every way the console chooses a landing spot.

Land here (straight down), Land here during a search (the nearest seen-free floor), the search's move
beside its target, Go look, a mission's landing and Return (at the take-off spot, or the nearest spot the
rule fits when it no longer does, e.g. within the robot's radius of a wall: :func:`return_spots`) all
land through this rule:
:func:`landing_problem` for one spot, :func:`landing_mask` for every floor cell at once (the two agree on
cell centres). Every mission the planner builds checks its landing spots with it
(:func:`planner.mission.check_landing`), and every route the planner plans (Go look, Go to, a clicked
goal, a search's move) lands only where it fits (:func:`no_landing`), so Build never refuses an offered
route for its landing.

A spot ``(x, y)`` on the floor is fit for landing when the robot's whole **footprint** there -- the floor
cells whose centre lies within ``robot.radius`` of ``(x, y)`` in plan, and the cell holding it --

1. **has been seen** (with known space): no cell of the footprint's walking column (the floor up to the
   body's height) is unknown (closed) or unseen (allowed). A fully known map is not checked, nor a
   ``forced`` landing (critical battery: a forced landing beats a crash);
2. **holds no mapped object, whatever its height**: no object's box comes within ``robot.radius`` of
   ``(x, y)`` in plan while overlapping the body's height above the floor -- a 5 cm sports mat counts as
   a 2 m cabinet does (the body touches both when it lands);
3. **holds no obstacle cell**: no footprint column holds an unlabelled obstacle (a depth surface no mapped
   object explains: an unmapped mat the simulator's exact depth saw), a mapped object's surface seen
   outside its box, or lies under a floating object;
4. and the planner does not close the spot's own floor cell for the robot's size (its configuration
   space, measured to obstacle cells' cubes; not for ``forced`` landings, and not for the workspace's edge
   band, which a straight descent comes no nearer to).

``clear`` (choosing a new spot): the spot must also lie outside the danger band (the planner's free
ground, where missions take off and land). World frame (z up) [m].
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Sequence

import numpy as np
from scipy import ndimage

from planner.cspace import box_distance, object_distances
from planner.map_uncertainty import margins
from planner.grid import CellState, Closed, PlanningGrid

OBSTACLE_CELLS = (Closed.UNLABELLED, Closed.SURFACE, Closed.BENEATH)
"""What a footprint column may not hold (the ground layer's reason says what its walking column holds);
mapped objects are measured by their exact boxes instead (item 2), not by the cells they overlap."""

_EDGE = getattr(Closed, "EDGE", None)  # the workspace's edge band: a straight descent comes no nearer to it

_WORDS = {
    Closed.UNLABELLED: "an unlabelled obstacle (a surface no mapped object explains)",
    Closed.SURFACE: "the seen surface of a mapped object",
    Closed.BENEATH: "the space under a floating object",
}


@dataclass(frozen=True)
class LandingProblem:
    """Why a spot is not fit for landing.

    Attributes:
        kind: ``outside``, ``unseen``, ``object`` (a mapped object within the radius), ``obstacle`` (an
            obstacle cell in the footprint, or the spot closed for the robot's size) or ``danger``.
        text: The operator's words.
        owner: The object's id (``object``), or the id the planner names for the closed cell, or ``None``.
    """

    kind: str
    text: str
    owner: str | None = None

    def __str__(self) -> str:
        return self.text


def _pt(x: float, y: float) -> str:
    return f"({x:.2f}, {y:.2f})"


def _has_known(grid: PlanningGrid) -> bool:
    return grid.rule != "fully_known" and grid.reason is not None


def _band(grid: PlanningGrid) -> tuple[float, float]:
    """The walking body's height range above the floor [m]."""
    floor = grid.workspace.floor
    return floor, floor + grid.robot.height


def _columns(grid: PlanningGrid) -> tuple[np.ndarray, np.ndarray]:
    """``(unseen, obstacle)`` ``bool [nx, ny]``: floor columns not seen (closed unknown, or unseen with
    unknown space allowed) and columns holding an obstacle cell (:data:`OBSTACLE_CELLS`)."""
    shape = grid.state.shape[:2]
    if grid.reason is None:
        return np.zeros(shape, dtype=bool), np.zeros(shape, dtype=bool)
    r0 = grid.reason[:, :, 0]
    unseen = (r0 == Closed.UNKNOWN) if _has_known(grid) else np.zeros(shape, dtype=bool)
    if grid.unseen is not None and _has_known(grid):
        unseen = unseen | grid.unseen[:, :, 0]
    return unseen, np.isin(r0, [int(c) for c in OBSTACLE_CELLS])


def footprint(grid: PlanningGrid, point: Sequence[float]) -> np.ndarray:
    """``bool [nx, ny]``: the floor cells under the robot's footprint at ``point`` (world [m]; x, y used):
    those whose centre lies within ``robot.radius`` of it in plan, and the cell holding it (empty outside
    the workspace)."""
    ws = grid.workspace
    x, y = float(point[0]), float(point[1])
    xs, ys, _ = ws.axes()
    foot = np.hypot(xs[:, None] - x, ys[None, :] - y) <= grid.robot.radius + 1e-9
    cell = ws.cell_of((x, y, ws.floor))
    if cell is None:
        return np.zeros_like(foot)
    foot[cell[0], cell[1]] = True
    return foot


def unseen_footprint(grid: PlanningGrid, point: Sequence[float]) -> bool:
    """Whether any floor column under the robot's footprint at ``point`` (world [m]) has not been seen
    (item 1 of the module's rule); ``False`` on a fully known map."""
    if not _has_known(grid):
        return False
    unseen, _ = _columns(grid)
    return bool(np.any(unseen & footprint(grid, point)))


def _nearest_object(grid: PlanningGrid, x: float, y: float) -> tuple[object, float] | None:
    """The mapped object (overlapping the body's height) nearest to ``(x, y)`` in plan within the
    robot's radius, and its footprint distance [m]; ``None`` when none is."""
    lo, hi = _band(grid)
    best = None
    p = np.array([[x, y, 0.0]])
    for obj in grid.objects:
        if obj.frame != "world":
            continue
        cz, h = float(obj.position[2]), float(obj.size[1])
        if not (cz - h / 2 < hi and cz + h / 2 > lo):
            continue
        d = float(box_distance(obj, p, horizontal=True)[0])
        if d <= grid.robot.radius + 1e-9 and (best is None or d < best[1]):
            best = (obj, d)
    return best


def landing_problem(grid: PlanningGrid, point: Sequence[float], forced: bool = False,
                    clear: bool = False) -> LandingProblem | None:
    """Why the robot may not land at ``point`` (world [m]; x, y used) on ``grid``, or ``None`` (the
    module's rule). ``forced``: a critical-battery landing (unseen floor and the planner's clearance do
    not stop it; objects and obstacle cells in the footprint do). ``clear``: also outside the danger band."""
    ws = grid.workspace
    x, y = float(point[0]), float(point[1])
    if not (math.isfinite(x) and math.isfinite(y)):
        return LandingProblem("outside", f"the landing spot ({x}, {y}) is not a finite point")
    cell = ws.cell_of((x, y, ws.floor))
    if cell is None:
        return LandingProblem("outside", f"the landing spot {_pt(x, y)} is outside the workspace")
    foot = footprint(grid, (x, y))
    unseen, obstacle = _columns(grid)
    if not forced and np.any(unseen & foot):
        return LandingProblem("unseen", f"the floor under the robot's footprint at {_pt(x, y)} has not been seen")
    near = _nearest_object(grid, x, y)
    if near is not None:
        obj, d = near
        name = f"{obj.label.replace('_', ' ')} '{obj.id}'"  # type: ignore[attr-defined]
        where = "under" if d <= 1e-9 else f"{d:.2f} m from"
        return LandingProblem("object", f"{name} is {where} the landing spot {_pt(x, y)}; the robot needs "
                              f"{grid.robot.radius:.2f} m around it (its radius), whatever the object's height",
                              obj.id)  # type: ignore[attr-defined]
    if np.any(obstacle & foot):
        i, j = np.argwhere(obstacle & foot)[0]
        what = _WORDS.get(Closed(int(grid.reason[i, j, 0])), "an obstacle")  # type: ignore[index]
        c = ws.centers(np.array([[i, j, 0]]))[0]
        return LandingProblem("obstacle", f"{what} at {_pt(c[0], c[1])} is under the robot's footprint at "
                              f"{_pt(x, y)}")
    k0 = (cell[0], cell[1], 0)
    if not forced and grid.state_at(k0) is CellState.OCCUPIED and grid.reason_at(k0) != _EDGE:
        owner = grid.owner_of(k0)
        return LandingProblem("obstacle", f"the landing spot {_pt(x, y)} is within the robot's radius of "
                              f"{owner or 'an obstacle'}", owner)
    if clear and grid.state_at(k0) is CellState.OCCUPIED:  # only the workspace's edge band reaches here
        return LandingProblem("obstacle", f"the landing spot {_pt(x, y)} is within the robot's radius of the "
                              "workspace's edge")
    if clear and grid.state_at(k0) is not CellState.FREE:
        return LandingProblem("danger", f"the landing spot {_pt(x, y)} is in the danger band beside an obstacle "
                              "(free ground is needed to take off and land)")
    return None


def landing_mask(grid: PlanningGrid, forced: bool = False, clear: bool = False) -> np.ndarray:
    """``bool [nx, ny]``: the floor cells whose centre is fit for landing (:func:`landing_problem` is
    ``None`` there), computed for the whole floor at once."""
    ws = grid.workspace
    r = max(0, int(math.floor(grid.robot.radius / ws.resolution + 1e-9)))
    ii, jj = np.mgrid[-r:r + 1, -r:r + 1]
    disk = np.hypot(ii, jj) * ws.resolution <= grid.robot.radius + 1e-9  # cell centres within the radius
    unseen, obstacle = _columns(grid)
    bad = ndimage.binary_dilation(obstacle, structure=disk) if obstacle.any() else obstacle.copy()
    if not forced and unseen.any():
        bad |= ndimage.binary_dilation(unseen, structure=disk)
    objs = [o for o in grid.objects if o.frame == "world"]
    if objs:
        pads = margins(objs) if getattr(grid.robot, "mapping_margin", False) else None
        d2, _ = object_distances(objs, ws.axes(), grid.robot.radius, z_band=_band(grid), pads=pads)
        bad |= d2 <= grid.robot.radius + 1e-9
    ground = grid.state[:, :, 0]
    if not forced:
        closed = ground == CellState.OCCUPIED
        if _EDGE is not None and grid.reason is not None:
            closed &= grid.reason[:, :, 0] != _EDGE
        bad |= closed
    if clear:
        bad |= ground != CellState.FREE
    return ~bad


_GATE: list[tuple[PlanningGrid, np.ndarray]] = []  # the last grid's no-landing mask (routes ask on every plan)


def no_landing(grid: PlanningGrid) -> np.ndarray:
    """``bool [nx, ny]``: the floor cells no route may land on, by the rule every mission's landing is
    checked with (:func:`planner.mission.check_landing` and the mission's landing spot: free ground, nothing
    right above): ``~landing_mask(grid, clear=True)``, and the cells with a closed cell right above them.
    The planner takes no move from the air down into them (:func:`planner.astar.astar`'s ``no_land``); the
    robot still walks through them and takes off from them. The last grid's answer is kept."""
    last = _GATE[0] if _GATE else None  # one read: another thread may replace it
    if last is not None and last[0] is grid:
        return last[1]
    gate = ~landing_mask(grid, clear=True)
    if grid.state.shape[2] > 1:
        gate |= grid.state[:, :, 1] == CellState.OCCUPIED
    _GATE[:] = [(grid, gate)]
    return gate


def refused_landing(grid: PlanningGrid, cells: np.ndarray) -> str | None:
    """The first landing of the cell path ``cells`` (K x 3, start..goal) on a floor cell :func:`no_landing`
    refuses, in the operator's words (``the only routes land at (1.62, 6.12), where the floor under ...``),
    or ``None`` when every landing of the path is fit."""
    cells = np.asarray(cells, dtype=np.int64).reshape(-1, 3)
    gate = no_landing(grid)
    for a, b in zip(cells[:-1], cells[1:]):
        if a[2] > 0 and b[2] == 0 and gate[b[0], b[1]]:
            c = grid.workspace.centers(b[None, :])[0]
            problem = landing_problem(grid, c[:2], clear=True)
            why = problem.text if problem is not None else "a cell right above it is closed for the robot's size"
            return f"the only routes land at {_pt(c[0], c[1])}, where the robot may not land: {why}"
    return None


def return_spots(grid: PlanningGrid, launch: Sequence[float], limit: int = 8) -> tuple[list[tuple[float, float, float]], str]:
    """Where Return may land, nearest first, and why not at the take-off spot ``launch`` (world [m]).

    ``([launch], "")`` when the landing rule (:func:`landing_problem`) fits the take-off spot and the
    planner does not close its floor cell; else the ``limit`` floor cell centres nearest to it in plan
    where both hold (z = the floor), and the reason: ``too near the wall`` when its cell lies in the
    workspace's edge band (within the robot's radius of a wall: :func:`planner.cspace.edge_closed`), else
    the landing rule's or the planner's words. The list is empty when no floor cell fits."""
    ws = grid.workspace
    x, y = float(launch[0]), float(launch[1])
    cell = ws.cell_of((x, y, ws.floor))
    why = ""
    if cell is None:
        why = "outside the workspace"
    elif grid.edge is not None and bool(grid.edge[cell[0], cell[1], 0]):
        why = "too near the wall"
    else:
        problem = landing_problem(grid, (x, y))
        if problem is not None:
            why = problem.text
        elif grid.state_at((cell[0], cell[1], 0)) is CellState.OCCUPIED:
            why = "its floor cell is closed for the robot's size"
    if not why:
        return [(x, y, float(launch[2]) if len(launch) > 2 else ws.floor)], ""
    ok = landing_mask(grid) & (grid.state[:, :, 0] != CellState.OCCUPIED)
    idx = np.argwhere(ok)
    if not len(idx):
        return [], why
    centres = ws.centers(np.column_stack([idx, np.zeros(len(idx), dtype=idx.dtype)]))
    order = np.argsort(np.hypot(centres[:, 0] - x, centres[:, 1] - y), kind="stable")[:max(1, int(limit))]
    return [(float(centres[n, 0]), float(centres[n, 1]), float(ws.floor)) for n in order], why


__all__ = ["LandingProblem", "OBSTACLE_CELLS", "footprint", "landing_mask", "landing_problem", "no_landing",
           "refused_landing", "return_spots", "unseen_footprint"]
