"""MAVLink telemetry: vehicle identity, validation at the boundary, stream ages, reboot detection.

:class:`Telemetry` receives every decoded MAVLink message (from the transport's receive thread)
and keeps the latest *valid* vehicle state in the vehicle's local NED frame [m, m/s, rad]:

- **identity**: the vehicle is the first HEARTBEAT whose component is the autopilot's
  (``MAV_COMP_ID_AUTOPILOT1`` by default), whose autopilot type is not ``MAV_AUTOPILOT_INVALID``
  and whose vehicle type is not a peripheral (gimbal, camera, GCS ...). Telemetry and COMMAND_ACK
  are taken from that (system, component) only, and a COMMAND_ACK only when addressed to the console
  (its ``target_system`` / ``target_component``: ArduPilot answers each sender); the other components are listed; a vehicle using
  the console's own system id, and a second vehicle on the port, are warned about;
- **validation**: every field used is checked finite and plausible; an invalid message is dropped
  whole and counted per message type with the reason (``LOCAL_POSITION_NED.x: not finite``), so
  an invalid value never becomes the robot's pose;
- **ages**: the time of the last message of each stream (valid or not) and of the last valid
  position, so a stream that stopped (without a heartbeat gap) shows as stale;
- **duplicates, reordering, loss**: every packet goes through
  :class:`~console.link.mavlink_quality.LinkQuality` first (exact copies dropped, loss from ``seq``
  gaps, TIMESYNC latency, rates); a position sample older than the one held is dropped (reordered);
- **reboot / reconnect** needs agreeing evidence: ``time_boot_ms`` going back *and* (a heartbeat
  silence longer than the heartbeat timeout that just ended, or ``REBOOT_SAMPLES`` samples in a row on
  the new, earlier clock), or a new transport socket: a late copy alone, or a heartbeat gap alone (a
  lossy radio), is never a reboot (after a gap the streams and the origin are asked for again).
  It increments ``epoch`` and records why; the EKF origin (GPS_GLOBAL_ORIGIN) is kept and a moved
  origin is warned about;
- **mode authority and estimator trust**: :class:`~console.link.mavlink_authority.ModeAuthority` sees
  every heartbeat's mode, :class:`~console.link.mavlink_authority.EstimatorWatch` every position and
  EKF_STATUS_REPORT / ESTIMATOR_STATUS.
"""

from __future__ import annotations

import logging
import math
import threading
import time
from dataclasses import dataclass, field
from typing import Any, Callable

from console.link.mavlink_authority import EstimatorWatch, ModeAuthority
from console.link.mavlink_quality import LinkQuality

log = logging.getLogger(__name__)

Vec3 = tuple[float, float, float]

LANDED_UNDEFINED, LANDED_ON_GROUND, LANDED_IN_AIR, LANDED_TAKEOFF, LANDED_LANDING = 0, 1, 2, 3, 4
"""MAV_LANDED_STATE values (EXTENDED_SYS_STATE.landed_state)."""

STATUSTEXT_KEPT = 20
"""How many of the vehicle's latest STATUSTEXT messages (and link warnings) the link keeps."""
STATUSTEXT_IN_STATE = 5
"""How many of them each state sample carries."""

MAV_TYPE_NOT_VEHICLE = frozenset({5, 6, 18, 26, 27, 30, 31, 32, 34, 36, 38, 39, 41, 42})
"""MAV_TYPE values of peripherals, never the vehicle: antenna tracker, GCS, onboard controller,
gimbal, ADS-B, camera, charging station, FLARM, ODID, servo, battery, log, OSD, IMU..."""

MAV_AUTOPILOT_INVALID = 8
MAV_SYS_STATUS_PREARM_CHECK = 1 << 28
EKF_POS_HORIZ_REL, EKF_POS_HORIZ_ABS, EKF_POS_VERT_ABS = 8, 16, 32
EKF_CONST_POS_MODE = 128
REBOOT_SAMPLES = 5
"""Samples in a row on an earlier ``time_boot_ms`` clock (without a silence) that make a reboot."""
TRACKED = ("LOCAL_POSITION_NED", "ATTITUDE", "EXTENDED_SYS_STATE", "SYS_STATUS")
"""Streams the link needs, re-requested while they do not flow."""


