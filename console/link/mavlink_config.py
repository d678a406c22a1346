"""Tunables of the MAVLink link: :class:`MavlinkConfig` and the ground-motion command set."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Literal

from console.link.mavlink_commands import copter_modes
from console.link.ned import NedFrame


@dataclass(frozen=True)
class GroundMotion:
    """The ground-motion command set: how WALK segments are sent to the robot.

    ArduPilot Copter cannot walk; on an aerial-ground robot the legs are driven by a limb
    controller that listens on the same MAVLink bus. The default sends position targets at
    ground height (``SET_POSITION_TARGET_LOCAL_NED``, ``z`` = the floor in NED) in GUIDED mode
    with the motors disarmed, to the autopilot component.

    Attributes:
        mode: Autopilot mode set before walking (``None``: leave the mode alone).
        command: ``position`` (position targets at ground height, repeated at the set-point rate)
            or ``velocity`` (horizontal velocity targets of ``speed`` towards the next waypoint).
        speed: Walking speed [m/s]: commanded (``MAV_CMD_DO_CHANGE_SPEED``) and used for time-outs.
        target_component: MAVLink component id that executes ground motion (``None``: the
            autopilot's).
        arm: Arm the vehicle before walking.
    """

    mode: str | None = "GUIDED"
    command: Literal["position", "velocity"] = "position"
    speed: float = 0.3
    target_component: int | None = None
    arm: bool = False

    def __post_init__(self) -> None:
        if self.command not in ("position", "velocity"):
            raise ValueError(f"GroundMotion.command must be 'position' or 'velocity', got {self.command!r}")
        if not (self.speed > 0 and math.isfinite(self.speed)):
            raise ValueError(f"GroundMotion.speed must be > 0 m/s, got {self.speed}")


@dataclass(frozen=True)
class MavlinkConfig:
    """Tunables of the MAVLink link (units in the names).

    Attributes:
        ned: Where the vehicle's local NED frame sits in the world.
        floor: World height of the ground [m]: walking targets and the landed check use it.
        ground: The ground-motion command set.
        flight_mode: Mode for take-off and flight (``GUIDED``).
        land_mode: Mode that lands (``LAND``).
        hold_mode: Mode that stops in the air (``BRAKE``; ``LOITER`` needs a position estimate).
        heartbeat_timeout: Vehicle heartbeat silence after which ``link_ok`` is False [s].
        pose_timeout: No valid LOCAL_POSITION_NED for this long makes the pose stale [s].
        ack_timeout: Wait for one COMMAND_ACK [s].
        retries: Re-sends of an unacknowledged command.
        command_max_age: No command is (re-)sent later than this after it was decided [s].
        nack_window: A refusal's reasons are the vehicle's lines up to this long after it [s].
        setpoint_rate: Position / velocity target re-send rate [Hz].
        position_tolerance: A waypoint counts as reached within this distance [m].
        altitude_tolerance: Take-off height reached within this [m].
        still_speed: The vehicle counts as stopped below this speed [m/s] (holds, landings).
        settle_timeout: Longest wait for the vehicle to stop after a hold / before a landing [s].
        ready_timeout: Longest wait of a take-off for the vehicle's readiness [s].
        fly_speed: Commanded horizontal flight speed (MAV_CMD_DO_CHANGE_SPEED) [m/s].
        climb_rate: Commanded climb rate [m/s].
        descent_rate: Commanded descent rate [m/s].
        timeout_factor: Motion time-out = expected time x this + ``timeout_slack``.
        timeout_slack: [s].
        face_travel: Send a yaw with flight targets so the camera looks where the robot goes.
        state_rate: State stream rate [Hz].
        source_system: Our MAVLink system id (255: a GCS).
        source_component: Our component id (190: MAV_COMP_ID_MISSIONPLANNER).
        autopilot_component: The autopilot's component id (1; ``None``: any non-peripheral).
        message_rate: Rate requested for LOCAL_POSITION_NED / ATTITUDE / EXTENDED_SYS_STATE /
            SYS_STATUS [Hz] (0 leaves the vehicle's stream rates alone).
        max_range: Largest plausible |local NED coordinate| [m]; beyond is invalid telemetry.
        max_speed: Largest plausible velocity component [m/s].
        vehicle_max_speed: Fastest the vehicle really moves [m/s]: a position step faster than this
            between two samples is an estimator jump (hold and pause).
        brake_decel: The vehicle's braking deceleration [m/s^2]: the stopping distance at speed v is
            v^2 / (2 brake_decel) (a pause stops within it; so does the end of a segment).
        overspeed_factor: The vehicle flying faster than the commanded speed x this (+ 0.15 m/s) for
            0.5 s is overspeed: the speed is sent again, then the vehicle is held.
        max_loss: Packet loss above which the link is too poor to fly (a readiness reason), in [0, 1].
        max_rtt: Round-trip time above which the link is too poor to fly [s].
        signing_key: MAVLink 2 signing passphrase (``--mavlink-key``; SHA-256 gives the 32-byte key, as
            MAVProxy's ``signing setup``) or 64 hex digits (the key itself); ``None``: unsigned.
    """

    ned: NedFrame = field(default_factory=NedFrame)
    floor: float = 0.0
    ground: GroundMotion = field(default_factory=GroundMotion)
    flight_mode: str = "GUIDED"
    land_mode: str = "LAND"
    hold_mode: str = "BRAKE"
    heartbeat_timeout: float = 3.0
    pose_timeout: float = 1.5
    ack_timeout: float = 1.5
    retries: int = 3
    command_max_age: float = 5.0
    nack_window: float = 0.5
    setpoint_rate: float = 4.0
    position_tolerance: float = 0.15
    altitude_tolerance: float = 0.1
    still_speed: float = 0.1
    settle_timeout: float = 8.0
    ready_timeout: float = 60.0
    fly_speed: float = 0.5
    climb_rate: float = 0.5
    descent_rate: float = 0.3
    timeout_factor: float = 3.0
    timeout_slack: float = 10.0
    face_travel: bool = True
    state_rate: float = 20.0
    source_system: int = 255
    source_component: int = 190
    autopilot_component: int | None = 1
    message_rate: float = 10.0
    max_range: float = 10_000.0
    max_speed: float = 50.0
    vehicle_max_speed: float = 15.0
    brake_decel: float = 2.5
    overspeed_factor: float = 1.3
    max_loss: float = 0.2
    max_rtt: float = 0.5
    signing_key: str | None = field(default=None, repr=False)

    def stopping_distance(self, speed: float) -> float:
        """Braking distance from ``speed`` [m/s]: v^2 / (2 ``brake_decel``) [m]."""
        return speed * speed / (2.0 * self.brake_decel)

    def __post_init__(self) -> None:
        modes = copter_modes()
        for name in ("flight_mode", "land_mode", "hold_mode"):
            if getattr(self, name) not in modes:
                raise ValueError(f"MavlinkConfig.{name}: unknown ArduPilot Copter mode {getattr(self, name)!r}")
        if self.ground.mode is not None and self.ground.mode not in modes:
            raise ValueError(f"GroundMotion.mode: unknown ArduPilot Copter mode {self.ground.mode!r}")
        for name in ("heartbeat_timeout", "pose_timeout", "ack_timeout", "command_max_age", "setpoint_rate",
                     "position_tolerance", "altitude_tolerance", "still_speed", "settle_timeout", "ready_timeout",
                     "fly_speed", "climb_rate", "descent_rate", "state_rate", "max_range", "max_speed",
                     "vehicle_max_speed", "brake_decel", "overspeed_factor", "max_rtt"):
            v = getattr(self, name)
            if not (v > 0 and math.isfinite(v)):
                raise ValueError(f"MavlinkConfig.{name} must be > 0, got {v}")
        for name in ("nack_window", "message_rate", "timeout_slack", "timeout_factor"):
            v = getattr(self, name)
            if not (v >= 0 and math.isfinite(v)):
                raise ValueError(f"MavlinkConfig.{name} must be >= 0, got {v}")
        if not (0.0 <= self.max_loss <= 1.0):
            raise ValueError(f"MavlinkConfig.max_loss must be in [0, 1], got {self.max_loss}")
        if self.signing_key is not None and not str(self.signing_key).strip():
            raise ValueError("MavlinkConfig.signing_key: must not be empty (leave it unset for no signing)")
        if self.retries < 0:
            raise ValueError(f"MavlinkConfig.retries must be >= 0, got {self.retries}")


__all__ = ["MavlinkConfig", "GroundMotion"]
