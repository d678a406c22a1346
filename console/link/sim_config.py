"""The simulated robot's settings: :class:`SimConfig` (speeds, rates, failsafes) and its camera.

Units are in the attribute names' docs (metres, seconds, radians); the camera mount is in the
robot body frame (x forward, y left, z up). Re-exported by :mod:`console.link.sim`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from pipeline.camera.geometry import CameraMount, Intrinsics
from planner.grid import Workspace

DEFAULT_INTRINSICS = Intrinsics(525.0, 525.0, 319.5, 239.5, 640, 480)
"""The simulated camera: 640 x 480, 62 degrees horizontal field of view."""

DEFAULT_MOUNT = CameraMount(position=(0.15, 0.0, 0.35), pitch=0.0)
"""Camera on the simulated robot (robot body frame), looking straight ahead."""


@dataclass(frozen=True)
class SimConfig:
    """Kinematics and timing of the simulated robot (units in the names).

    Attributes:
        walk_speed: Walking speed [m/s].
        fly_speed: Horizontal / straight-line flight speed [m/s].
        climb_rate: Take-off climb rate [m/s].
        descent_rate: Landing descent rate [m/s].
        yaw_rate: Turn rate [rad/s] (the robot turns to face where it goes).
        spool_time: Arming to lift-off [s].
        settle_time: Touch-down to disarmed [s].
        rate: State publication and integration rate [Hz].
        time_scale: Simulated seconds per wall-clock second (> 1 runs faster).
        start_tolerance: How far a segment's first waypoint may be from the robot [m].
        drain_idle: Battery fraction used per second standing [1/s].
        drain_walk: ... walking [1/s].
        drain_fly: ... in the air [1/s].
        workspace: Bounds the robot may not leave and the occupancy resolution.
        link_loss_hold: During a link outage the robot holds (ends its segment) after this [s].
        link_loss_land: ... and lands where it is after this [s] (its own failsafe).
        battery_critical: On-board battery failsafe (like ArduPilot's ``BATT_CRT_VOLT`` with
            ``BATT_FS_CRT_ACT`` = Land): at or below this charge [0..1] in the air the robot ends its
            segment and lands where it is by itself (mode ``failsafe``, status message "battery
            critical: landing"); 0 disables it. Tests reach it quickly with a high ``drain_*`` rate or
            :meth:`~console.link.sim.SimRobot.set_battery`.
        body_radius: The robot's body in plan: a circle of this radius [m] around its origin. A
            motion stops where the body would touch a hidden object ("contact with an unmapped
            obstacle ahead at (x, y, z)"). Smaller than the planner's robot radius (0.35 m), which
            adds a safety margin to the body.
        body_height: The body's height above its origin [m] (the origin is on the floor when the
            robot walks; the camera sits 0.35 m up).
    """

    walk_speed: float = 0.4
    fly_speed: float = 0.8
    climb_rate: float = 0.5
    descent_rate: float = 0.4
    yaw_rate: float = math.radians(120.0)
    spool_time: float = 1.0
    settle_time: float = 0.5
    rate: float = 50.0
    time_scale: float = 1.0
    start_tolerance: float = 0.3
    drain_idle: float = 1e-5
    drain_walk: float = 2e-4
    drain_fly: float = 2e-3
    workspace: Workspace = field(default_factory=Workspace)
    link_loss_hold: float = 1.0
    link_loss_land: float = 10.0
    battery_critical: float = 0.10
    body_radius: float = 0.25
    body_height: float = 0.45

    def __post_init__(self) -> None:
        for name in ("walk_speed", "fly_speed", "climb_rate", "descent_rate", "yaw_rate", "time_scale",
                     "start_tolerance", "body_radius", "body_height"):
            v = getattr(self, name)
            if not (isinstance(v, (int, float)) and math.isfinite(v) and v > 0):
                raise ValueError(f"SimConfig.{name} must be a positive number, got {v!r}")
        for name in ("spool_time", "settle_time", "drain_idle", "drain_walk", "drain_fly", "link_loss_hold",
                     "link_loss_land"):
            v = getattr(self, name)
            if not (isinstance(v, (int, float)) and math.isfinite(v) and v >= 0):
                raise ValueError(f"SimConfig.{name} must be >= 0, got {v!r}")
        b = self.battery_critical
        if not (isinstance(b, (int, float)) and math.isfinite(b) and 0.0 <= b < 1.0):
            raise ValueError(f"SimConfig.battery_critical must be within 0..1, got {b!r}")
        if not 20.0 <= self.rate <= 1000.0:
            raise ValueError(f"SimConfig.rate must be within 20..1000 Hz, got {self.rate}")



__all__ = ["SimConfig", "DEFAULT_INTRINSICS", "DEFAULT_MOUNT"]
