"""The 3D planning grid: the robot's configuration space from scene boxes and known space, the
danger band, layer costs.

Everything here is in the world frame (z up) [m]. Cell ``(i, j, k)`` spans
``min + (i, j, k) * resolution`` to ``min + (i+1, j+1, k+1) * resolution``; ``k = 0`` is the
ground layer (the robot walks there), ``k = 1`` the take-off/landing layer, ``k >= 2`` flight.

:func:`build_grid` closes every cell the robot (:mod:`planner.robot_model`) cannot stand in:
inside an object, within its radius of an obstacle (objects, grown by the uncertainty of where they
were mapped; unlabelled obstacles the depth saw,
unknown space unless allowed, the column under a floating object, the space outside the workspace),
so no route passes closer than the radius; the danger band beyond it only makes cells dearer (Nav2's
inflation layer). Known space comes from :mod:`pipeline.mapping.known_space` (read through
:class:`KnownSpaceLike`); a scene without it is fully known.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from enum import IntEnum
from typing import Any, Iterable, Mapping, Protocol, Sequence

import numpy as np

from pipeline.scene import Scene, SceneObject
from planner.cspace import box_distance, dilate, edge_closed, floating_objects
from planner.clearance import crowding
from planner.flight_body import body_gap, flight_dilate
from planner.map_uncertainty import margins
from planner.object_space import object_cells
from planner.robot_model import MORPHOGEAR, RobotModel, RobotModelError


class CellState(IntEnum):
    """What a cell holds."""

    FREE = 0
    DANGEROUS = 1
    OCCUPIED = 2


class GridError(ValueError):
    """Bad workspace or grid parameters."""


@dataclass(frozen=True)
class Workspace:
    """An axis-aligned box in the world frame [m], split into cubic cells."""

    min: tuple[float, float, float] = (0.0, 0.0, 0.0)
    max: tuple[float, float, float] = (5.0, 8.0, 3.0)
    resolution: float = 0.25

    def __post_init__(self) -> None:
        if not (self.resolution > 0 and math.isfinite(self.resolution)):
            raise GridError(f"resolution must be > 0 m, got {self.resolution}")
        for a in range(3):
            if not self.max[a] > self.min[a]:
                raise GridError(f"workspace max {self.max} must exceed min {self.min} on every axis")
        smallest = min(self.max[a] - self.min[a] for a in range(3))
        if self.resolution > 2.0 * smallest:  # the first cell's centre (half a cell in) would lie outside the room
            raise GridError(f"resolution must be at most twice the workspace's smallest side ({smallest:g} m), "
                            f"so a cell's centre lies inside it, got {self.resolution:g} m")
        if np.prod(self.shape) > 400_000_000:
            raise GridError(f"grid {self.shape} has too many cells; use a coarser resolution")

    @property
    def shape(self) -> tuple[int, int, int]:
        """Cells per axis ``(nx, ny, nz)``."""
        n = [max(1, int(round((self.max[a] - self.min[a]) / self.resolution))) for a in range(3)]
        return (n[0], n[1], n[2])

    @property
    def floor(self) -> float:
        """Floor height [m] (bottom of the ground layer)."""
        return self.min[2]

    def contains(self, point: Sequence[float]) -> bool:
        return all(self.min[a] <= point[a] <= self.max[a] for a in range(3))

    def cell_of(self, point: Sequence[float]) -> tuple[int, int, int] | None:
        """The cell holding a world point, or ``None`` outside the workspace."""
        if not self.contains(point):
            return None
        idx = [min(int((point[a] - self.min[a]) / self.resolution), self.shape[a] - 1) for a in range(3)]
        return (idx[0], idx[1], idx[2])

    def centers(self, cells: np.ndarray) -> np.ndarray:
        """World centres [m] of cells (N x 3 int)."""
        c = np.asarray(cells, dtype=np.float64).reshape(-1, 3)
        return np.asarray(self.min) + (c + 0.5) * self.resolution

    def axes(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Cell-centre coordinates along x, y, z [m]."""
        nx, ny, nz = self.shape
        r = self.resolution
        return tuple(self.min[a] + (np.arange(n) + 0.5) * r for a, n in enumerate((nx, ny, nz)))  # type: ignore[return-value]

    def layer_height(self, k: int) -> float:
        """Centre height of layer ``k`` [m]."""
        return self.min[2] + (k + 0.5) * self.resolution


