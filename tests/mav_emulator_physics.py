"""Motion and flight modes of the ArduCopter emulator (:class:`~mav_emulator.ArduCopterEmulator` mixes
this in): what the vehicle does in each mode, as ArduPilot Copter does it.

Read from the firmware (ArduPilot/ardupilot), never copied:

- ``ArduCopter/mode_guided.cpp``: GUIDED starts in velocity control; the first position target after
  that (or after a take-off or velocity control) starts position control (``pos_control_start`` ->
  ``pva_control_start``), which sets the horizontal speed back to the default ``WPNAV_SPEED``; a
  ``MAV_CMD_DO_CHANGE_SPEED`` (``set_speed_xy``) changes the speed of the controller running now, so a
  speed sent *before* the first position target is lost;
- ``ArduCopter/GCS_Mavlink.cpp`` (``handle_message_set_position_target_local_ned``) and
  ``mode_guided.cpp``: the frames and type masks GUIDED takes, an invalid one stops the vehicle
  (``init(true)``), a velocity target not renewed within ``GUID_TIMEOUT`` (3 s) is zeroed;
- ``ArduCopter/mode_rtl.cpp``: RTL climbs to ``RTL_ALT`` (or stays higher if already above it), returns
  to home at the waypoint speed, descends and lands (then disarms);
- ``ArduCopter/mode_land.cpp`` / ``mode_brake.cpp``: LAND descends while the horizontal motion decays,
  BRAKE stops at a fixed deceleration.

Frames: the vehicle's local NED [m, m/s]; times [s].
"""

from __future__ import annotations

import math
import time
from typing import Any

from pymavlink import mavutil

mav = mavutil.mavlink

RETURNING = ("RTL", "SMART_RTL")
"""Modes that fly home by themselves (SMART_RTL retraces the path; here it flies straight home)."""


