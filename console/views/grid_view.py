"""The workspace and its planning grid in the 3D view.

Draws the floor, the workspace bounds and the grid cells as four separately toggleable layers, each
one batched mesh so tens of thousands of cells stay fluid, sorted by why a cell is closed
(:attr:`PlanningGrid.reason`):

- occupied (red): obstacles only: inside a mapped object, a depth surface an object explains, or
  under a floating object (unlabelled obstacles are drawn magenta by the known-space view);
- dangerous (yellow): the robot's clearance around an obstacle (closed) and the dearer band beyond it,
  and the band along the workspace's edge the robot keeps its size from (:attr:`Closed.EDGE`);
- free (blue, off by default: one click under Layers shows it);
- unknown (translucent grey, off by default): cells no capture has seen, and the clearance and band
  around unseen space (not around an obstacle); the same cells whether unknown space is closed or
  planned through ("Plan into unknown space" changes the routes, not the colours).

Free cells are drawn on the goal layer only (the floor, or the chosen goal
altitude): that is the layer a click puts a goal on, and a full 3D lattice of free cells would
hide everything else. All positions are world frame (z up) [m].
"""

from __future__ import annotations

import math
import threading
from typing import Any

import numpy as np
import trimesh
import viser

from planner.cspace import dilate, object_distances
from planner.grid import DANGER_BAND, CellState, Closed, PlanningGrid
from planner.robot_model import RobotModel

from console.session.session import GRID, SETTINGS, Session

OCCUPIED_RGB = (220, 50, 47)
DANGEROUS_RGB = (240, 190, 30)
FREE_RGB = (70, 130, 230)
UNKNOWN_RGB = (150, 150, 155)

OBSTACLE_REASONS = (Closed.OBJECT, Closed.SURFACE, Closed.BENEATH)
"""Closed cells the red layer draws (:attr:`Closed.UNLABELLED` is the known-space view's magenta layer)."""

_LAYERS: tuple[tuple[str, CellState, tuple[int, int, int], float, float], ...] = (
    # name, state, colour, size as a fraction of the cell, opacity
    ("occupied", CellState.OCCUPIED, OCCUPIED_RGB, 0.32, 0.75),
    ("dangerous", CellState.DANGEROUS, DANGEROUS_RGB, 0.2, 0.75),
    ("free", CellState.FREE, FREE_RGB, 0.22, 0.7),
    ("unknown", CellState.OCCUPIED, UNKNOWN_RGB, 0.2, 0.25),
)


def near_obstacles(grid: PlanningGrid) -> np.ndarray:
    """Boolean ``[nx, ny, nz]``: cells within the robot's reach (radius plus :data:`DANGER_BAND`) of
    an obstacle: a mapped object's box or an obstacle cell (:data:`OBSTACLE_REASONS`, unlabelled);
    unseen space is no obstacle here. The same reach as :func:`planner.grid.build_grid` uses: spheres
    of the flying radius in the air, the walking cylinder (radius, up to the body height) on the ground."""
    ws = grid.workspace
    reason = grid.reason
    rb = grid.robot if grid.robot is not None else RobotModel.with_radius(float(grid.margin))
    res = ws.resolution
    cells = np.isin(reason, [int(r) for r in OBSTACLE_REASONS + (Closed.UNLABELLED,)])
    reach_f, reach_w = rb.flying_radius + DANGER_BAND, rb.radius + DANGER_BAND
    d3, _ = object_distances(grid.objects, ws.axes(), reach_f)
    near = (d3 <= reach_f + 1e-9) | dilate(cells, reach_f, res)
    kh = max(1, min(ws.shape[2], int(math.ceil(rb.height / res - 1e-9))))
    d2, _ = object_distances(grid.objects, ws.axes(), reach_w, z_band=(ws.floor, ws.floor + rb.height))
    near[:, :, 0] = (d2 <= reach_w + 1e-9) | dilate(cells[:, :, :kh].any(axis=2), reach_w, res)
    return near


