"""The simulator's default hidden world: the paper's experiment room.

The room of the paper's search-and-rescue test, in the world frame (z up) [m]: the 5 x 8 x 3 m
planning workspace spans ``(0, 0, 0)``-``(5, 8, 3)``. A line of stacked cardboard boxes (three
high, 1.2 m) crosses it from wall to wall at ``y = 4 m``; a robot dog hides behind it at
``y = 6.3 m``. Two desks, two office chairs, two suitcases and a compressor stand in front of the
line (facing the robot's start), an office cabinet and a sports mat behind it. The robot starts at ``(2.5, 0.7, 0)`` facing
+y (towards the line).

Labels are catalog class names; sizes are the real objects' ``(w, h, l)`` [m] (close to, not
equal to, the catalog's typical sizes, as real objects are). The operator does not see this
scene: the simulator renders it and the console must map it.
"""

from __future__ import annotations

import math

from pipeline.camera.geometry import Pose
from pipeline.scene import Scene, SceneObject, Source

ROOM_MIN: tuple[float, float, float] = (0.0, -1.0, 0.0)
"""Room walls / floor corner [m] (world frame); the room is larger than the workspace in y."""

ROOM_MAX: tuple[float, float, float] = (5.0, 9.0, 4.0)
"""Room walls / ceiling corner [m] (world frame)."""

DEFAULT_START: Pose = Pose.from_xyz_yaw(2.5, 0.7, 0.0, math.pi / 2)
"""Where the simulated robot starts: ``world <- robot``, on the floor facing +y."""

SEARCH_GOAL: tuple[float, float, float] = (2.5, 5.7, 0.0)
"""A floor spot in front of the hidden robot dog [m] (world frame)."""

BOX_SIZE: tuple[float, float, float] = (0.45, 0.40, 0.45)
"""One cardboard box ``(w, h, l)`` [m]."""

BOX_LINE_Y = 4.0
"""Centre line of the box wall [m] (world y)."""


def _obj(oid: str, label: str, x: float, y: float, size: tuple[float, float, float],
         yaw: float = 0.0, z0: float = 0.0) -> SceneObject:
    """An object standing at ``(x, y)`` with its bottom at height ``z0`` [m]."""
    return SceneObject(oid, label, (x, y, z0 + size[1] / 2), size, yaw, "world",
                       source=Source(method="ground_truth"))


def box_wall(y: float = BOX_LINE_Y, x_min: float = 0.0, x_max: float = 5.0,
             layers: int = 3) -> list[SceneObject]:
    """Cardboard boxes stacked ``layers`` high in a line along x at ``y``, wall to wall.

    Columns are 0.45 m wide and spread over ``[x_min, x_max]`` with the left-over centimetres
    shared out as gaps narrower than one planning cell; upper boxes get a small deterministic
    offset and twist so the stack does not look machine-made.
    """
    w, h, l = BOX_SIZE
    n = int((x_max - x_min) // l)
    if n < 1:
        raise ValueError(f"a box wall needs at least {l} m, got {x_max - x_min:.2f} m")
    gap = (x_max - x_min - n * l) / n
    out: list[SceneObject] = []
    for c in range(n):
        cx = x_min + gap / 2 + l / 2 + c * (l + gap)
        for k in range(layers):
            jitter = ((c * 7 + k * 3) % 5 - 2) * 0.01  # -2..2 cm
            twist = ((c * 5 + k * 11) % 7 - 3) * math.radians(1.5)
            out.append(_obj(f"box-{c}-{k}", "cardboard_box", cx + (jitter if k else 0.0),
                            y + (jitter / 2 if k else 0.0), BOX_SIZE, twist if k else 0.0, z0=k * h))
    return out


def paper_room() -> Scene:
    """The hidden ground-truth scene of the paper's experiment (world frame)."""
    face_robot = -math.pi / 2  # front towards the start (-y)
    objects = [
        _obj("desk-1", "desk", 1.2, 2.95, (1.40, 0.75, 0.70), face_robot),
        _obj("office_chair-1", "office_chair", 1.45, 2.3, (0.62, 1.05, 0.62), face_robot + 0.4),
        _obj("desk-2", "desk", 3.9, 2.95, (1.20, 0.74, 0.60), face_robot),
        _obj("office_chair-2", "office_chair", 3.6, 2.3, (0.60, 1.00, 0.60), face_robot - 0.3),
        _obj("suitcase-1", "suitcase", 1.55, 3.5, (0.45, 0.68, 0.27), 0.2),
        _obj("suitcase-2", "suitcase", 3.4, 3.55, (0.40, 0.56, 0.24), -0.15),
        _obj("compressor-1", "compressor", 3.3, 1.6, (0.35, 0.50, 0.45), 0.5),
        _obj("office_cabinet-1", "office_cabinet", 4.75, 6.2, (0.80, 1.85, 0.42), math.pi),
        _obj("sports_mat-1", "sports_mat", 0.8, 7.3, (1.00, 0.05, 1.00), 0.0),
        _obj("robot_dog-1", "robot_dog", 2.5, 6.3, (0.28, 0.40, 0.645), math.pi / 2),
    ]
    objects += box_wall()
    return Scene(objects=tuple(objects))


__all__ = ["paper_room", "box_wall", "DEFAULT_START", "SEARCH_GOAL", "ROOM_MIN", "ROOM_MAX",
           "BOX_SIZE", "BOX_LINE_Y"]
