"""Rules an operator's edit of the map must keep: no object is put where the robot stands.

An edit (today: Move, typed or dragged) whose box would overlap the robot's body at its current pose is
refused with the object, the robot's position and its radius named, so a route never starts inside an
object. The body is :class:`planner.robot_model.RobotModel`'s walking cylinder: ``radius`` around the
robot's origin, from its origin's height up ``height`` (world frame, z up, metres, radians).
"""

from __future__ import annotations

import math
from typing import Sequence

from pipeline.scene import SceneObject
from planner.robot_model import MORPHOGEAR, RobotModel

from console.session.session_types import RobotSnapshot, SessionError


def box_overlaps_body(centre: Sequence[float], size: Sequence[float], yaw: float,
                      robot_xyz: Sequence[float], model: RobotModel = MORPHOGEAR) -> bool:
    """Whether an oriented box overlaps the robot's body cylinder (touching is not overlapping).

    Args:
        centre: Box centre ``(x, y, z)``, world [m].
        size: ``(w, h, l)`` full extents [m], ``h`` vertical, ``l`` along ``yaw``.
        yaw: Heading of the box's length axis about +z [rad].
        robot_xyz: The robot's origin, world [m] (on the floor when walking).
        model: The robot's size (``radius``, ``height``).
    """
    w, h, length = (float(v) for v in size)
    cz, rz = float(centre[2]), float(robot_xyz[2])
    if not (cz - h / 2 < rz + model.height and cz + h / 2 > rz):
        return False
    dx, dy = float(robot_xyz[0]) - float(centre[0]), float(robot_xyz[1]) - float(centre[1])
    c, s = math.cos(yaw), math.sin(yaw)
    along, across = dx * c + dy * s, -dx * s + dy * c  # the robot in the box's frame
    ex = max(abs(along) - length / 2, 0.0)
    ey = max(abs(across) - w / 2, 0.0)
    return math.hypot(ex, ey) < model.radius


def robot_position(robot: RobotSnapshot | None, start: Sequence[float]) -> tuple[float, float, float]:
    """Where the robot stands (world [m]): its reported pose, or the route's ``start`` while no position
    was ever reported (no link yet, or ``pose_age`` infinite)."""
    if robot is None or not math.isfinite(robot.pose_age):
        return float(start[0]), float(start[1]), float(start[2])
    x, y, z = (float(v) for v in robot.pose.translation)
    return x, y, z


def check_clear_of_robot(obj: SceneObject, robot_xyz: Sequence[float], model: RobotModel = MORPHOGEAR) -> None:
    """Refuse ``obj`` (as it would be after the edit) when its box overlaps the robot's body at ``robot_xyz``.

    Raises:
        SessionError: ``cannot move desk-1 there: it would overlap the robot at (2.50, 0.70) (0.35 m
            radius): move the robot first or choose another place``.
    """
    x, y = float(robot_xyz[0]), float(robot_xyz[1])
    if box_overlaps_body(obj.position, obj.size, obj.yaw, robot_xyz, model):
        raise SessionError(f"cannot move {obj.id} there: it would overlap the robot at ({x:.2f}, {y:.2f}) "
                           f"({model.radius:.2f} m radius): move the robot first or choose another place")


__all__ = ["box_overlaps_body", "check_clear_of_robot", "robot_position"]