HOLDS = (Closed.OBJECT, Closed.SURFACE, Closed.BENEATH, Closed.UNLABELLED)
"""What a cell itself holds: it wins over its being unseen (as :func:`planner.grid.build_grid` orders them)."""


def unseen_cells(grid: PlanningGrid) -> np.ndarray:
    """Boolean ``[nx, ny, nz]``: cells no capture has seen (outside what a cell holds, :data:`HOLDS`), on the
    ground layer any cell of the walking column (the robot's body height), whatever the planning rule: with
    unknown space closed they are :attr:`Closed.UNKNOWN`; with it allowed (``"Plan into unknown space"``) the
    planner marks them passable but dearer, or clearance or edge cells, so they are read from the grid's
    known space (:meth:`pipeline.mapping.known_space.KnownSpace.planning_view`). All ``False`` without known
    space (a hand-made map is fully known)."""
    reason = grid.reason
    if reason is None:
        return np.zeros(grid.state.shape, bool)
    if grid.rule != "allow":
        return reason == Closed.UNKNOWN
    known = (grid.build or {}).get("known")
    if known is None:
        return np.zeros(grid.state.shape, bool) if grid.unseen is None else grid.unseen.copy()
    ws = grid.workspace
    kstate, _ = known.planning_view(ws.min, ws.shape, ws.resolution, ())
    unseen = kstate == 0
    rb = grid.robot if grid.robot is not None else RobotModel.with_radius(float(grid.margin))
    kh = max(1, min(ws.shape[2], int(math.ceil(rb.height / ws.resolution - 1e-9))))
    unseen[:, :, 0] = unseen[:, :, :kh].any(axis=2)
    return unseen & ~np.isin(reason, [int(r) for r in HOLDS])


def layer_mask(grid: PlanningGrid, name: str) -> np.ndarray:
    """Boolean ``[nx, ny, nz]`` of the cells the layer ``name`` draws.

    ``occupied``: obstacle cells (:data:`OBSTACLE_REASONS`; every occupied cell on a grid without
    reasons); ``dangerous``: dangerous cells and closed clearance cells (:attr:`Closed.CLEARANCE`)
    near an obstacle (:func:`near_obstacles`) and the band along the workspace's edge, none of them unseen;
    ``free``: free cells; ``unknown``: cells no capture has seen (:func:`unseen_cells`: closed as
    :attr:`Closed.UNKNOWN`, or passable but dearer with "Plan into unknown space"), and the dangerous and
    clearance cells that only unseen space makes so (no obstacle near). The planning rule changes what may be
    planned through, not the colours: unseen space is grey (off by default) either way.
    """
    reason = grid.reason
    if name == "free":
        return grid.state == CellState.FREE
    if name in ("dangerous", "unknown"):
        banded = grid.state == CellState.DANGEROUS
        if reason is None:
            return banded if name == "dangerous" else np.zeros(grid.state.shape, bool)
        banded |= reason == Closed.CLEARANCE
        near = near_obstacles(grid)
        unseen = unseen_cells(grid)
        if name == "dangerous":  # and the robot's size along the workspace's edge; never unseen space
            return ((banded & near) | (reason == Closed.EDGE)) & ~unseen
        return unseen | (banded & ~near)
    if name == "occupied":
        if reason is None:
            return grid.state == CellState.OCCUPIED
        return np.isin(reason, [int(r) for r in OBSTACLE_REASONS])
    raise ValueError(f"layer: must be one of occupied, dangerous, free, unknown, not {name!r}")


def layer_cells(grid: PlanningGrid, state: CellState | np.ndarray, max_height: float | None = None,
                level: int | None = None) -> np.ndarray:
    """World centres [m] (N x 3) of the cells in ``state``.

    Args:
        grid: The planning grid.
        state: Which cells: a cell state, or a boolean mask shaped like the grid (:func:`layer_mask`).
        max_height: Only cells whose bottom is below this height above the floor [m].
        level: Only cells of this layer index (0 = ground).
    """
    mask = state if isinstance(state, np.ndarray) else grid.state == state
    idx = np.argwhere(mask)
    ws = grid.workspace
    if max_height is not None and len(idx):
        bottom = ws.floor + idx[:, 2] * ws.resolution
        idx = idx[bottom < ws.floor + max_height - 1e-9]
    if level is not None and len(idx):
        idx = idx[idx[:, 2] == level]
    return ws.centers(idx)


