"""One description of the robot's size, used by every planning rule (configuration space, goal
check, own cells, viewpoints, the workspace's edge: :func:`planner.cspace.edge_closed` keeps
``radius`` / ``flying_radius`` from its walls and, flying, ``max(flying_radius, height)`` from its top).

Frames and units: world frame (z up), metres, radians. The robot walking is a vertical cylinder
of :attr:`RobotModel.radius` around its origin from the floor up to :attr:`RobotModel.height`; in
the air it is a sphere of :attr:`RobotModel.flying_radius` around its origin (the propellers'
disc with a safety margin, taken round for simplicity) and, with :attr:`RobotModel.flying_height`,
the vertical cylinder of that radius from the origin up to that height (:mod:`planner.flight_body`).

MorphoGear's defaults (:data:`MORPHOGEAR`). The paper (``morphonavi-paper.tex``, "MorphoGear:
Aerial-Ground Robot") names the robot, its hardware and its camera but gives **no dimensions**; the
figures below are the project's own, in one place:

- ``radius = 0.35`` m: the planner's robot radius since the first console (``--margin``, "a 0.7 m
  robot" in the issue that made it a hard limit); the simulator's body is 0.25 m with this adding
  a safety margin (``SimConfig.body_radius``);
- ``height = 0.45`` m: the simulator's body height (``SimConfig.body_height``); the camera sits
  0.35 m up on the default mount (``CameraMount.position``), below the body's top;
- ``flying_radius = 0.35`` m: as walking (the legs fold under the rotors);
- ``camera_height = 0.35`` m and ``camera_half_vfov = 0.42`` rad: the default camera mount and the
  simulated 640 x 480 camera (fy = 525 px: vertical field of view 49 degrees); used to pick
  viewpoints that can see a point.
"""

from __future__ import annotations

import math
from dataclasses import dataclass


class RobotModelError(ValueError):
    """A robot dimension is not a finite number in range; the message names it."""


@dataclass(frozen=True)
class RobotModel:
    """The robot's size for planning [m].

    Attributes:
        radius: Footprint radius when walking [m]: no walking route passes closer to an obstacle.
        height: Height of the walking body [m]: the space up to it over a walked cell must be free.
        flying_radius: Radius in the air [m]: no flight passes closer to an obstacle.
        camera_height: Camera height above the floor when standing [m] (viewpoints).
        camera_half_vfov: Half the camera's vertical field of view [rad] (viewpoints).
        flying_height: Height above its origin [m] the flying body keeps clear (:mod:`planner.flight_body`;
            0: the flying-radius sphere only, the default until the look chain is tuned for it; the
            simulator's body is 0.45 m tall).
        mapping_margin: Grow mapped objects by their mapping margin (:mod:`planner.map_uncertainty`;
            off by default until the look chain is tuned for it).
    """

    radius: float = 0.35
    height: float = 0.45
    flying_radius: float = 0.35
    camera_height: float = 0.35
    camera_half_vfov: float = 0.42
    flying_height: float = 0.0
    mapping_margin: bool = False

    def __post_init__(self) -> None:
        if not isinstance(self.mapping_margin, bool):
            raise RobotModelError(f"robot.mapping_margin: must be true or false, got {self.mapping_margin!r}")
        for name, lo, hi in (("radius", 0.0, 5.0), ("height", 0.0, 5.0), ("flying_radius", 0.0, 5.0),
                             ("camera_height", 0.0, 5.0), ("camera_half_vfov", 0.0, math.pi / 2),
                             ("flying_height", 0.0, 5.0)):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
                raise RobotModelError(f"robot.{name}: must be a finite number, got {v!r}")
            if not lo <= v <= hi:
                raise RobotModelError(f"robot.{name}: must be within {lo:g}..{hi:g}, got {v}")

    @staticmethod
    def with_radius(radius: float) -> "RobotModel":
        """MorphoGear's model with another radius for walking and flying (the ``--margin`` option)."""
        return RobotModel(radius=radius, flying_radius=radius)

    def describe(self) -> str:
        return (f"robot radius {self.radius:.2f} m walking (height {self.height:.2f} m), "
                f"{self.flying_radius:.2f} m flying")


MORPHOGEAR = RobotModel()
"""MorphoGear's defaults (see the module docstring for where each comes from)."""

__all__ = ["MORPHOGEAR", "RobotModel", "RobotModelError"]