class CopterPhysics:
    """Mode changes, targets and motion integration (state lives in the emulator)."""

    # the emulator's state (NED); annotated for readers
    mode: str
    landed_state: int
    pos: list[float]
    vel: list[float]
    target: list[float] | None
    vtarget: list[float] | None
    cmd_speed: float | None
    guided_sub: str  # "vel" (GUIDED just entered), "pos", "takeoff"
    rtl_stage: str  # "climb", "return", "descend"
    ground_down: float  # NED z of the ground under the vehicle [m] (a raised floor: negative)
    params: dict[str, float]
    record: Any

    def _enter_mode(self, name: str, by: str = "gcs") -> None:
        """Switch mode (``by``: ``gcs`` for a MAVLink command, else the vehicle's own reason)."""
        self.mode = name
        self.record.modes.append(name)
        self.record.mode_times.append((name, time.monotonic()))
        self.record.mode_positions.append((name, (self.pos[0], self.pos[1], self.pos[2])))
        self.record.mode_sent_after.append(self.record.timesync_ts1)
        self.record.mode_sources.append((name, by))
        self.vtarget = None
        if name in ("BRAKE", "LOITER", "GUIDED", *RETURNING):
            if name != "GUIDED" and self.landed_state == mav.MAV_LANDED_STATE_TAKEOFF:
                self.landed_state = mav.MAV_LANDED_STATE_IN_AIR  # stop climbing where it is
            self.target = None  # BRAKE / GUIDED without a target: stop (decelerating) and hold
        if name == "GUIDED":
            # mode_guided.cpp init(): velocity control with a zero target; speeds back to defaults
            self.guided_sub = "vel"
            self.cmd_speed = None
        if name in RETURNING:
            self.rtl_stage = "climb"
        if name == "LAND" and self.landed_state != mav.MAV_LANDED_STATE_ON_GROUND:
            self.landed_state = mav.MAV_LANDED_STATE_LANDING
            self.takeoff_alt = None

    def _guided_stop(self) -> None:
        """GUIDED ``init(true)``: an invalid target stops the vehicle (velocity control, zero target)."""
        self.record.targets_invalid += 1
        self.target, self.vtarget, self.guided_sub = None, [0.0, 0.0, 0.0], "vel"
        self.vtarget_time = time.monotonic()

    def _position_target(self, m: Any) -> None:
        """GCS_Mavlink.cpp handle_message_set_position_target_local_ned: GUIDED only; frames LOCAL_NED,
        LOCAL_OFFSET_NED (offset from where the vehicle is), BODY_NED / BODY_OFFSET_NED (offset rotated
        by its yaw, yaw relative); position, velocity or both (acceleration alone: hold); any other frame
        or mask (force without acceleration ignored, nothing to use) stops the vehicle."""
        mask = int(m.type_mask)
        self.record.targets.append((float(m.x), float(m.y), float(m.z), mask))
        self.record.target_times.append(time.monotonic())
        self.record.target_sent_after.append(self.record.timesync_ts1)
        if self.mode != "GUIDED":
            self.record.targets_ignored += 1
            return
        frame = int(m.coordinate_frame)
        body = frame in (mav.MAV_FRAME_BODY_NED, mav.MAV_FRAME_BODY_OFFSET_NED)
        if frame not in (mav.MAV_FRAME_LOCAL_NED, mav.MAV_FRAME_LOCAL_OFFSET_NED) and not body:
            return self._guided_stop()
        pos_ignore, vel_ignore, acc_ignore = bool(mask & 0b111), bool(mask & 0b111000), bool(mask & 0b111000000)
        if mask & 512 and not acc_ignore:  # FORCE_SET: force inputs are not supported
            return self._guided_stop()
        if pos_ignore and vel_ignore and not acc_ignore:
            self.target, self.vtarget = None, [0.0, 0.0, 0.0]  # acceleration targets: held here
            self.vtarget_time = time.monotonic()
            return None
        if pos_ignore and vel_ignore:
            return self._guided_stop()
        c, s_ = math.cos(self.yaw), math.sin(self.yaw)
        x, y, z = float(m.x), float(m.y), float(m.z)
        vx, vy, vz = float(m.vx), float(m.vy), float(m.vz)
        if body:
            x, y = c * x - s_ * y, s_ * x + c * y
            vx, vy = c * vx - s_ * vy, s_ * vx + c * vy
        if frame != mav.MAV_FRAME_LOCAL_NED:
            x, y, z = x + self.pos[0], y + self.pos[1], z + self.pos[2]
        on_ground = self.landed_state == mav.MAV_LANDED_STATE_ON_GROUND
        if not mask & 1024:
            self.yaw = float(m.yaw) + (self.yaw if body else 0.0)
        if not pos_ignore:  # position target (position + velocity flies to the position here)
            if on_ground and abs(z - self.ground_down) > 0.2:
                return None  # a landed copter ignores targets in the air (take off first)
            if self.guided_sub != "pos":  # pos_control_start -> pva_control_start: WPNAV_SPEED again
                self.guided_sub = "pos"
                self.cmd_speed = None
                self.record.speed_resets += 1
            self.target = [x, y, self.ground_down if on_ground else z]
            self.vtarget = None
        else:  # velocity target, zeroed after GUID_TIMEOUT without a new one (velaccel_control_run)
            if self.guided_sub != "vel":
                self.guided_sub = "vel"
                self.cmd_speed = None
            self.vtarget = [vx, vy, 0.0 if on_ground else vz]
            self.vtarget_time = time.monotonic()
            self.target = None
        return None

    def _brake(self, dt: float, horizontal_only: bool = False) -> None:
        axes = 2 if horizontal_only else 3
        n = math.sqrt(sum(self.vel[i] ** 2 for i in range(axes)))
        if n > 1e-9:
            k = max(0.0, n - self.brake_decel * dt) / n
            for i in range(axes):
                self.vel[i] *= k

    def _approach(self, dt: float, speed: float, target: list[float] | None = None) -> None:
        target = target if target is not None else self.target
        d = [target[i] - self.pos[i] for i in range(3)] if target else [0.0, 0.0, 0.0]
        n = math.sqrt(sum(c * c for c in d))
        want = min(speed, math.sqrt(2 * self.accel * n)) if n > 1e-6 else 0.0
        desired = [d[i] / n * want if n > 1e-6 else 0.0 for i in range(3)]
        dv = [desired[i] - self.vel[i] for i in range(3)]
        m = math.sqrt(sum(c * c for c in dv))
        k = min(1.0, self.accel * dt / m) if m > 1e-9 else 0.0
        self.vel = [self.vel[i] + dv[i] * k for i in range(3)]
        if target and n <= 1e-3 and m < 1e-3:
            self.pos = list(target)

    def _rtl(self, dt: float) -> None:
        """mode_rtl.cpp: climb to RTL_ALT [cm] (never down), fly home, then LAND."""
        rtl_alt = self.params.get("RTL_ALT", 1500.0) / 100.0
        if self.rtl_stage == "climb":
            top = max(rtl_alt, -self.pos[2])
            self._brake(dt, horizontal_only=True)
            self.vel[2] = -self.climb_rate
            if self.pos[2] + self.vel[2] * dt <= -top:
                self.vel[2] = (-top - self.pos[2]) / dt
                self.rtl_stage = "return"
                self.record.rtl_top = top
        elif self.rtl_stage == "return":
            home = [0.0, 0.0, self.pos[2]]
            self._approach(dt, self.wpnav_speed, home)
            if math.hypot(self.pos[0], self.pos[1]) < 0.05 and math.hypot(self.vel[0], self.vel[1]) < 0.05:
                self.rtl_stage = "descend"
                self.landed_state = mav.MAV_LANDED_STATE_LANDING

    def _step(self, dt: float) -> None:
        """Advance the motion by ``dt`` [s] in steps of at most ``PHYSICS_STEP``: a loop woken late on
        a loaded machine integrates as finely as an idle one (no overshoot from one long step)."""
        n = max(1, math.ceil(dt / self.physics_step))
        for _ in range(min(n, 2000)):
            self._physics(dt / n)

    def _physics(self, dt: float) -> None:
        if dt <= 0 or self.frozen or time.monotonic() < self._silent_until:
            return
        ls = self.landed_state
        arrived = False
        if self.freeze_motion:
            self.vel = [0.0, 0.0, 0.0]
        elif ls == mav.MAV_LANDED_STATE_TAKEOFF and self.takeoff_alt is not None:
            self._brake(dt, horizontal_only=True)
            self.vel[2] = -self.climb_rate
            if self.pos[2] + self.vel[2] * dt <= -self.takeoff_alt:
                self.vel[2] = (-self.takeoff_alt - self.pos[2]) / dt
                self.landed_state = mav.MAV_LANDED_STATE_IN_AIR
                self.target = [self.pos[0], self.pos[1], -self.takeoff_alt]
                arrived = True  # the take-off ends at its altitude, stopped (no climb carried on)
        elif ls == mav.MAV_LANDED_STATE_LANDING or (self.mode == "LAND" and ls == mav.MAV_LANDED_STATE_IN_AIR):
            self.landed_state = mav.MAV_LANDED_STATE_LANDING
            self._brake(dt, horizontal_only=True)  # LAND does not stop horizontal motion at once
            self.vel[2] = min(self.descent_rate, (self.ground_down - self.pos[2]) / dt)
            if self.pos[2] + self.vel[2] * dt >= self.ground_down - 1e-9:
                self.landed_state = mav.MAV_LANDED_STATE_ON_GROUND
                self.armed = False  # ArduPilot disarms after landing
                self.target = None
                self.vel = [0.0, 0.0, 0.0]
                self.pos[2] = self.ground_down
        elif self.mode in RETURNING and ls == mav.MAV_LANDED_STATE_IN_AIR:
            self._rtl(dt)
        elif self.mode == "GUIDED" and self.vtarget is not None:
            if time.monotonic() - self.vtarget_time > self.params.get("GUID_TIMEOUT", 3.0):
                self.vtarget = [0.0, 0.0, 0.0]  # no new velocity for GUID_TIMEOUT: stop
            self.vel = list(self.vtarget)
        elif self.mode == "GUIDED" and self.target is not None:
            on_ground = ls == mav.MAV_LANDED_STATE_ON_GROUND
            cap = (self.cmd_speed if self.cmd_speed is not None and not self.speed_ignored
                   else (self.walk_speed if on_ground else self.wpnav_speed))
            self._approach(dt, min(cap, self.walk_speed) if on_ground else cap)
        else:
            self._brake(dt)  # BRAKE, LOITER, GUIDED without a target, STABILIZE on the ground
        self.pos = [self.pos[i] + self.vel[i] * dt for i in range(3)]
        if arrived:
            self.vel[2] = 0.0
        if self.landed_state == mav.MAV_LANDED_STATE_ON_GROUND:
            self.pos[2], self.vel[2] = self.ground_down, 0.0
        self.record.max_speed = max(self.record.max_speed, math.hypot(self.vel[0], self.vel[1]))
        self.record.max_height = max(self.record.max_height, -self.pos[2])
        self.battery = max(0.0, self.battery - (0.05 if self.armed else 0.001) * dt)


__all__ = ["CopterPhysics", "RETURNING"]
