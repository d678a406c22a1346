"""COMMAND_LONG handling of the ArduCopter emulator (:class:`~mav_emulator.ArduCopterEmulator` mixes
this in), with the results ArduPilot Copter gives.

Read from the firmware (ArduPilot/ardupilot), never copied:

- ``libraries/GCS_MAVLink/GCS_Common.cpp`` (``handle_command_long``): every COMMAND_LONG is answered by
  one COMMAND_ACK whose ``target_system`` / ``target_component`` are the *sender's* ids, so an ACK meant
  for a second ground station or a companion computer on the same link carries their ids, not ours;
  ``_set_mode_common``: a DO_SET_MODE without ``MAV_MODE_FLAG_CUSTOM_MODE_ENABLED`` is DENIED, a mode
  ``set_mode`` refuses is FAILED;
- ``ArduCopter/mode.cpp`` (``Copter::set_mode``): the mode it is in already is ACCEPTED at once; an
  *armed* vehicle without a position estimate cannot enter a mode that needs one (``requires_GPS``), a
  mode blocked by ``FLTMODE_GCSBLOCK`` cannot be entered from a ground station; both say
  ``Mode change to GUIDED failed: <why>`` (severity WARNING) and are FAILED; disarmed, any mode goes;
- ``ArduCopter/GCS_Mavlink.cpp`` (``handle_MAV_CMD_DO_CHANGE_SPEED``): a speed <= 0 is DENIED, speed
  type 4 (``SPEED_TYPE_ENUM_END``) DENIED, types 0/1 horizontal, 2 climb, 3 descent; the flight mode
  decides (``set_speed_NE_ms`` ...): GUIDED and AUTO take it, other modes refuse it (FAILED);
- ``ArduCopter/takeoff.cpp`` (``Mode::do_user_takeoff_U_m``): NAV_TAKEOFF needs armed, landed, a mode
  with a user take-off (GUIDED here) and an altitude [m] *above home* higher than the vehicle's; home
  is where the vehicle armed (``AP_Arming_Copter::arm`` sets it while not locked);
- ``GCS_Common.cpp`` (``handle_command_component_arm_disarm``): arming an armed vehicle, or disarming a
  disarmed one, is ACCEPTED without doing anything.

Frames: local NED [m]; speeds [m/s].
"""

from __future__ import annotations

import math
import time
from typing import Any

from pymavlink import mavutil

mav = mavutil.mavlink
MODES = {name: num for num, name in mavutil.mode_mapping_acm.items()}
NAMES = dict(mavutil.mode_mapping_acm)
ARMABLE = {"GUIDED", "LOITER", "STABILIZE", "ALT_HOLD", "POSHOLD"}
NEEDS_POSITION = {"GUIDED", "LOITER", "RTL", "AUTO", "POSHOLD", "BRAKE", "SMART_RTL", "CIRCLE", "FOLLOW",
                  "ZIGZAG", "AUTO_RTL", "DRIFT", "THROW", "AVOID_ADSB"}
"""Copter modes whose ``requires_GPS()`` is true (a position estimate is needed to enter them armed)."""
SPEED_MODES = {"GUIDED", "AUTO"}
"""Modes that take MAV_CMD_DO_CHANGE_SPEED (``set_speed_NE_ms`` / ``up`` / ``down`` overridden)."""
OTHER_GCS = (254, 190)
"""(system, component) of the second ground station whose commands :attr:`foreign_acks` answers."""


def _ack_has_target() -> bool:
    """MAVLink 2 (the dialect in use now: :func:`mav_emulator_events.use_mavlink2` switches it)."""
    return "target_system" in mavutil.mavlink.MAVLink_command_ack_message.fieldnames