@dataclass(frozen=True)
class CostWeights:
    """Per-cell traversal costs (per metre) of the Aerial-Ground A*.

    Attributes:
        ground: Ground layer: walking is the safe, cheap motion.
        takeoff: First air layer: take-off and landing are the riskiest manoeuvres.
        flight: Higher layers: flying is less preferable than walking indoors.
        danger: Multiplier for dangerous cells (within the robot's margin of an obstacle).
        forbid_low_danger: Make dangerous cells of the take-off layer impassable, so the robot
            never takes off or lands next to an obstacle (spots stay on free ground).
    """

    ground: float = 1.0
    takeoff: float = 12.0
    flight: float = 3.0
    danger: float = 5.0
    forbid_low_danger: bool = True

    def __post_init__(self) -> None:
        for name in ("ground", "takeoff", "flight", "danger"):
            v = getattr(self, name)
            if not (v > 0 and math.isfinite(v)):
                raise GridError(f"cost weight {name} must be a positive number, got {v}")


def box_window(obj: SceneObject, ws: Workspace) -> tuple[tuple[slice, slice, slice], np.ndarray] | None:
    """The cells an object's oriented box overlaps, as index slices of the grid and the mask within them
    (``None`` when it overlaps none): :func:`box_cells` without a whole-grid array per object."""
    if obj.frame != "world":
        raise GridError(f"object {obj.id!r} is in the {obj.frame} frame; the planner needs world")
    w, h, l = obj.size
    half = ws.resolution / 2.0
    xs, ys, zs = ws.axes()
    cx, cy, cz = obj.position
    c, s = math.cos(obj.yaw), math.sin(obj.yaw)
    # conservative bounding window first, to keep work local
    rx = abs(c) * l / 2 + abs(s) * w / 2 + half
    ry = abs(s) * l / 2 + abs(c) * w / 2 + half
    ix = np.nonzero(np.abs(xs - cx) < rx)[0]
    iy = np.nonzero(np.abs(ys - cy) < ry)[0]
    iz = np.nonzero(np.abs(zs - cz) < h / 2 + half)[0]
    if ix.size == 0 or iy.size == 0 or iz.size == 0:
        return None
    dx = xs[ix][:, None] - cx
    dy = ys[iy][None, :] - cy
    along = c * dx + s * dy  # length axis
    across = -s * dx + c * dy  # width axis
    foot = (np.abs(along) < l / 2 + half) & (np.abs(across) < w / 2 + half)
    sub = np.repeat(foot[:, :, None], iz.size, axis=2)
    # the axes are sorted, so each index set is one contiguous run
    return (slice(int(ix[0]), int(ix[-1]) + 1), slice(int(iy[0]), int(iy[-1]) + 1),
            slice(int(iz[0]), int(iz[-1]) + 1)), sub


def box_cells(obj: SceneObject, ws: Workspace) -> np.ndarray:
    """Boolean mask [nx, ny, nz] of the cells an object's oriented box overlaps.

    A cell counts when its centre lies strictly within the box grown by half a cell, i.e. the
    cell and the box overlap for an axis-aligned box (slightly conservative when yawed).
    """
    mask = np.zeros(ws.shape, dtype=bool)
    found = box_window(obj, ws)
    if found is not None:
        mask[found[0]] = found[1]
    return mask


class Closed(IntEnum):
    """Why a cell is impassable (:attr:`PlanningGrid.reason`); ``OPEN`` for passable cells."""

    OPEN = 0
    OBJECT = 1  # inside a mapped object's box
    CLEARANCE = 2  # within the robot's radius of an obstacle (or, walking, under one below its height)
    UNLABELLED = 3  # a depth surface no mapped object explains
    UNKNOWN = 4  # not seen yet (unknown space closed)
    BENEATH = 5  # under a floating object, not seen free
    SURFACE = 6  # a depth surface a mapped object explains, outside its mapped box (the box may be off)
    EDGE = 7  # within the robot's size of the workspace's edge (space outside it is closed: planner.cspace)


