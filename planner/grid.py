"""The 3D planning grid: workspace, occupancy from scene boxes, dangerous margin, layer costs.

Everything here is in the world frame (z up) [m]. Cell ``(i, j, k)`` spans
``min + (i, j, k) * resolution`` to ``min + (i+1, j+1, k+1) * resolution``; ``k = 0`` is the
ground layer (the robot walks there), ``k = 1`` the take-off/landing layer, ``k >= 2`` flight.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from enum import IntEnum
from typing import Iterable, Sequence

import numpy as np
from scipy import ndimage

from pipeline.scene import Scene, SceneObject


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


def box_cells(obj: SceneObject, ws: Workspace) -> np.ndarray:
    """Boolean mask [nx, ny, nz] of the cells an object's oriented box overlaps.

    A cell counts when its centre lies strictly within the box grown by half a cell, i.e. the
    cell and the box overlap for an axis-aligned box (slightly conservative when yawed).
    """
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
    mask = np.zeros(ws.shape, dtype=bool)
    if ix.size == 0 or iy.size == 0 or iz.size == 0:
        return mask
    dx = xs[ix][:, None] - cx
    dy = ys[iy][None, :] - cy
    along = c * dx + s * dy  # length axis
    across = -s * dx + c * dy  # width axis
    foot = (np.abs(along) < l / 2 + half) & (np.abs(across) < w / 2 + half)
    sub = np.repeat(foot[:, :, None], iz.size, axis=2)
    mask[np.ix_(ix, iy, iz)] = sub
    return mask


@dataclass(frozen=True)
class PlanningGrid:
    """Cell states over a workspace. ``state[i, j, k]`` holds a :class:`CellState`."""

    workspace: Workspace
    state: np.ndarray
    margin: float
    owners: tuple[str, ...] = ()
    owner: np.ndarray | None = None  # int32 [nx, ny, nz]: index into ``owners`` or -1

    def owner_of(self, cell: Sequence[int]) -> str | None:
        """Id of the object occupying a cell, if any."""
        if self.owner is None:
            return None
        i = int(self.owner[cell[0], cell[1], cell[2]])
        return self.owners[i] if i >= 0 else None

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


def build_grid(
    objects: Scene | Iterable[SceneObject],
    workspace: Workspace = Workspace(),
    margin: float = 0.35,
) -> PlanningGrid:
    """Occupancy and danger from a scene's world-frame boxes.

    Args:
        objects: A scene (or its objects) in the world frame.
        workspace: Bounds and resolution.
        margin: Robot radius [m]: free cells whose centre lies within this distance of an
            occupied cell's centre become dangerous.
    """
    if not (margin >= 0 and math.isfinite(margin)):
        raise GridError(f"margin must be >= 0 m, got {margin}")
    objs = objects.objects if isinstance(objects, Scene) else tuple(objects)
    occupied = np.zeros(workspace.shape, dtype=bool)
    owner = np.full(workspace.shape, -1, dtype=np.int32)
    for n, obj in enumerate(objs):
        cells = box_cells(obj, workspace)
        owner[cells & ~occupied] = n
        occupied |= cells
    state = np.zeros(workspace.shape, dtype=np.uint8)
    if occupied.any() and margin > 0:
        dist = ndimage.distance_transform_edt(~occupied, sampling=workspace.resolution)
        state[(dist <= margin + 1e-9) & ~occupied] = CellState.DANGEROUS
    state[occupied] = CellState.OCCUPIED
    return PlanningGrid(workspace, state, margin, tuple(o.id for o in objs), owner)