def statustext_line(severity: int, text: Any) -> str:
    """``"SEVERITY: text"`` of a STATUSTEXT (``"WARNING: PreArm: Need 3D Fix"``)."""
    from pymavlink import mavutil

    sev = mavutil.mavlink.enums["MAV_SEVERITY"].get(int(severity))
    name = sev.name.removeprefix("MAV_SEVERITY_") if sev is not None else f"SEVERITY {int(severity)}"
    body = text.decode(errors="replace") if isinstance(text, bytes) else str(text)
    return f"{name}: {body.rstrip(chr(0)).strip()}"


def _check(msg_type: str, values: dict[str, float], limit: float) -> str | None:
    """The first field that is not finite or beyond ``|limit|``, as ``"TYPE.field: why"``."""
    for name, v in values.items():
        try:
            f = float(v)
        except (TypeError, ValueError):
            return f"{msg_type}.{name}: not a number"
        if not math.isfinite(f):
            return f"{msg_type}.{name}: not finite ({f})"
        if abs(f) > limit:
            return f"{msg_type}.{name}: implausible ({f:g}, limit {limit:g})"
    return None


@dataclass
class StatusLine:
    number: int
    time: float  # monotonic [s]
    severity: int  # MAV_SEVERITY (0 emergency ... 7 debug)
    text: str  # "SEVERITY: text"


@dataclass
class Vehicle:
    """Latest valid telemetry of the vehicle (NED, as received) and link bookkeeping."""

    system: int | None = None
    component: int = 1
    autopilot: int = 0
    last_heartbeat: float = -math.inf  # monotonic [s]
    custom_mode: int | None = None
    base_mode: int = 0
    system_status: int = 0
    pos_ned: Vec3 | None = None  # last valid
    pos_time: float = -math.inf  # monotonic [s] of the last valid position
    vel_ned: Vec3 = (0.0, 0.0, 0.0)
    yaw_ned: float = 0.0
    landed_state: int = LANDED_UNDEFINED
    battery: float | None = None
    voltage: float | None = None
    sensors_health: int | None = None  # SYS_STATUS.onboard_control_sensors_health
    sensors_present: int | None = None
    ekf_flags: int | None = None
    last_boot_ms: int | None = None
    pos_boot_ms: int | None = None  # time_boot_ms of the position held
    low_boot_ms: int | None = None  # a candidate earlier clock (reboot or late copies)
    low_count: int = 0
    silence_end: float = -math.inf  # monotonic [s] a heartbeat silence ended
    silence_end_prev: float = -math.inf  # monotonic [s] of the last heartbeat before that silence
    last_rx: float = -math.inf  # monotonic [s] of the vehicle's last message of any kind
    origin: tuple[float, float, float] | None = None  # first GPS_GLOBAL_ORIGIN (lat deg, lon deg, alt m)
    origin_now: tuple[float, float, float] | None = None
    stream_time: dict[str, float] = field(default_factory=dict)  # message type -> monotonic [s]
    invalid: dict[str, int] = field(default_factory=dict)  # message type -> count dropped
    late_dropped: int = 0  # position / attitude samples older than the ones held (reordered, late copies)
    last_invalid: tuple[float, str] | None = None  # (monotonic [s], reason)
    statustext: list[StatusLine] = field(default_factory=list)
    statustext_count: int = 0
    components: dict[tuple[int, int], tuple[int, int, float]] = field(default_factory=dict)
    warnings: dict[str, str] = field(default_factory=dict)  # key -> text
    epoch: int = 0
    epoch_reason: str = ""
    params: dict[str, float] = field(default_factory=dict)
    foreign_acks: int = 0  # COMMAND_ACKs addressed to another ground station / component (ignored)
    home_ned: Vec3 | None = None  # where the vehicle was when it last armed (its home, NED)

    @property
    def armed(self) -> bool:
        return bool(self.base_mode & 128)  # MAV_MODE_FLAG_SAFETY_ARMED