UNKNOWN_POLICIES = ("closed", "allow")
"""``closed`` (default): unknown cells are obstacles; ``allow``: passable, dearer, marked unseen."""

DANGER_BAND = 0.25
"""Width [m] of the dangerous (dearer) band beyond the robot's radius (Nav2's inflation cost)."""

KNOWN_RULES = {
    "fully_known": "fully known: no known space in the scene, every cell outside the objects is taken as free",
    "closed": "known space: only seen-free space is planned through (unknown space closed)",
    "allow": "known space: unknown space allowed (routes through it are marked unseen)",
}
"""The rule a grid was built with (:attr:`PlanningGrid.rule`) and how ``plan`` says it."""


class KnownSpaceLike(Protocol):
    """What the planner reads of :class:`pipeline.mapping.known_space.KnownSpace` (duck-typed: the
    planner imports only :mod:`pipeline.scene`)."""

    def planning_view(self, origin: Sequence[float], shape: Sequence[int], resolution: float,
                      objects: Sequence[SceneObject] = ...) -> tuple[np.ndarray, np.ndarray]: ...


@dataclass(frozen=True)
class PlanningGrid:
    """Cell states over a workspace. ``state[i, j, k]`` holds a :class:`CellState`.

    ``OCCUPIED`` means impassable for the robot (its configuration space): inside an object, within
    its radius of an obstacle, an unlabelled obstacle, unknown space (closed by default) or the
    column under a floating object; :attr:`reason` says which (:class:`Closed`).
    ``DANGEROUS`` cells are passable but dearer: within the danger band beyond the radius, or
    unseen (``unknown="allow"``).

    Attributes:
        workspace: Bounds and resolution.
        state: ``uint8 [nx, ny, nz]`` of :class:`CellState`.
        margin: The robot's walking radius [m] (``robot.radius``).
        owners: Object ids; ``owner`` indexes them (``-1``: no object) for object cells.
        reason: ``uint8 [nx, ny, nz]`` of :class:`Closed` (``None`` on grids made elsewhere: all
            occupied cells count as objects).
        unseen: ``bool [nx, ny, nz]``: passable cells not seen free (only with ``unknown="allow"``).
        robot: The robot's size.
        rule: Key of :data:`KNOWN_RULES`.
        objects: The scene's objects (world frame), to name the nearest in messages.
        unlabelled: Planning cells holding unlabelled obstacles.
        floating: Ids of floating objects whose column is closed (not seen free beneath).
    """

    workspace: Workspace
    state: np.ndarray
    margin: float
    owners: tuple[str, ...] = ()
    owner: np.ndarray | None = None  # int32 [nx, ny, nz]: index into ``owners`` or -1
    reason: np.ndarray | None = None
    unseen: np.ndarray | None = None
    robot: RobotModel = MORPHOGEAR
    rule: str = "fully_known"
    objects: tuple[SceneObject, ...] = ()
    unlabelled: int = 0
    floating: tuple[str, ...] = ()
    build: Mapping[str, Any] | None = None  # build_grid's keyword arguments (for :meth:`without`)
    edge: np.ndarray | None = None  # bool [nx, ny, nz]: too near the workspace's edge (cspace.edge_closed)

    def without(self, ids: Iterable[str]) -> "PlanningGrid":
        """The same grid built without the objects ``ids`` (same known space and rules)."""
        drop = set(ids)
        kw = dict(self.build or {"robot": self.robot})
        return build_grid([o for o in self.objects if o.id not in drop], self.workspace, **kw)

    def owner_of(self, cell: Sequence[int]) -> str | None:
        """Id of the object occupying a cell, if any; for a cell closed because it lies within the
        robot's radius of an object (:attr:`Closed.CLEARANCE`), that object."""
        if self.owner is None:
            return None
        i = int(self.owner[cell[0], cell[1], cell[2]])
        if i >= 0:
            return self.owners[i]
        if self.reason is not None and int(self.reason[cell[0], cell[1], cell[2]]) == Closed.CLEARANCE:
            found = crowding(self, cell)
            if found is not None:
                return found[0].id
        return None

    def reason_at(self, cell: Sequence[int]) -> Closed:
        """Why the cell is closed (``OPEN`` when passable)."""
        if self.reason is None:
            return Closed.OBJECT if self.state_at(cell) is CellState.OCCUPIED else Closed.OPEN
        return Closed(int(self.reason[cell[0], cell[1], cell[2]]))

    def counts(self) -> dict[str, int]:
        """Number of cells per state."""
        return {s.name.lower(): int(np.count_nonzero(self.state == s)) for s in CellState}

    def cost(self, weights: CostWeights = CostWeights()) -> np.ndarray:
        """Per-cell traversal cost [1/m] (``inf`` = impassable), C-contiguous float64."""
        nz = self.state.shape[2]
        layer = np.full(nz, weights.flight)
        layer[0] = weights.ground
        if nz > 1:
            layer[1] = weights.takeoff
        cost = np.broadcast_to(layer, self.state.shape).copy()
        danger = self.state == CellState.DANGEROUS
        cost[danger] *= weights.danger
        cost[self.state == CellState.OCCUPIED] = np.inf
        if weights.forbid_low_danger and nz > 1:
            cost[:, :, 1][danger[:, :, 1]] = np.inf
        return np.ascontiguousarray(cost)

    def state_at(self, cell: Sequence[int]) -> CellState:
        return CellState(int(self.state[cell[0], cell[1], cell[2]]))

    def walk_layers(self) -> int:
        """Layers (from the floor) the walking body spans: ``ceil(height / resolution)``, at least 1."""
        return max(1, min(self.state.shape[2], int(math.ceil(self.robot.height / self.workspace.resolution - 1e-9))))

    def own_cells(self, position: Sequence[float]) -> np.ndarray:
        """``bool [nx, ny, nz]``: the robot's own cells at ``position`` (world [m]): free by
        definition. On the floor (below the take-off layer) the ground cells whose centre lies
        within ``robot.radius`` of it horizontally; in the air the cells whose centre lies in the flying
        body (:mod:`planner.flight_body`: the sphere and the height above); always the cell holding it."""
        ws = self.workspace
        out = np.zeros(self.state.shape, dtype=bool)
        cell = ws.cell_of(position)
        if cell is None:
            return out
        xs, ys, zs = ws.axes()
        p = [float(v) for v in position]
        if cell[2] == 0:
            out[:, :, 0] = np.hypot(xs[:, None] - p[0], ys[None, :] - p[1]) <= self.robot.radius + 1e-9
        else:
            r2, dz = self.robot.flying_radius ** 2 + 1e-9, zs[None, None, :] - p[2]
            plan = (xs[:, None, None] - p[0]) ** 2 + (ys[None, :, None] - p[1]) ** 2
            out[:] = (plan + dz ** 2 <= r2) | ((plan <= r2) & (dz >= 0) & (dz <= self.robot.flying_height + 1e-9))
        out[cell] = True
        return out

    def objects_at(self, position: Sequence[float]) -> list[SceneObject]:
        """Objects overlapping the robot's body at ``position`` (world [m]; walking cylinder on the
        floor layer, the flying body above: :mod:`planner.flight_body`), as mapped (no mapping margin)."""
        ws = self.workspace
        cell = ws.cell_of(position)
        p = np.asarray([[float(v) for v in position]])
        out = []
        for o in self.objects:
            if cell is not None and cell[2] == 0:
                lo, hi = o.position[2] - o.size[1] / 2, o.position[2] + o.size[1] / 2
                if hi <= ws.floor or lo >= ws.floor + self.robot.height:
                    continue
                if box_distance(o, p, horizontal=True)[0] < self.robot.radius:
                    out.append(o)
            elif body_gap(o, p[0], self.robot) <= 0.0:
                out.append(o)
        return out

    def nearest_object(self, point: Sequence[float]) -> tuple[SceneObject | None, float]:
        """The object nearest a world point [m] and its distance [m] (horizontal on the floor layer)."""
        ws = self.workspace
        cell = ws.cell_of(point)
        flat = cell is not None and cell[2] == 0
        p = np.asarray([[float(v) for v in point]])
        best: tuple[SceneObject | None, float] = (None, math.inf)
        for o in self.objects:
            d = float(box_distance(o, p, horizontal=flat)[0])
            if d < best[1]:
                best = (o, d)
        return best