def seen_free_cells(session: Any) -> int | None:
    """Cells of the session's known space the captures saw free (``None``: no known space yet)."""
    from pipeline.mapping.known_space import KnownState

    known = getattr(session, "known_space", None)
    return None if known is None else int((known.state() == KnownState.FREE).sum())


def count_line(grid: PlanningGrid, masks: dict[str, np.ndarray], hidden: list[str], seen_free: int | None) -> str:
    """The grid's count line (HTML): cells per layer of the whole grid (``masks``: :func:`layer_mask`).

    ``free`` counts the grid's free cells: where the robot, at its size, may be planned (seen free space
    too near unseen space or an obstacle for its body is not); ``seen_free`` (the known space's seen-free
    cells) is said beside it, so a first capture's few free cells are not read as nothing seen.
    """
    ws = grid.workspace
    seen = "" if seen_free is None else f" ({seen_free} seen free)"
    return (f"<small>Grid {ws.shape[0]}×{ws.shape[1]}×{ws.shape[2]} at {ws.resolution:g} m: "
            f"<b style='color:rgb{OCCUPIED_RGB}'>{int(masks['occupied'].sum())}</b> occupied · "
            f"<b style='color:rgb{(180, 140, 0)}'>{int(masks['dangerous'].sum())}</b> dangerous · "
            f"<b style='color:rgb{FREE_RGB}'>{int(masks['free'].sum())}</b> free for the robot{seen} · "
            f"<b style='color:rgb{(110, 110, 115)}'>{int(masks['unknown'].sum())}</b> unknown"
            + (f" ({' and '.join(hidden)} not drawn: {hidden_hint(hidden)})" if hidden else "") + "</small>")


def hidden_hint(hidden: list[str]) -> str:
    """How to show the hidden layers ``hidden`` (names of :data:`_LAYERS`), in words."""
    boxes = " / ".join(f"<i>{name.capitalize()} cells</i>" for name in hidden)
    return f"tick {boxes} under Layers"


