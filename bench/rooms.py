"""Seeded random rooms for the benchmarks (shared by ``bench/known_space.py`` and ``bench/search.py``).

World frame (z up) [m], the paper's 5 x 8 x 3 m workspace at 0.25 m (:data:`WS`), the room shell
beyond it. Each room holds a line or wall of cardboard boxes across it (wall to wall, with gaps
narrower and wider than the robot, or with an open end), catalog furniture in front of and behind
it, and objects beside or behind the robot's start (outside the first view). The robot stands at
``y = 0.7`` facing +y. :func:`random_room` draws one from a generator; :func:`paper` is the paper's
room with floor goals behind its line.

Import with the repository root on ``sys.path`` (``from bench.rooms import random_room``); the
``bench`` folder itself must stay off it (``bench/planner.py`` would shadow the planner package).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from console.link.world import DEFAULT_START, box_wall, paper_room
from pipeline.scene import Scene, SceneObject, Source
from planner.cspace import box_distance
from planner.grid import Workspace

WS = Workspace()
"""The paper's workspace: 5 x 8 x 3 m at 0.25 m."""
RADIUS = 0.35
"""The planner's robot radius [m]."""
FURNITURE = [("desk", (0.7, 0.75, 1.3)), ("office_chair", (0.6, 1.0, 0.6)), ("suitcase", (0.45, 0.65, 0.27)),
             ("compressor", (0.35, 0.5, 0.45)), ("office_cabinet", (0.42, 1.85, 0.8)), ("robot_dog", (0.28, 0.4, 0.645)),
             ("cardboard_box", (0.45, 0.4, 0.45))]
"""Catalog classes and their ``(w, h, l)`` sizes [m]."""


def obj(oid: str, label: str, x: float, y: float, size, yaw: float = 0.0, z0: float = 0.0) -> SceneObject:
    """A ground-truth object standing at ``(x, y)`` [m] with its bottom at ``z0`` [m] (world frame)."""
    return SceneObject(oid, label, (x, y, z0 + size[1] / 2), tuple(size), yaw, "world", source=Source(method="ground_truth"))


@dataclass
class Room:
    """A hidden room: its objects, the robot's start ``(x, y)`` [m], the line's y [m] and floor goals [m]."""

    name: str
    scene: Scene
    start: tuple[float, float]
    line_y: float
    goals: list[tuple[float, float, float]] = field(default_factory=list)


def clear_of(objs: list[SceneObject], xy: tuple[float, float], r: float) -> bool:
    """Whether ``xy`` [m] lies farther than ``r`` [m] (in plan) from every object's box."""
    p = np.array([[xy[0], xy[1], 0.0]])
    return all(box_distance(o, p, horizontal=True)[0] > r for o in objs)


def random_room(rng: np.random.Generator, n: int) -> Room:
    """Room ``n`` of the paper's size, drawn from ``rng`` (line, furniture, three goals behind the line)."""
    line_y = float(rng.uniform(3.3, 4.7))
    layers = int(rng.integers(1, 4))
    kind = str(rng.choice(["wall", "gaps", "open_end"]))
    boxes = box_wall(line_y, 0.0, 5.0, layers)
    if kind == "gaps":
        for g in range(int(rng.integers(1, 3))):
            width = float(rng.choice([0.3, 0.5, 0.6, 0.9, 1.2]))
            cx = float(rng.uniform(0.8, 4.2))
            boxes = [b for b in boxes if abs(b.position[0] - cx) > width / 2 + 0.225]
    elif kind == "open_end":
        cut = float(rng.uniform(0.8, 1.6))
        left = bool(rng.integers(0, 2))
        boxes = [b for b in boxes if (b.position[0] > cut if left else b.position[0] < 5.0 - cut)]
    sx = float(rng.uniform(1.5, 3.5))
    objs = list(boxes)
    placed = 0
    tries = 0
    want = int(rng.integers(3, 7))
    while placed < want and tries < 200:
        tries += 1
        label, size = FURNITURE[int(rng.integers(0, len(FURNITURE)))]
        zone = rng.integers(0, 3)  # 0 in front, 1 behind, 2 beside / behind the robot (outside the first view)
        if zone == 0:
            x, y = rng.uniform(0.4, 4.6), rng.uniform(1.6, line_y - 0.8)
        elif zone == 1:
            x, y = rng.uniform(0.4, 4.6), rng.uniform(line_y + 0.8, 7.6)
        else:
            x, y = rng.choice([rng.uniform(0.3, max(0.4, sx - 1.3)), rng.uniform(min(4.6, sx + 1.3), 4.7)]), \
                rng.uniform(0.2, 1.5)
        o = obj(f"{label}-{placed}", label, float(x), float(y), size, float(rng.uniform(-math.pi, math.pi)))
        if not clear_of(objs, (float(x), float(y)), max(size) / 2 + 0.2) or math.dist((x, y), (sx, 0.7)) < 1.0:
            continue
        objs.append(o)
        placed += 1
    room = Room(f"room{n:02d}-{kind}-{layers}", Scene(objects=tuple(objs)), (sx, 0.7), line_y)
    room.goals = goals_behind(rng, objs, line_y)
    return room


def goals_behind(rng: np.random.Generator, objs: list[SceneObject], line_y: float, k: int = 3) -> list[tuple[float, float, float]]:
    """Up to ``k`` floor cell centres [m] behind the line, free for the robot's radius."""
    out: list[tuple[float, float, float]] = []
    for _ in range(400):
        if len(out) == k:
            break
        x, y = float(rng.uniform(0.5, 4.5)), float(rng.uniform(line_y + 0.9, 7.6))
        cell = WS.cell_of((x, y, 0.0))
        c = WS.centers(np.array([cell]))[0]
        if clear_of(objs, (c[0], c[1]), RADIUS + 0.05):
            out.append((float(c[0]), float(c[1]), 0.0))
    return out


def paper() -> Room:
    """The paper's room (its line at y = 4 m) with three floor goals behind the line."""
    scene = paper_room()
    x, y, _ = DEFAULT_START.translation
    rng = np.random.default_rng(1234)
    room = Room("paper", scene, (float(x), float(y)), 4.0)
    room.goals = [(2.625, 5.625, 0.0)] + goals_behind(rng, list(scene.objects), 4.0, 2)
    return room


__all__ = ["FURNITURE", "RADIUS", "Room", "WS", "clear_of", "goals_behind", "obj", "paper", "random_room"]