def _object_cells(objs: Sequence[SceneObject], ws: Workspace) -> tuple[np.ndarray, np.ndarray]:
    occupied = np.zeros(ws.shape, dtype=bool)
    owner = np.full(ws.shape, -1, dtype=np.int32)
    for n, obj in enumerate(objs):  # each object touches only its own window (not the whole grid)
        found = box_window(obj, ws)
        if found is None:
            continue
        win, cells = found
        occ, own = occupied[win], owner[win]  # views
        own[cells & ~occ] = n
        occ |= cells
    return occupied, owner


def _beneath(objs: Sequence[SceneObject], ws: Workspace, seen_free: np.ndarray | None) -> tuple[np.ndarray, list[str]]:
    """Cells under floating objects (down to the floor), less what was seen free; and their ids."""
    out = np.zeros(ws.shape, dtype=bool)
    ids = []
    for n in floating_objects(objs, ws.floor):
        cells = box_cells(objs[n], ws)
        if not cells.any():
            continue
        col = cells.any(axis=2)
        k_low = int(np.argmax(cells.any(axis=(0, 1))))
        under = np.zeros(ws.shape, dtype=bool)
        under[:, :, :k_low] = col[:, :, None]
        if seen_free is not None:
            under &= ~seen_free
        if under.any():
            out |= under
            ids.append(objs[n].id)
    return out, ids