class GridView:
    """Floor, bounds and the occupied / dangerous / free cell layers.

    Args:
        server: The viser server (scene and GUI shared by every tab).
        session: The state it draws.
    """

    def __init__(self, server: viser.ViserServer, session: Session) -> None:
        self._server = server
        self._session = session
        self._lock = threading.Lock()
        self._cube = trimesh.creation.box(extents=(1.0, 1.0, 1.0))
        self._handles: dict[str, Any] = {}
        ws = session.workspace
        self._checks: dict[str, viser.GuiCheckboxHandle] = {}
        defaults = {"occupied": True, "dangerous": True, "free": False, "unknown": False}
        hints = {
            "occupied": "Obstacle cells: inside a mapped object or a surface the depth saw; impassable (red). "
                        "Unlabelled obstacles are the magenta layer",
            "dangerous": "Cells within the robot's radius of an obstacle (impassable) or its margin beyond "
                         "(high cost) (yellow)",
            "free": "Free cells of the goal layer (the floor, or the goal altitude): where a click puts a goal "
                    "(blue). Off by default",
            "unknown": "Cells closed only because no capture has seen them yet, and the clearance around them "
                       "(translucent grey). Off by default",
        }
        self._counts = server.gui.add_markdown("")
        with server.gui.add_folder("Layers", expand_by_default=False) as folder:
            self.layers_folder = folder
            """The folder holding the layer toggles; other views may add their toggles to it."""
            for name, _, _, _, _ in _LAYERS:
                cb = server.gui.add_checkbox(f"{name.capitalize()} cells", defaults[name], hint=hints[name])
                cb.on_update(lambda _e: self.redraw())
                self._checks[name] = cb
            top = ws.max[2] - ws.floor
            self._height = server.gui.add_slider(
                "Cells up to [m]", min=ws.resolution, max=top, step=ws.resolution, initial_value=top,
                hint="Hide occupied, dangerous and unknown cells above this height (metres above the floor)",
            )
        self._height.on_update(lambda _e: self.redraw())
        self._draw_workspace()
        session.subscribe(self._on_event)
        self.redraw()

    # --- static geometry ---------------------------------------------------------------------
    def _draw_workspace(self) -> None:
        ws = self._session.workspace
        (x0, y0, z0), (x1, y1, z1) = ws.min, ws.max
        w, h = x1 - x0, y1 - y0
        self._server.scene.add_grid(
            "/workspace/floor", width=w, height=h, position=((x0 + x1) / 2, (y0 + y1) / 2, z0 - 0.002),
            cell_size=ws.resolution, section_size=1.0, cell_color=(205, 210, 218), section_color=(140, 150, 165),
            plane_color=(246, 247, 250), plane_opacity=1.0, shadow_opacity=0.2,
        )
        c = np.array([[x0, y0, z0], [x1, y0, z0], [x1, y1, z0], [x0, y1, z0],
                      [x0, y0, z1], [x1, y0, z1], [x1, y1, z1], [x0, y1, z1]])
        edges = [(0, 1), (1, 2), (2, 3), (3, 0), (4, 5), (5, 6), (6, 7), (7, 4), (0, 4), (1, 5), (2, 6), (3, 7)]
        self._server.scene.add_line_segments(
            "/workspace/bounds", np.array([[c[a], c[b]] for a, b in edges]), (90, 100, 120), thickness=0.012,
        )
        self._server.scene.add_label("/workspace/origin", "origin (0, 0)", position=(x0, y0, z0),
                                     font_screen_scale=0.7, anchor="top-left")

    # --- cells ----------------------------------------------------------------------------------
    def _on_event(self, topic: str, _payload: Any) -> None:
        if topic in (GRID, SETTINGS):
            self.redraw()

    def visible_layers(self) -> dict[str, bool]:
        """Which cell layers are switched on."""
        return {name: bool(cb.value) for name, cb in self._checks.items()}

    def redraw(self) -> None:
        """Redraw the four layers from the session's current grid."""
        with self._lock:  # read the state inside the lock: the last redraw always draws the latest state
            grid = self._session.grid
            ws = grid.workspace
            max_h = float(self._height.value)
            masks = {name: layer_mask(grid, name) for name, _, _, _, _ in _LAYERS}
            goal_cell = ws.cell_of((ws.min[0], ws.min[1], min(self._session.goal_height(), ws.max[2])))
            level = goal_cell[2] if goal_cell is not None else 0
            for name, state, rgb, frac, opacity in _LAYERS:
                node = f"/grid/{name}"
                old = self._handles.pop(name, None)
                if not self._checks[name].value:
                    pts = np.zeros((0, 3))
                elif name == "free":
                    pts = layer_cells(grid, masks[name], level=level)
                else:
                    pts = layer_cells(grid, masks[name], max_h)
                if len(pts) == 0:
                    if old is not None:
                        old.remove()
                    continue
                n = len(pts)
                handle = self._server.scene.add_batched_meshes_simple(
                    node,
                    vertices=self._cube.vertices * (ws.resolution * frac),
                    faces=self._cube.faces,
                    batched_wxyzs=np.tile([1.0, 0.0, 0.0, 0.0], (n, 1)),
                    batched_positions=pts.astype(np.float32),
                    batched_colors=rgb,
                    opacity=opacity,
                    lod="off",
                    cast_shadow=False,
                    receive_shadow=False,
                    flat_shading=True,
                )
                self._handles[name] = handle
            hidden = [name for name in ("free", "unknown") if not self._checks[name].value]
            self._counts.content = count_line(grid, masks, hidden, seen_free_cells(self._session))

    def drawn_counts(self) -> dict[str, int]:
        """Instances currently drawn per layer (for tests and the status line)."""
        with self._lock:
            return {name: int(len(h.batched_positions)) for name, h in self._handles.items()}