class VehicleCommands:
    """COMMAND_LONG -> behaviour + COMMAND_ACK (state lives in the emulator)."""

    mode: str
    armed: bool
    landed_state: int
    pos: list[float]
    record: Any
    params: dict[str, float]
    ack_delays: dict[int, list[float]]
    late_acks: list[tuple[float, int, int, tuple[int, int]]]

    def _ack(self, command: int, result: int, confirmation: int, to: tuple[int, int] | None = None) -> None:
        """One COMMAND_ACK addressed (MAVLink 2) to the command's sender (default: the last requester)."""
        target = to or getattr(self, "_requester", (0, 0))
        if to is None:
            self.record.commands.append((command, confirmation, result))
            delays = self.ack_delays.get(command)
            if delays:  # this answer travels late (a slow or congested link): sent by the loop when due
                self.late_acks.append((time.monotonic() + delays.pop(0), command, result, target))
                return
        self._ack_now(command, result, target)

    def _ack_now(self, command: int, result: int, target: tuple[int, int]) -> None:
        if _ack_has_target():
            self._send("command_ack_send", command, result, 0, 0, target[0], target[1])
        else:  # MAVLink 1 has no target fields: an ACK cannot say whom it answers
            self._send("command_ack_send", command, result)

    def _send_late_acks(self, now: float) -> None:
        """Send the delayed COMMAND_ACKs that are due (``ack_delays``), in the order they were decided."""
        due = [a for a in self.late_acks if a[0] <= now]
        self.late_acks[:] = [a for a in self.late_acks if a[0] > now]
        for _, command, result, target in due:
            self._ack_now(command, result, target)

    def _command(self, m: Any) -> None:
        cmd, conf = int(m.command), int(m.confirmation)
        self._requester = (m.get_srcSystem(), m.get_srcComponent())
        self.record.received.append((cmd, conf))
        if cmd in self.foreign_acks:  # the vehicle answers another ground station's same command first
            self._ack(cmd, self.foreign_acks[cmd], 0, to=OTHER_GCS)
        if cmd in self.ignore_commands:
            return None
        if cmd in self.refuse_commands:
            return self._ack(cmd, mav.MAV_RESULT_UNSUPPORTED, conf)
        handler = {mav.MAV_CMD_DO_SET_MODE: self._set_mode, mav.MAV_CMD_COMPONENT_ARM_DISARM: self._arm_disarm,
                   mav.MAV_CMD_NAV_TAKEOFF: self._takeoff, mav.MAV_CMD_DO_CHANGE_SPEED: self._change_speed,
                   mav.MAV_CMD_SET_MESSAGE_INTERVAL: self._message_interval,
                   mav.MAV_CMD_REQUEST_MESSAGE: self._request_message,
                   mav.MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN: self._reboot_command}.get(cmd)
        if handler is None:
            return self._ack(cmd, mav.MAV_RESULT_UNSUPPORTED, conf)
        return handler(m, cmd, conf)

    def _mode_failed(self, name: str, why: str) -> None:
        self.say(f"Mode change to {name} failed: {why}", mav.MAV_SEVERITY_WARNING)

    def _set_mode(self, m: Any, cmd: int, conf: int) -> None:
        if not int(m.param1) & mav.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED:
            return self._ack(cmd, mav.MAV_RESULT_DENIED, conf)
        name = NAMES.get(int(m.param2))
        if name is None:
            return self._ack(cmd, mav.MAV_RESULT_FAILED, conf)
        if name in self.ignore_modes:
            return None
        if self.deny_modes.get(name, 0) > 0:
            self.deny_modes[name] -= 1
            return self._ack(cmd, mav.MAV_RESULT_DENIED, conf)
        if name != self.mode:
            if name in self.gcs_blocked_modes:
                self._mode_failed(name, "GCS entry disabled (FLTMODE_GCSBLOCK)")
                return self._ack(cmd, mav.MAV_RESULT_FAILED, conf)
            if self.armed and name in NEEDS_POSITION and (not self.ekf_ready or self.position_bad):
                self._mode_failed(name, "requires position")
                return self._ack(cmd, mav.MAV_RESULT_FAILED, conf)
            self._enter_mode(name)
        else:
            self.record.modes.append(name)  # ACCEPTED again, nothing changes
        return self._ack(cmd, mav.MAV_RESULT_ACCEPTED, conf)

    def _arm_disarm(self, m: Any, cmd: int, conf: int) -> None:
        if m.param1 >= 0.5:
            if self.armed:
                return self._ack(cmd, mav.MAV_RESULT_ACCEPTED, conf)
            if self.mode not in ARMABLE:
                return self._ack(cmd, mav.MAV_RESULT_FAILED, conf)
            reason = self.prearm_failure or (None if self.ekf_ready else "Need Position Estimate")
            if reason:
                text = reason if reason.startswith(("PreArm:", "Arm:")) else f"PreArm: {reason}"
                if not self.reason_after_ack:
                    self.say(text, mav.MAV_SEVERITY_CRITICAL)
                self._ack(cmd, mav.MAV_RESULT_FAILED, conf)
                if self.reason_after_ack:
                    self.say(text, mav.MAV_SEVERITY_CRITICAL)
                return None
            self.armed = True
            self.home_down = self.pos[2]  # home: where it armed
        else:
            if self.armed and self.landed_state != mav.MAV_LANDED_STATE_ON_GROUND and int(m.param2) != 21196:
                return self._ack(cmd, mav.MAV_RESULT_FAILED, conf)
            self.armed = False
        return self._ack(cmd, mav.MAV_RESULT_ACCEPTED, conf)

    def _takeoff(self, m: Any, cmd: int, conf: int) -> None:
        alt = float(m.param7)  # above home [m]
        above_home = self.home_down - self.pos[2]
        if (self.mode != "GUIDED" or not self.armed or self.landed_state != mav.MAV_LANDED_STATE_ON_GROUND
                or not math.isfinite(alt) or alt <= above_home):
            return self._ack(cmd, mav.MAV_RESULT_FAILED, conf)
        self.record.takeoff_altitudes.append(alt)
        self.takeoff_alt = alt - self.home_down  # height above the EKF origin
        self.guided_sub = "takeoff"
        self.landed_state = mav.MAV_LANDED_STATE_TAKEOFF
        self.target = None
        return self._ack(cmd, mav.MAV_RESULT_ACCEPTED, conf)

    def _change_speed(self, m: Any, cmd: int, conf: int) -> None:
        kind, speed = float(m.param1), float(m.param2)
        self.record.speeds.append((int(kind) if math.isfinite(kind) else -1, speed))
        if not speed > 0:
            return self._ack(cmd, mav.MAV_RESULT_DENIED, conf)
        if kind == 4:
            return self._ack(cmd, mav.MAV_RESULT_DENIED, conf)
        if kind not in (0, 1, 2, 3) or self.mode not in SPEED_MODES:
            return self._ack(cmd, mav.MAV_RESULT_FAILED, conf)
        if kind in (0, 1):
            self.cmd_speed = speed
        elif kind == 2:
            self.climb_rate = speed
        else:
            self.descent_rate = speed
        return self._ack(cmd, mav.MAV_RESULT_ACCEPTED, conf)

    def _message_interval(self, m: Any, cmd: int, conf: int) -> None:
        if not self.message_interval_supported:
            return self._ack(cmd, mav.MAV_RESULT_UNSUPPORTED, conf)
        self.record.intervals.append((int(m.param1), float(m.param2)))
        name = mav.mavlink_map[int(m.param1)].msgname if int(m.param1) in mav.mavlink_map else ""
        if name in self.STREAM_NAMES:
            self.streaming.add(name)
        return self._ack(cmd, mav.MAV_RESULT_ACCEPTED, conf)

    def _request_message(self, m: Any, cmd: int, conf: int) -> None:
        self._ack(cmd, mav.MAV_RESULT_ACCEPTED, conf)
        if int(m.param1) == mav.MAVLINK_MSG_ID_GPS_GLOBAL_ORIGIN and self.origin_set:  # none before it is set
            lat, lon, alt = self.origin
            self._send("gps_global_origin_send", int(lat * 1e7), int(lon * 1e7), int(alt * 1000))

    def _reboot_command(self, m: Any, cmd: int, conf: int) -> None:
        if self.armed:
            return self._ack(cmd, mav.MAV_RESULT_FAILED, conf)
        self._ack(cmd, mav.MAV_RESULT_ACCEPTED, conf)
        self.reboot()


__all__ = ["VehicleCommands", "ARMABLE", "NEEDS_POSITION", "SPEED_MODES", "OTHER_GCS", "MODES", "NAMES"]