class Telemetry:
    """Decodes and validates the vehicle's messages (thread-safe; ``lock`` is a Condition).

    Args:
        source_system: The console's own MAVLink system id (a vehicle using it is warned about).
        heartbeat_timeout: Heartbeat silence after which a new heartbeat counts as a reconnect [s].
        autopilot_component: Component id of the autopilot (``None``: any non-peripheral).
        max_range: Largest plausible |NED coordinate| [m].
        max_speed: Largest plausible speed component [m/s].
        on_epoch: Called (outside the lock) with the reason after a reboot / reconnect.
        vehicle_max_speed: Fastest the vehicle really moves [m/s] (faster position steps are jumps).
        source_component: The console's own component id (COMMAND_ACKs for other ids are not ours).
    """

    def __init__(self, source_system: int, heartbeat_timeout: float, autopilot_component: int | None = 1,
                 max_range: float = 10_000.0, max_speed: float = 50.0,
                 on_epoch: Callable[[str], None] | None = None, vehicle_max_speed: float = 15.0,
                 source_component: int = 190) -> None:
        self.source_system, self.source_component = source_system, source_component
        self.heartbeat_timeout = heartbeat_timeout
        self.autopilot_component = autopilot_component
        self.max_range, self.max_speed = max_range, max_speed
        self.on_epoch = on_epoch
        self.lock = threading.Condition()
        self.v = Vehicle()
        self.acks: dict[int, tuple[Any, float]] = {}  # command -> (COMMAND_ACK, monotonic [s])
        self.received = 0
        self.quality = LinkQuality()
        self.timesync_sent: dict[int, float] = {}  # our TIMESYNC ts1 [ns] -> monotonic [s] sent
        self.authority = ModeAuthority(lambda: [(s.time, s.severity, s.text) for s in self.v.statustext])
        self.estimator = EstimatorWatch(vehicle_max_speed)
        self.signing_key_set = False

    # --- identity --------------------------------------------------------------------------------
    def _is_autopilot(self, msg: Any) -> bool:
        if int(msg.autopilot) == MAV_AUTOPILOT_INVALID or int(msg.type) in MAV_TYPE_NOT_VEHICLE:
            return False
        return self.autopilot_component is None or msg.get_srcComponent() == self.autopilot_component

    def warn(self, key: str, text: str) -> None:
        """Add a standing warning (once per key) and a ``WARNING: link: ...`` status line."""
        with self.lock:
            if self.v.warnings.get(key) == text:
                return
            self.v.warnings[key] = text
            self._add_line(4, f"WARNING: link: {text}")
        log.warning("%s", text)

    def clear_warning(self, key: str) -> None:
        with self.lock:
            self.v.warnings.pop(key, None)

    def _add_line(self, severity: int, text: str) -> None:
        v = self.v
        v.statustext_count += 1
        v.statustext = (v.statustext + [StatusLine(v.statustext_count, time.monotonic(), severity, text)])[
            -STATUSTEXT_KEPT:]

    def _heartbeat(self, msg: Any, now: float) -> str | None:
        v = self.v
        src, comp = msg.get_srcSystem(), msg.get_srcComponent()
        v.components[(src, comp)] = (int(msg.type), int(msg.autopilot), now)
        if not self._is_autopilot(msg):
            return None
        if v.system is None:
            v.system, v.component, v.autopilot = src, comp, int(msg.autopilot)
            log.info("vehicle found: system %d component %d (autopilot type %d)", src, comp, v.autopilot)
            if src == self.source_system:
                self.v.warnings["sysid"] = (f"the vehicle uses system id {src}, the console's own: set the "
                                            "vehicle's MAV_SYSID (or the console's) to another value")
                self._add_line(4, "WARNING: link: " + self.v.warnings["sysid"])
        elif src != v.system:
            key = f"vehicle{src}"
            if key not in v.warnings:
                v.warnings[key] = (f"a second vehicle (system {src}, component {comp}) is on this link: ignored; "
                                   f"the console follows system {v.system}")
                self._add_line(4, "WARNING: link: " + v.warnings[key])
            return None
        if comp != v.component:
            return None
        reason = None
        if v.last_heartbeat > -math.inf and now - v.last_heartbeat > self.heartbeat_timeout:
            reason = f"heartbeat back after {now - v.last_heartbeat:.1f} s of silence"
            v.silence_end = now
            v.silence_end_prev = v.last_heartbeat  # the last heartbeat before the silence
        v.last_heartbeat = now
        v.custom_mode = int(msg.custom_mode)
        from pymavlink import mavutil  # on first use, as console.link.mavlink_transport.mavutil()
        name = mavutil.mode_mapping_acm.get(v.custom_mode, f"mode {v.custom_mode}")
        if self.authority.observe(name, now - v.silence_end_prev if reason else 0.0) is not None:
            self._add_line(4, f"WARNING: link: the vehicle switched to {name} by itself: the console "
                              "sends nothing until the operator takes control")
        was_armed = v.armed
        v.base_mode = int(msg.base_mode)
        v.system_status = int(msg.system_status)
        if v.armed and not was_armed:  # ArduPilot sets home where it arms (AP_Arming_Copter::arm)
            v.home_ned = v.pos_ned
        return reason

    # --- receiving -------------------------------------------------------------------------------
    def handle(self, msg: Any) -> None:
        """Take one received message (any source)."""
        kind = msg.get_type()
        if kind == "BAD_DATA":
            return
        now = time.monotonic()
        epoch_reason = None
        with self.lock:
            v = self.v
            if not self.quality.accept(msg, (v.system, v.component) if v.system is not None else None):
                return  # an exact copy (a second link, a retransmission): already handled
            if self.quality.signed and not self.signing_key_set and "signing" not in v.warnings:
                v.warnings["signing"] = ("the vehicle signs its messages (MAVLink 2 signing): it ignores unsigned "
                                         "commands; signing required: set a key with --mavlink-key")
                self._add_line(4, "WARNING: link: " + v.warnings["signing"])
            if v.system is not None and msg.get_srcSystem() == v.system:
                v.last_rx = now
            if kind == "HEARTBEAT":
                epoch_reason = self._heartbeat(msg, now)
            elif v.system is not None and msg.get_srcSystem() == v.system:
                if kind == "STATUSTEXT":  # any component of the vehicle may explain itself
                    self._add_line(int(msg.severity), statustext_line(msg.severity, msg.text))
                elif msg.get_srcComponent() == v.component:
                    self.received += 1
                    epoch_reason = self._telemetry(kind, msg, now)
            silence = None
            if epoch_reason and epoch_reason.startswith("heartbeat back"):
                # a heartbeat gap alone is no reboot (a lossy radio loses a few in a row): streams and origin
                # are asked for again; a reboot shows in time_boot_ms (the silence counts as evidence there)
                silence, epoch_reason = epoch_reason, None
            if epoch_reason:
                self._epoch(epoch_reason)
            self.lock.notify_all()
        if silence:
            log.warning("vehicle %s", silence)
            if self.on_epoch is not None:
                self.on_epoch(silence)
        if epoch_reason:
            log.warning("vehicle %s", epoch_reason)
            if self.on_epoch is not None:
                self.on_epoch(epoch_reason)

    def _epoch(self, reason: str) -> None:
        v = self.v
        if reason.startswith("rebooted"):
            self.authority.release()  # a rebooted vehicle is in its own mode: the console claims nothing
        self.estimator.forget()
        self.quality.reset_sequence()
        v.low_boot_ms, v.low_count, v.pos_boot_ms = None, 0, None
        v.epoch += 1
        v.epoch_reason = reason
        v.warnings["epoch"] = (f"vehicle {reason} (#{v.epoch}): telemetry and EKF origin requested again; "
                               "check what it is doing before resuming")
        self._add_line(4, "WARNING: link: " + v.warnings["epoch"])

    def _drop(self, kind: str, reason: str, now: float) -> None:
        v = self.v
        v.invalid[kind] = v.invalid.get(kind, 0) + 1
        if v.last_invalid is None or v.last_invalid[1] != reason or v.invalid[kind] in (1, 10, 100, 1000):
            log.warning("dropped invalid %s (%s), %d so far", kind, reason, v.invalid[kind])
        v.last_invalid = (now, reason)

    def _telemetry(self, kind: str, msg: Any, now: float) -> str | None:
        """Validate and store one message of the vehicle; returns a reboot reason or None."""
        v = self.v
        v.stream_time[kind] = now
        epoch = None
        boot = getattr(msg, "time_boot_ms", None)
        if isinstance(boot, int) and kind in ("LOCAL_POSITION_NED", "ATTITUDE"):
            if v.last_boot_ms is not None and boot + 1000 < v.last_boot_ms:
                # an earlier clock: late copies, or a reboot; a reboot needs agreeing evidence
                if v.low_boot_ms is not None and boot >= v.low_boot_ms:
                    v.low_count += 1
                else:
                    v.low_count = 1
                v.low_boot_ms = boot
                if now - v.silence_end < 5.0 or v.low_count >= REBOOT_SAMPLES:
                    epoch = (f"rebooted (time_boot_ms went back from {v.last_boot_ms / 1000:.1f} s to "
                             f"{boot / 1000:.1f} s)")
                    v.last_boot_ms = boot
                    v.low_boot_ms, v.low_count, v.pos_boot_ms = None, 0, None
                else:
                    v.late_dropped += 1
                    return None  # not used: it may be a late copy of the past
            else:
                v.low_boot_ms, v.low_count = None, 0
                v.last_boot_ms = max(boot, v.last_boot_ms or 0) if epoch is None else boot
        if kind == "LOCAL_POSITION_NED" and isinstance(boot, int) and v.pos_boot_ms is not None \
                and boot < v.pos_boot_ms and epoch is None:
            v.late_dropped += 1  # reordered: older than the position held
            return None
        if kind == "LOCAL_POSITION_NED":
            bad = (_check(kind, {"x": msg.x, "y": msg.y, "z": msg.z}, self.max_range)
                   or _check(kind, {"vx": msg.vx, "vy": msg.vy, "vz": msg.vz}, self.max_speed))
            if bad:
                self._drop(kind, bad, now)
            else:
                v.pos_ned = (float(msg.x), float(msg.y), float(msg.z))
                v.vel_ned = (float(msg.vx), float(msg.vy), float(msg.vz))
                v.pos_time = now
                if isinstance(boot, int):
                    v.pos_boot_ms = boot
                if epoch is not None:  # this sample starts the rebooted vehicle's track (new origin)
                    self.estimator.forget()
                jump = self.estimator.position(v.pos_ned, boot / 1000.0 if isinstance(boot, int) else now)
                if jump:
                    self._add_line(4, f"WARNING: link: {jump}")
        elif kind == "ATTITUDE":
            bad = _check(kind, {"yaw": msg.yaw}, 2 * math.pi + 0.01)
            if bad:
                self._drop(kind, bad, now)
            else:
                v.yaw_ned = float(msg.yaw)
        elif kind == "EXTENDED_SYS_STATE":
            if int(msg.landed_state) not in range(5):
                self._drop(kind, f"{kind}.landed_state: unknown value {int(msg.landed_state)}", now)
            else:
                v.landed_state = int(msg.landed_state)
        elif kind == "SYS_STATUS":
            remaining = int(msg.battery_remaining)
            if not -1 <= remaining <= 100:
                self._drop(kind, f"{kind}.battery_remaining: out of range ({remaining})", now)
            else:
                v.battery = None if remaining < 0 else remaining / 100.0
                v.voltage = None if msg.voltage_battery in (0, 65535) else msg.voltage_battery / 1000.0
                v.sensors_health = int(msg.onboard_control_sensors_health)
                v.sensors_present = int(msg.onboard_control_sensors_present)
        elif kind == "EKF_STATUS_REPORT":
            v.ekf_flags = int(msg.flags)
            fault = self.estimator.ekf_fault(v.ekf_flags, {
                "velocity": float(msg.velocity_variance), "position": float(msg.pos_horiz_variance),
                "height": float(msg.pos_vert_variance), "compass": float(msg.compass_variance)})
            self._estimator_flags(fault)
        elif kind == "ESTIMATOR_STATUS":
            fault = self.estimator.estimator_fault(int(msg.flags), {
                "velocity": float(msg.vel_ratio), "position": float(msg.pos_horiz_ratio),
                "height": float(msg.pos_vert_ratio), "compass": float(msg.mag_ratio)})
            self._estimator_flags(fault)
        elif kind == "TIMESYNC":
            self.quality.timesync(msg, self.timesync_sent)
        elif kind == "COMMAND_ACK":
            if self._ack_for_us(msg):
                self.acks[int(msg.command)] = (msg, now)
        elif kind == "PARAM_VALUE":
            name = msg.param_id.decode(errors="replace") if isinstance(msg.param_id, bytes) else str(msg.param_id)
            if math.isfinite(float(msg.param_value)):
                v.params[name.rstrip("\x00")] = float(msg.param_value)
        elif kind == "GPS_GLOBAL_ORIGIN":
            lat, lon, alt = msg.latitude / 1e7, msg.longitude / 1e7, msg.altitude / 1000.0
            if abs(lat) > 90 or abs(lon) > 180 or not math.isfinite(alt):
                self._drop(kind, f"{kind}: latitude/longitude out of range ({lat}, {lon})", now)
            else:
                self._origin((lat, lon, alt))
        return epoch

    def _ack_for_us(self, msg: Any) -> bool:
        """ArduPilot addresses each COMMAND_ACK to the command's sender (GCS_Common.cpp handle_command_long):
        one for a second ground station or a companion is not ours (target 0 / MAVLink 1: anyone's)."""
        to_sys, to_comp = int(getattr(msg, "target_system", 0) or 0), int(getattr(msg, "target_component", 0) or 0)
        if to_sys in (0, self.source_system) and to_comp in (0, self.source_component):
            return True
        self.v.foreign_acks += 1
        return False

    def _estimator_flags(self, fault: str) -> None:
        if self.v.pos_ned is None and not self.v.armed:
            fault = ""  # before the first position (EKF starting up): readiness says it
        new = self.estimator.flags(fault)
        if new:
            self._add_line(4, f"WARNING: link: estimator fault: {new}")

    def _origin(self, origin: tuple[float, float, float]) -> None:
        v = self.v
        v.origin_now = origin
        if v.origin is None:
            v.origin = origin
            return
        north = math.radians(origin[0] - v.origin[0]) * 6_378_137.0
        east = math.radians(origin[1] - v.origin[1]) * 6_378_137.0 * math.cos(math.radians(v.origin[0]))
        up = origin[2] - v.origin[2]
        moved = math.sqrt(north ** 2 + east ** 2 + up ** 2)
        if moved > 0.1:
            text = (f"the vehicle's EKF origin moved {moved:.1f} m (north {north:+.1f}, east {east:+.1f} m) "
                    "since the link opened: world positions are off by that much until --ned-origin is "
                    "corrected")
            if v.warnings.get("origin") != text:
                v.warnings["origin"] = text
                self._add_line(4, "WARNING: link: " + text)
        else:
            v.warnings.pop("origin", None)

    def new_epoch(self, reason: str) -> None:
        """Record a reboot / reconnect seen outside the messages (a new transport socket)."""
        with self.lock:
            self._epoch(reason)
            self.lock.notify_all()
        log.warning("vehicle link: %s", reason)
        if self.on_epoch is not None:
            self.on_epoch(reason)

    # --- queries ---------------------------------------------------------------------------------
    def stream_age(self, kind: str) -> float:
        """Seconds since the last ``kind`` message of the vehicle (valid or not; ``inf`` if never)."""
        with self.lock:
            return time.monotonic() - self.v.stream_time.get(kind, -math.inf)

    def silence(self) -> float:
        """Seconds since the vehicle's last message of any kind (``inf`` before the first)."""
        with self.lock:
            return time.monotonic() - self.v.last_rx

    def heartbeat_age(self) -> float:
        with self.lock:
            return time.monotonic() - self.v.last_heartbeat

    def pose_age(self) -> float:
        """Seconds since the last valid LOCAL_POSITION_NED (``inf`` before the first)."""
        with self.lock:
            return time.monotonic() - self.v.pos_time

    def lines_between(self, start: float, end: float) -> list[StatusLine]:
        """STATUSTEXT lines received in the monotonic interval [start, end]."""
        with self.lock:
            return [s for s in self.v.statustext if start <= s.time <= end]

    def readiness(self, pose_timeout: float) -> str:
        """``""`` when the vehicle can take off, else why not (position, EKF, pre-arm)."""
        with self.lock:
            v = self.v
            why = []
            if v.pos_ned is None:
                why.append("no position estimate yet (no LOCAL_POSITION_NED)")
            elif time.monotonic() - v.pos_time > pose_timeout:
                why.append("position stale")
            if v.ekf_flags is not None and (not v.ekf_flags & (EKF_POS_HORIZ_REL | EKF_POS_HORIZ_ABS)
                                            or v.ekf_flags & EKF_CONST_POS_MODE):
                why.append("EKF has no horizontal position")
            prearm_known = v.sensors_present is not None and v.sensors_present & MAV_SYS_STATUS_PREARM_CHECK
            if prearm_known and not (v.sensors_health or 0) & MAV_SYS_STATUS_PREARM_CHECK and not v.armed:
                recent = [s.text.split(": ", 1)[-1] for s in v.statustext
                          if "PreArm:" in s.text and time.monotonic() - s.time < 30.0]
                why.append("pre-arm checks failing" + (f" ({recent[-1]})" if recent else ""))
            return "; ".join(why)


__all__ = ["Telemetry", "Vehicle", "StatusLine", "statustext_line", "TRACKED", "LANDED_UNDEFINED",
           "LANDED_ON_GROUND", "LANDED_IN_AIR", "LANDED_TAKEOFF", "LANDED_LANDING"]
