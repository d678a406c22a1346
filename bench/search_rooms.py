"""Seeded random rooms for the search benchmark, with a hidden target, and the truth about each.

World frame (z up) [m]. Room ``n`` of seed ``s`` is drawn from ``numpy.random.default_rng([s, n])``
(so any process rebuilds the same room): ``W x L`` with both sides within 5..12 m (whole planning
cells), 3 m high, the planning workspace the room's floor plan at 0.25 m, the rendered shell 0.5 m
beyond it (no wall inside the robot's reach). The robot starts at ``(x, 0.7)`` facing +y.

Across the room, at 40-65 % of its length, a line of cardboard boxes 1-3 high (0.4-1.2 m) of
one of these kinds:

- ``wall``: wall to wall, no gap: the far side is reachable only by flying over it;
- ``gaps``: one or two gaps, 0.3-1.2 m wide (those narrower than the robot's 0.7 m still only by flying);
- ``open_end``: the line stops 0.8-2 m short of one side wall;
- ``two_lines``: a wall-to-wall line with one gap and a second, shorter line behind it.

Catalog furniture stands in front of and behind the line and beside the start. The target (a
robot dog, the catalog's size) stands behind the line, in half of the rooms also behind a piece of
furniture (a cabinet, shelf or box stack between it and the line). Two kinds of room cannot be
solved: ``sealed`` (the dog inside a ring of boxes up to the ceiling) and ``absent`` (no dog).

:func:`truth` finds, on the true room (every object known, the planner's robot size), whether a
floor spot within :data:`NEAR_TARGET` of the target's footprint can be reached from the start, and
the shortest path there in metres and the cheapest in the planner's cost (the SPL's reference).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np

from bench.rooms import clear_of, obj
from console.link.world import DEFAULT_START, ROOM_MAX, ROOM_MIN, box_wall, paper_room
from pipeline.scene import SceneObject
from planner.object_goal import footprint_distance
from planner.grid import CostWeights, PlanningGrid, Workspace, build_grid
from planner.robot_model import MORPHOGEAR
from planner.route import Route
from planner.search_viewpoints import path_costs

RES = 0.25
"""Planning cell [m]."""
HEIGHT = 3.0
"""Room and workspace height [m]."""
SHELL = 0.5
"""The rendered walls stand this far beyond the workspace [m]."""
NEAR_TARGET = 1.0
"""A search ends well when the robot stands on the floor within this of the target's footprint [m]
(go-to-object's :data:`planner.object_goal.APPROACH_MAX`: where it puts the robot beside an object)."""
TARGET = "robot_dog"
TARGET_SIZE = (0.28, 0.40, 0.645)
"""The catalog's robot dog ``(w, h, l)`` [m]."""
BOX = (0.45, 0.40, 0.45)
FURNITURE: list[tuple[str, tuple[float, float, float]]] = [
    ("desk", (1.4, 0.75, 0.7)), ("office_chair", (0.6, 1.0, 0.6)), ("suitcase", (0.45, 0.65, 0.27)),
    ("compressor", (0.35, 0.5, 0.45)), ("office_cabinet", (0.8, 1.85, 0.42)), ("cardboard_box", BOX),
    ("sofa", (2.0, 0.85, 0.9)), ("shelf", (0.8, 1.8, 0.3)), ("table", (0.9, 0.75, 1.6)),
    ("barrel", (0.58, 0.88, 0.58)), ("plant", (0.4, 0.8, 0.4)), ("trash_bin", (0.4, 0.65, 0.4)),
]
"""Catalog classes with their catalog sizes ``(w, h, l)`` [m]."""
KEEP_CLEAR = 0.8
"""Furniture keeps this far [m] (in plan, from its box) from the robot's start and the dog's centre."""
KINDS = ("wall", "gaps", "open_end", "two_lines")


@dataclass
class SearchRoom:
    """One hidden room.

    Attributes:
        name: ``room07-gaps-2`` (number, kind, box layers) or ``paper``.
        kind: The line's kind, ``sealed``, ``absent`` or ``paper``.
        objects: The true objects (world frame).
        workspace: The planning workspace (the room's floor plan, 3 m high).
        shell: The rendered room's ``(min, max)`` corners [m].
        start: The robot's start ``(x, y, yaw)`` [m, rad] on the floor.
        target_id: The hidden target's id (``None``: no target in the room).
    """

    name: str
    kind: str
    objects: tuple[SceneObject, ...]
    workspace: Workspace
    shell: tuple[tuple[float, float, float], tuple[float, float, float]]
    start: tuple[float, float, float]
    target_id: str | None

    @property
    def target(self) -> SceneObject | None:
        return next((o for o in self.objects if o.id == self.target_id), None)


@dataclass(frozen=True)
class Truth:
    """What the true room allows: ``findable`` (a floor spot within :data:`NEAR_TARGET` of the target
    is reachable), the shortest path there [m] and the cheapest in planner cost [cost·m] (``inf`` when not),
    and ``walk``: reachable on the floor alone."""

    findable: bool
    shortest_m: float
    shortest_cost: float
    why: str
    walk: bool = False  # reachable walking only (no flight)


def _renamed(objs: list[SceneObject], prefix: str) -> list[SceneObject]:
    return [dataclasses.replace(o, id=f"{prefix}{o.id}") for o in objs]


def box_run(x0: float, y0: float, x1: float, y1: float, layers: int, prefix: str) -> list[SceneObject]:
    """Boxes stacked ``layers`` high from ``(x0, y0)`` to ``(x1, y1)`` (axis-aligned) [m], overlapping so
    no gap is left (a sealed wall)."""
    length = math.hypot(x1 - x0, y1 - y0)
    n = max(1, int(math.ceil(length / 0.4)))
    yaw = 0.0 if abs(x1 - x0) >= abs(y1 - y0) else math.pi / 2
    out = []
    for c in range(n + 1):
        f = c / n
        for k in range(layers):
            out.append(obj(f"{prefix}{c}-{k}", "cardboard_box", x0 + f * (x1 - x0), y0 + f * (y1 - y0), BOX, yaw,
                           z0=k * BOX[1]))
    return out


def _line(rng: np.random.Generator, kind: str, y: float, width: float, layers: int) -> list[SceneObject]:
    boxes = _renamed(box_wall(y, 0.0, width, layers), "a")
    if kind == "gaps":
        for _ in range(int(rng.integers(1, 3))):
            gap = float(rng.choice([0.3, 0.5, 0.6, 0.9, 1.2]))
            cx = float(rng.uniform(0.8, width - 0.8))
            boxes = [b for b in boxes if abs(b.position[0] - cx) > gap / 2 + 0.225]
    elif kind == "open_end":
        cut = float(rng.uniform(0.8, 2.0))
        left = bool(rng.integers(0, 2))
        boxes = [b for b in boxes if (b.position[0] > cut if left else b.position[0] < width - cut)]
    elif kind == "two_lines":
        cx = float(rng.uniform(0.8, width - 0.8))
        boxes = [b for b in boxes if abs(b.position[0] - cx) > 0.45 + 0.225]
    return boxes


def _place(rng: np.random.Generator, objs: list[SceneObject], label: str, size, xr, yr, oid: str,
           keep_from: list[tuple[float, float]], tries: int = 60, yaw: float | None = None) -> SceneObject | None:
    for _ in range(tries):
        x, y = float(rng.uniform(*xr)), float(rng.uniform(*yr))
        if not clear_of(objs, (x, y), max(size[0], size[2]) / 2 + 0.2):
            continue
        o = obj(oid, label, x, y, size, float(rng.uniform(-math.pi, math.pi)) if yaw is None else yaw)
        if not all(clear_of([o], p, KEEP_CLEAR) for p in keep_from):  # the start and the dog stay clear
            continue
        objs.append(o)
        return o
    return None


def random_search_room(seed: int, n: int) -> SearchRoom:
    """Room ``n`` of ``seed`` (see the module docstring)."""
    rng = np.random.default_rng([int(seed), int(n)])
    W = round(float(rng.uniform(5.0, 12.0)) / RES) * RES
    L = round(float(rng.uniform(5.0, 12.0)) / RES) * RES
    ws = Workspace((0.0, 0.0, 0.0), (W, L, HEIGHT), RES)
    shell = ((-SHELL, -SHELL, 0.0), (W + SHELL, L + SHELL, HEIGHT))
    sx = float(rng.uniform(1.0, W - 1.0))
    start = (sx, 0.7, math.pi / 2)
    line_y = float(rng.uniform(max(2.6, 0.4 * L), min(0.65 * L, L - 1.8)))
    layers = int(rng.integers(1, 4))
    kind = "sealed" if n % 17 == 5 else "absent" if n % 25 == 12 else str(rng.choice(KINDS))
    line_kind = str(rng.choice(KINDS)) if kind in ("sealed", "absent") else kind
    objs = _line(rng, line_kind, line_y, W, layers)
    if line_kind == "two_lines" and L - line_y > 3.0:
        y2 = float(rng.uniform(line_y + 1.4, L - 1.2))
        x0 = float(rng.uniform(0.0, W / 2))
        objs += _renamed(box_wall(y2, x0, min(W, x0 + max(1.5, W / 2)), int(rng.integers(1, 4))), "b")
    keep = [(sx, 0.7)]
    target_id: str | None = None
    behind = (line_y + 0.9, L - 0.5)
    if kind != "absent":
        dog = _place(rng, objs, TARGET, TARGET_SIZE, (0.6, W - 0.6), behind, f"{TARGET}-1", keep, tries=200)
        if dog is not None:
            target_id = dog.id
            dx, dy = dog.position[0], dog.position[1]
            keep.append((dx, dy))
            if kind == "sealed":
                h = 8  # 3.2 m: up to the ceiling
                r = 0.75
                objs += box_run(dx - r, dy - r, dx + r, dy - r, h, "s0-") + box_run(dx - r, dy + r, dx + r, dy + r, h, "s1-")
                objs += box_run(dx - r, dy - r, dx - r, dy + r, h, "s2-") + box_run(dx + r, dy - r, dx + r, dy + r, h, "s3-")
            elif rng.random() < 0.5:  # hidden behind furniture too: an occluder between the dog and the line
                label, size = FURNITURE[int(rng.choice([4, 5, 7]))]
                oy = dy - 0.45 - size[0] / 2 - 0.15
                if oy - size[0] / 2 > line_y + 0.35:
                    occ = obj("occluder-1", label, dx, oy, size, 0.0)
                    if clear_of([o for o in objs if o.id != target_id], (dx, oy), max(size) / 2 + 0.05):
                        objs.append(occ)
    want = int(rng.integers(3, 5)) + int(W * L / 20)
    for m in range(want):
        label, size = FURNITURE[int(rng.integers(0, len(FURNITURE)))]
        zone = int(rng.integers(0, 3))
        if zone == 0:
            xr, yr = (0.5, W - 0.5), (1.8, line_y - 0.8)
        elif zone == 1:
            xr, yr = (0.5, W - 0.5), (line_y + 0.8, L - 0.4)
        else:
            xr, yr = (0.4, W - 0.4), (0.3, 1.6)
        _place(rng, objs, label, size, xr, yr, f"{label}-{m}", keep)
    return SearchRoom(f"room{n:02d}-{kind}-{layers}", kind, tuple(objs), ws, shell, start, target_id)


def paper_search_room() -> SearchRoom:
    """The paper's room (the simulator's default world): the robot dog behind the line of boxes."""
    x, y, _ = DEFAULT_START.translation
    return SearchRoom("paper", "paper", paper_room().objects, Workspace(), (ROOM_MIN, ROOM_MAX),
                      (float(x), float(y), math.pi / 2), "robot_dog-1")


def true_grid(room: SearchRoom) -> PlanningGrid:
    """The planner's grid of the true room (every object known, the robot's size)."""
    return build_grid(room.objects, room.workspace, robot=MORPHOGEAR)


def near_target_cells(room: SearchRoom, grid: PlanningGrid) -> np.ndarray:
    """Floor cells ``[K, 3]`` whose centre lies within :data:`NEAR_TARGET` of the target's footprint."""
    t = room.target
    if t is None:
        return np.zeros((0, 3), dtype=np.int64)
    xs, ys, _ = grid.workspace.axes()
    xy = np.stack(np.meshgrid(xs, ys, indexing="ij"), axis=-1).reshape(-1, 2)
    near = (footprint_distance(t, xy) <= NEAR_TARGET + 1e-9).reshape(len(xs), len(ys))
    ij = np.argwhere(near)
    return np.column_stack([ij, np.zeros(len(ij), dtype=np.int64)])


def near_target(room: SearchRoom, p) -> bool:
    """Whether the robot at ``p`` (world [m]) stands on the floor within :data:`NEAR_TARGET` of the target's footprint."""
    t = room.target
    return t is not None and float(p[2]) < 0.01 and \
        float(footprint_distance(t, np.array([[float(p[0]), float(p[1])]]))[0]) <= NEAR_TARGET + 1e-9


def truth(room: SearchRoom) -> Truth:
    """Whether the target can be reached (see :class:`Truth`) and the reference path lengths."""
    if room.target is None:
        return Truth(False, math.inf, math.inf, "no target in the room")
    grid = true_grid(room)
    start = (room.start[0], room.start[1], 0.0)
    cells = near_target_cells(room, grid)
    out = {}
    for name, w in (("cost", CostWeights()), ("m", CostWeights(1.0, 1.0, 1.0, 1.0))):
        route = Route(grid, start, w)
        d = path_costs(grid, route.cost_array, grid.workspace.cell_of(start))
        dc = d[cells[:, 0], cells[:, 1], cells[:, 2]]
        ok = np.isfinite(dc) & np.isfinite(route.cost_array[cells[:, 0], cells[:, 1], cells[:, 2]])
        if not ok.any():
            return Truth(False, math.inf, math.inf, "no floor within 1 m of the target can be reached")
        best = math.inf
        for c in cells[ok][np.argsort(dc[ok])[:4]]:  # the A* (diagonal moves) to the nearest few by face moves
            goal = grid.workspace.centers(c[None])[0]
            res = route.plan(start, (goal[0], goal[1], 0.0))
            if res.ok:
                best = min(best, res.cost)
        out[name] = best
    ground = Route(grid, start).cost_array.copy()
    ground[:, :, 1:] = np.inf
    dg = path_costs(grid, ground, grid.workspace.cell_of(start))
    walk = bool(np.isfinite(dg[cells[:, 0], cells[:, 1], cells[:, 2]]).any())
    return Truth(math.isfinite(out["cost"]), out["m"], out["cost"], "", walk)


__all__ = ["KINDS", "NEAR_TARGET", "SearchRoom", "TARGET", "Truth", "box_run", "near_target_cells", "near_target",
           "paper_search_room", "random_search_room", "true_grid", "truth"]