def build_grid(
    objects: Scene | Iterable[SceneObject],
    workspace: Workspace = Workspace(),
    margin: float = 0.35,
    *,
    robot: RobotModel | None = None,
    known: KnownSpaceLike | None = None,
    unknown: str = "closed",
    danger_band: float = DANGER_BAND,
    floating: str = "close",
) -> PlanningGrid:
    """The robot's configuration space from a scene's world-frame boxes and, if given, known space.

    Args:
        objects: A scene (or its objects) in the world frame.
        workspace: Bounds and resolution.
        margin: Robot radius [m] walking and flying when ``robot`` is not given (0: a point robot).
        robot: The robot's size (:class:`planner.robot_model.RobotModel`); overrides ``margin``.
        known: Known space (``None``: the scene is taken as fully known: every cell outside the
            objects is free, as hand-made maps expect).
        unknown: ``closed`` or ``allow`` (:data:`UNKNOWN_POLICIES`); ignored without known space.
        danger_band: Width [m] of the dearer band beyond the radius.
        floating: ``close`` the column under a floating object unless seen free (with known space),
            or ``keep`` it (a simulator's true world, where floating things really float).

    Rules (world frame, cell centres): obstacles are the objects' boxes, every occupied known-space
    cell (unlabelled ones: no object explains them; and the seen surfaces of mapped objects outside
    their boxes, which may be mapped off), unknown cells (when closed) and the columns beneath
    floating objects. The **ground layer** (``k = 0``, walking) is closed where an obstacle lies
    within ``robot.radius`` horizontally of the cell's centre anywhere up to ``robot.height`` (the
    walking cylinder); **air layers** where an obstacle comes within the flying body at the cell's
    centre (a sphere of ``robot.flying_radius`` and the cylinder of that radius up to ``robot.height``
    above it: :mod:`planner.flight_body`). Cell obstacles are their cubes, objects their exact boxes grown in
    plan by their mapping margin (:mod:`planner.map_uncertainty`: none when pinned or without sightings). Cells within the further
    ``danger_band`` are dangerous. Cells too near the workspace's edge for the robot are closed
    (:attr:`Closed.EDGE`, :func:`planner.cspace.edge_closed`).
    """
    rb = robot if robot is not None else None
    if rb is None:
        if isinstance(margin, bool) or not isinstance(margin, (int, float)) or not (margin >= 0 and math.isfinite(margin)):
            raise GridError(f"margin must be >= 0 m, got {margin}")
        try:
            rb = RobotModel.with_radius(float(margin))
        except RobotModelError as exc:
            raise GridError(str(exc)) from None
    if not (isinstance(danger_band, (int, float)) and math.isfinite(danger_band) and danger_band >= 0):
        raise GridError(f"danger_band must be a finite number >= 0 m, got {danger_band!r}")
    if unknown not in UNKNOWN_POLICIES:
        raise GridError(f"unknown must be one of {', '.join(UNKNOWN_POLICIES)}, got {unknown!r}")
    if floating not in ("close", "keep"):
        raise GridError(f"floating must be 'close' or 'keep', got {floating!r}")
    ws = workspace
    res = ws.resolution
    objs = objects.objects if isinstance(objects, Scene) else tuple(objects)
    obj_occ, owner = _object_cells(objs, ws)
    if known is not None:
        try:
            kstate, unl = known.planning_view(ws.min, ws.shape, res, objs)
        except ValueError as exc:
            raise GridError(f"known space: {exc}") from None
        unl = unl & ~obj_occ
        surface = (kstate == 2) & ~obj_occ & ~unl  # seen surfaces of mapped objects, outside their boxes
        unknown_cells = (kstate == 0) & ~obj_occ
        seen_free: np.ndarray | None = kstate == 1
        rule = unknown
    else:
        unl = np.zeros(ws.shape, dtype=bool)
        surface = np.zeros(ws.shape, dtype=bool)
        unknown_cells = np.zeros(ws.shape, dtype=bool)
        seen_free = None
        rule = "fully_known"
    if floating == "close" and known is not None:
        beneath, floating_ids = _beneath(objs, ws, seen_free)
        beneath &= ~obj_occ
    else:
        beneath, floating_ids = np.zeros(ws.shape, dtype=bool), []
    closed_unknown = unknown_cells if rule == "closed" else np.zeros(ws.shape, dtype=bool)
    cell_obst = unl | surface | beneath | closed_unknown
    reason = np.zeros(ws.shape, dtype=np.uint8)
    danger, axes, reach_w = np.zeros(ws.shape, dtype=bool), ws.axes(), rb.radius + danger_band
    # air: the flying body; objects close within their mapping margin, the danger band ends as from the mapped box
    pads = margins(objs) if rb.mapping_margin else [0.0] * len(objs)
    air, air_dear, walk, walk_dear = object_cells(objs, axes, rb, danger_band, pads, ws.floor)
    reason[air | flight_dilate(cell_obst, rb, res)] = Closed.CLEARANCE
    danger |= air_dear | flight_dilate(cell_obst, rb, res, danger_band)
    # ground layer: the walking cylinder
    kh = max(1, min(ws.shape[2], int(math.ceil(rb.height / res - 1e-9))))
    col = cell_obst[:, :, :kh].any(axis=2)
    reason[:, :, 0] = np.where(walk | dilate(col, rb.radius, res), Closed.CLEARANCE, Closed.OPEN)
    danger[:, :, 0] = walk_dear | dilate(col, reach_w, res)
    # what the cell (for the ground layer: its walking column) itself holds wins over clearance
    for mask, why in ((closed_unknown, Closed.UNKNOWN), (beneath, Closed.BENEATH), (surface, Closed.SURFACE),
                      (unl, Closed.UNLABELLED),
                      (obj_occ, Closed.OBJECT)):
        if why is not Closed.OBJECT:  # an object above the floor cell only crowds the walking body: clearance
            reason[:, :, 0][mask[:, :, :kh].any(axis=2)] = why
        reason[mask] = why
    edge = edge_closed(ws.min, ws.max, axes, rb)  # outside the workspace is closed: keep the robot's size from it
    reason[edge & (reason == Closed.OPEN)] = Closed.EDGE
    state = np.zeros(ws.shape, dtype=np.uint8)
    state[danger] = CellState.DANGEROUS
    unseen = None
    if rule == "allow":
        unseen = unknown_cells.copy()
        unseen[:, :, 0] = unknown_cells[:, :, :kh].any(axis=2)
        unseen &= reason == Closed.OPEN
        state[unseen] = CellState.DANGEROUS
    state[reason != Closed.OPEN] = CellState.OCCUPIED
    build = {"robot": rb, "known": known, "unknown": unknown, "danger_band": danger_band, "floating": floating}
    return PlanningGrid(ws, state, rb.radius, tuple(o.id for o in objs), owner, reason, unseen, rb, rule, tuple(objs),
                        int(unl.sum()), tuple(floating_ids), build, edge)
