"""Which mapped object closes a planning cell for the robot's size, and by how much: for messages.

World frame (z up) [m]. A cell is closed for clearance (:attr:`planner.grid.Closed.CLEARANCE`) when the
robot's body at its centre comes within an object's mapping margin (:mod:`planner.map_uncertainty`) of
the object's box: walking, the footprint (``robot.radius`` in plan) against the boxes that overlap the
body's height; flying, the body of :mod:`planner.flight_body` (sphere and height above).
"""

from __future__ import annotations

from typing import Any, Sequence

import numpy as np

from pipeline.scene import SceneObject
from planner.cspace import box_distance
from planner.flight_body import body_gap
from planner.map_uncertainty import object_margin


def crowding(grid: Any, cell: Sequence[int]) -> tuple[SceneObject, float, float] | None:
    """The mapped object of ``grid`` (a :class:`planner.grid.PlanningGrid`) that closes ``cell``, the
    nearest first, as ``(object, gap, margin)``: ``gap`` [m] between the robot's body at the cell centre
    and the object's box as mapped (0 when they touch), ``margin`` [m] the object's mapping margin (the
    cell is closed because ``gap <= margin``). ``None`` when no object does (another obstacle closes it)."""
    ws, robot = grid.workspace, grid.robot
    c = ws.centers(np.array([cell]))[0]
    best: tuple[SceneObject, float, float] | None = None
    for o in grid.objects:
        pad = object_margin(o) if getattr(robot, "mapping_margin", False) else 0.0
        if int(cell[2]) == 0:
            lo, hi = o.position[2] - o.size[1] / 2, o.position[2] + o.size[1] / 2
            if hi <= ws.floor or lo >= ws.floor + robot.height:
                continue
            gap = float(box_distance(o, c[None, :], horizontal=True)[0]) - robot.radius
            closes = gap <= pad + 1e-9
        else:
            gap = body_gap(o, c, robot)
            closes = gap <= 1e-9 or (pad > 0 and body_gap(o, c, robot, pad) <= 1e-9)
        if closes and (best is None or gap < best[1]):
            best = (o, max(gap, 0.0), pad)
    return best


__all__ = ["crowding"]
