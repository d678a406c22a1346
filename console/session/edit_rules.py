"""Rules that keep the map possible: no object where the robot's body is.

The body is :class:`planner.robot_model.RobotModel`'s walking cylinder: ``radius`` around the robot's
origin, from its origin's height up ``height`` (world frame, z up, metres, radians). Each way an object
comes into the map meets it by what the operator would expect:

- **Move** (typed or dragged) onto the robot is refused, naming the object, the robot's position and its
  radius (:func:`check_clear_of_robot`), so a route never starts inside an object.
- **A capture** never sees the body of the robot it is on: an object it maps over the robot's reported
  pose is a perception error, dropped before the merge with a notice naming it (:func:`drop_over_robot`).
- **A scene file or a loaded session** is the operator's word: opened as it is, with a warning naming
  the object; Execute stays off while any object overlaps the robot (:func:`robot_overlap_blocker`,
  the mission panel says why) until it is moved or deleted (or the robot's position is corrected).
"""

from __future__ import annotations

import math
from typing import Sequence

from pipeline.scene import Scene, SceneObject
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


def reported_position(robot: RobotSnapshot | None) -> tuple[float, float, float] | None:
    """The robot's reported origin (world [m]), ``None`` while no position was ever reported."""
    if robot is None or not math.isfinite(robot.pose_age):
        return None
    x, y, z = (float(v) for v in robot.pose.translation)
    return x, y, z


def objects_on_robot(objects: Sequence[SceneObject], robot_xyz: Sequence[float],
                     model: RobotModel = MORPHOGEAR) -> list[SceneObject]:
    """The world-frame objects whose box overlaps the robot's body at ``robot_xyz`` (world [m]), in order."""
    return [o for o in objects if o.frame == "world" and box_overlaps_body(o.position, o.size, o.yaw, robot_xyz, model)]


def _names(objs: Sequence[SceneObject]) -> str:
    return ", ".join(f"{o.label.replace('_', ' ')} '{o.id}'" for o in objs)


def drop_over_robot(scene: Scene, robot: RobotSnapshot | None, what: str,
                    model: RobotModel = MORPHOGEAR) -> tuple[Scene, str | None]:
    """``scene`` (a capture's objects, ``what`` names it) without the objects over the robot's body at its
    reported pose, and the operator's words for what was dropped (``None``: nothing was; no pose: nothing)."""
    at = reported_position(robot)
    bad = objects_on_robot(scene.objects, at, model) if at is not None else []
    if not bad:
        return scene, None
    ids = {o.id for o in bad}
    verb = "was" if len(bad) == 1 else "were"
    text = (f"{what}: {_names(bad)} mapped over the robot's own body at ({at[0]:.2f}, {at[1]:.2f}) "  # type: ignore[index]
            f"({model.radius:.2f} m radius) {verb} not added: a camera cannot see the robot it is on, so it is a "
            "perception error")
    return scene.with_objects([o for o in scene.objects if o.id not in ids]), text


def robot_overlap_blocker(objects: Sequence[SceneObject], robot: RobotSnapshot | None,
                          model: RobotModel = MORPHOGEAR) -> str | None:
    """Why Execute is off while a mapped object overlaps the robot's body at its reported pose (a scene
    file or a loaded session put it there), or ``None``."""
    at = reported_position(robot)
    bad = objects_on_robot(objects, at, model) if at is not None else []
    if not bad:
        return None
    verb = "overlaps" if len(bad) == 1 else "overlap"
    return (f"{_names(bad)} {verb} the robot at ({at[0]:.2f}, {at[1]:.2f}) ({model.radius:.2f} m radius): move or "  # type: ignore[index]
            "delete it (or correct the robot's position) before running a mission")


__all__ = ["box_overlaps_body", "check_clear_of_robot", "drop_over_robot", "objects_on_robot", "reported_position",
           "robot_overlap_blocker", "robot_position"]
