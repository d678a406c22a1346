"""An ArduPilot-Copter-like vehicle for tests: real MAVLink over UDP on 127.0.0.1 (pymavlink).

It implements the behaviours the MAVLink link relies on, the way ArduPilot Copter does them:

- HEARTBEAT (type QUADROTOR, autopilot ARDUPILOTMEGA, Copter custom mode, armed flag);
- MAV_CMD_DO_SET_MODE with Copter mode numbers, answered by COMMAND_ACK; commands are answered
  only when addressed to the autopilot (component 1 or 0);
- MAV_CMD_COMPONENT_ARM_DISARM (arming only in armable modes and when pre-arm checks pass, else
  MAV_RESULT_FAILED with a ``PreArm: ...`` STATUSTEXT; disarming only when landed);
- MAV_CMD_NAV_TAKEOFF (only in GUIDED, armed and landed), altitude above the origin in param7;
- MAV_CMD_DO_CHANGE_SPEED (types 0/1 horizontal, 2 climb, 3 descent); without it the vehicle flies
  at its WPNAV_SPEED (``fly_speed``);
- motion with acceleration limits: it arrives at a target decelerating (``accel``), BRAKE and
  LAND stop horizontal motion at ``brake_decel`` (braking distance v^2 / 2a; LAND while moving
  touches down past the spot);
- SET_POSITION_TARGET_LOCAL_NED in GUIDED: flies there in the air; on the ground, a target at
  ground height makes the robot *walk* (the aerial-ground robot's ground-motion command set);
- streams: LOCAL_POSITION_NED (only once the EKF has a position), ATTITUDE, SYS_STATUS (with the
  pre-arm bit), EXTENDED_SYS_STATE, EKF_STATUS_REPORT; MAV_CMD_SET_MESSAGE_INTERVAL and
  REQUEST_DATA_STREAM switch them on; GPS_GLOBAL_ORIGIN on MAV_CMD_REQUEST_MESSAGE; PARAM_VALUE
  on PARAM_REQUEST_READ (``FS_GCS_ENABLE`` ...);
- reboot (MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN or :meth:`reboot`): silent for ``reboot_silence``,
  then time_boot_ms restarts, the requested rates are forgotten and the EKF origin is set where
  the vehicle stands.

Faults for tests (attributes): ``heartbeat_enabled`` (silence the heartbeat only),
``telemetry_enabled`` (silence the streams only), ``corrupt`` (``{"x": nan}``: override fields of
LOCAL_POSITION_NED / ATTITUDE), ``drop`` (packet loss), ``blocked`` (nothing is sent, incoming
messages queue and are handled late when unblocked, like a blocked TCP port), ``deny_modes``,
``ignore_commands``, ``prearm_failure`` (+ ``reason_after_ack``), ``ekf_ready``,
``message_interval_supported``, ``streams_need_request``, ``components`` (other components of
the system heartbeating: a gimbal 154 ...), ``other_systems`` (other vehicles), ``freeze_motion``.
"""

from __future__ import annotations

import math
import random
import threading
import time
from dataclasses import dataclass, field
from typing import Any

from pymavlink import mavutil

mav = mavutil.mavlink
MODES = {name: num for num, name in mavutil.mode_mapping_acm.items()}
NAMES = dict(mavutil.mode_mapping_acm)
ARMABLE = {"GUIDED", "LOITER", "STABILIZE", "ALT_HOLD", "POSHOLD"}
STREAMS = ("LOCAL_POSITION_NED", "ATTITUDE", "SYS_STATUS", "EXTENDED_SYS_STATE", "EKF_STATUS_REPORT")
DATA_STREAM_GROUPS = {2: ("SYS_STATUS", "EXTENDED_SYS_STATE"), 6: ("LOCAL_POSITION_NED",), 10: ("ATTITUDE",),
                      12: ("EKF_STATUS_REPORT",)}
PHYSICS_STEP = 0.005  # [s] longest motion integration step (the loop sleeps 4 ms when idle)
EKF_GOOD = 1 | 2 | 4 | 8 | 16 | 32  # attitude, velocities, horizontal rel/abs, vertical position
ORIGIN = (-35.3632621, 149.1652374, 584.0)  # ArduPilot SITL's default home (lat, lon deg, alt m)


@dataclass
class Record:
    """What the emulator received (for assertions)."""

    received: list[tuple[int, int]] = field(default_factory=list)  # every COMMAND_LONG: (command, confirmation)
    commands: list[tuple[int, int, int]] = field(default_factory=list)  # answered: (command, confirmation, result)
    to_others: list[tuple[int, int]] = field(default_factory=list)  # COMMAND_LONGs for other components
    modes: list[str] = field(default_factory=list)  # accepted mode changes, in order
    mode_times: list[tuple[str, float]] = field(default_factory=list)  # (mode, monotonic [s] handled)
    takeoff_altitudes: list[float] = field(default_factory=list)
    targets: list[tuple[float, float, float, int]] = field(default_factory=list)  # NED + type_mask
    speeds: list[tuple[int, float]] = field(default_factory=list)  # DO_CHANGE_SPEED (type, m/s)
    intervals: list[tuple[int, float]] = field(default_factory=list)  # SET_MESSAGE_INTERVAL (msg id, us)
    data_streams: list[tuple[int, int]] = field(default_factory=list)  # REQUEST_DATA_STREAM (id, rate)
    gcs_heartbeats: int = 0
    dropped_in: int = 0
    dropped_out: int = 0
    late: int = 0  # messages handled after a block

    @property
    def mode_changes(self) -> list[str]:
        """:attr:`modes` with repeats folded: a SET_MODE re-sent because its ACK came late (a loaded
        machine) is accepted twice but changes the mode once."""
        return [m for i, m in enumerate(self.modes) if i == 0 or m != self.modes[i - 1]]
    max_speed: float = 0.0  # fastest horizontal speed flown [m/s]


class ArduCopterEmulator:
    """A simulated ArduPilot Copter sending to a GCS listening on ``127.0.0.1:gcs_port``.

    Args:
        gcs_port: UDP port of the GCS (the link under test, ``udpin:127.0.0.1:<port>``).
        walk_speed, fly_speed, climb_rate, descent_rate: Motion [m/s]; ``fly_speed`` is WPNAV_SPEED,
            what the vehicle flies at until told a speed.
        accel: Horizontal acceleration / approach deceleration [m/s^2].
        brake_decel: Deceleration of BRAKE and of horizontal motion in LAND [m/s^2].
        heartbeat_rate: HEARTBEAT rate [Hz] (ArduPilot: 1 Hz; faster here to keep tests short).
        telemetry_rate: LOCAL_POSITION_NED / ATTITUDE rate [Hz].
        drop: Fraction of packets lost, each direction.
        seed: Random seed of the packet loss.
        start_ned: Initial position (NED) [m].
        system: MAVLink system id.
        reboot_silence: How long a reboot keeps the vehicle silent [s].
        url: Another pymavlink connection instead of UDP to ``gcs_port`` (``tcpin:127.0.0.1:PORT``:
            the vehicle listens on TCP like SITL's serial port 0).
    """

    def __init__(self, gcs_port: int, *, walk_speed: float = 2.0, fly_speed: float = 4.0,
                 climb_rate: float = 3.0, descent_rate: float = 3.0, accel: float = 50.0, brake_decel: float = 50.0,
                 heartbeat_rate: float = 5.0, telemetry_rate: float = 25.0, drop: float = 0.0, seed: int = 1,
                 start_ned: tuple[float, float, float] = (0.0, 0.0, 0.0), system: int = 1,
                 reboot_silence: float = 0.5, url: str | None = None) -> None:
        self.conn = mavutil.mavlink_connection(url or f"udpout:127.0.0.1:{gcs_port}", source_system=system,
                                               source_component=1)
        self.system = system
        self.walk_speed, self.wpnav_speed = walk_speed, fly_speed
        self.climb_rate, self.descent_rate = climb_rate, descent_rate
        self.accel, self.brake_decel = accel, brake_decel
        self.heartbeat_rate, self.telemetry_rate = heartbeat_rate, telemetry_rate
        self.reboot_silence = reboot_silence
        self.drop = drop
        self._rng = random.Random(seed)
        # faults
        self.heartbeat_enabled = True
        self.telemetry_enabled = True
        self.corrupt: dict[str, float] = {}
        self.blocked = False
        self.frozen = False  # like a stopped process: silent, no physics, incoming handled late
        self.refuse_commands: set[int] = set()  # answered MAV_RESULT_UNSUPPORTED
        self.ignore_modes: set[str] = set()  # mode changes to these are never answered
        self.deny_modes: dict[str, int] = {}
        self.ignore_commands: set[int] = set()
        self.prearm_failure: str | None = None
        self.reason_after_ack = False
        self.ekf_ready = True
        self.message_interval_supported = True
        self.streams_need_request = False
        self.components: list[tuple[int, int, int]] = []  # (component, MAV_TYPE, MAV_AUTOPILOT)
        self.autopilot_heartbeat_delay = 0.0  # [s] before the autopilot's first heartbeat
        self.other_systems: list[int] = []
        self.freeze_motion = False
        self.params = {"FS_GCS_ENABLE": 1.0, "FS_GCS_TIMEOUT": 5.0, "FS_EKF_ACTION": 1.0}
        self.record = Record()
        self.lock = threading.RLock()
        self._queue: list[Any] = []
        self._encoders: dict[tuple[int, int], Any] = {}
        # vehicle state (NED)
        self.mode = "STABILIZE"
        self.armed = False
        self.landed_state = mav.MAV_LANDED_STATE_ON_GROUND
        self.pos = list(start_ned)
        self.vel = [0.0, 0.0, 0.0]
        self.yaw = 0.0
        self.target: list[float] | None = None  # position target (NED)
        self.vtarget: list[float] | None = None  # velocity target (NED)
        self.takeoff_alt: float | None = None
        self.cmd_speed: float | None = None
        self.battery = 100.0
        self.origin = ORIGIN
        self.streaming: set[str] = set(STREAMS)
        self.reboots = 0
        self._silent_until = 0.0
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._loop, name="mav-emulator", daemon=True)
        self._boot = time.monotonic()

    # --- lifecycle -------------------------------------------------------------------------------
    def start(self) -> "ArduCopterEmulator":
        if self.streams_need_request:
            self.streaming = set()
        self._thread.start()
        return self

    def stop(self) -> None:
        self._stop.set()
        self._thread.join(timeout=2.0)
        self.conn.close()

    def __enter__(self) -> "ArduCopterEmulator":
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.stop()

    def drop_client(self) -> None:
        """With ``url="tcpin:..."``: close the GCS's TCP connection (it may connect again)."""
        with self.lock:
            port = getattr(self.conn, "port", None)
            if port is not None:
                port.close()
                self.conn.port = None
                self.conn.fd = self.conn.listen.fileno()

    def reboot(self) -> None:
        """Restart like ArduPilot: silent, then new boot time, rates forgotten, origin where it stands."""
        with self.lock:
            self._silent_until = time.monotonic() + self.reboot_silence
            north, east = self.pos[0], self.pos[1]
            lat = self.origin[0] + math.degrees(north / 6_378_137.0)
            lon = self.origin[1] + math.degrees(east / (6_378_137.0 * math.cos(math.radians(self.origin[0]))))
            self.origin = (lat, lon, self.origin[2])
            self.pos, self.vel = [0.0, 0.0, 0.0], [0.0, 0.0, 0.0]
            self.mode, self.armed, self.target, self.vtarget, self.cmd_speed = "STABILIZE", False, None, None, None
            self.landed_state = mav.MAV_LANDED_STATE_ON_GROUND
            self.streaming = set() if self.streams_need_request else set(STREAMS)
            self.reboots += 1
            self._boot = time.monotonic() + self.reboot_silence

    # --- I/O -------------------------------------------------------------------------------------
    def _lost(self) -> bool:
        return self.drop > 0 and self._rng.random() < self.drop

    def _silent(self) -> bool:
        return self.blocked or self.frozen or time.monotonic() < self._silent_until

    def _send(self, name: str, *args: Any) -> None:
        if self._silent():
            return
        if self._lost():
            self.record.dropped_out += 1
            return
        getattr(self.conn.mav, name)(*args)

    def _send_as(self, system: int, component: int, name: str, *args: Any) -> None:
        if self._silent():
            return
        enc = self._encoders.get((system, component))
        if enc is None:
            enc = self._encoders[(system, component)] = mav.MAVLink(self.conn, srcSystem=system, srcComponent=component)
        getattr(enc, name)(*args)

    def _ack(self, command: int, result: int, confirmation: int) -> None:
        self.record.commands.append((command, confirmation, result))
        self._send("command_ack_send", command, result)

    def say(self, text: str, severity: int = mav.MAV_SEVERITY_INFO) -> None:
        """Send a STATUSTEXT (at most 50 characters, as MAVLink 1 carries)."""
        self._send("statustext_send", severity, text.encode()[:50])

    def _loop(self) -> None:
        last = time.monotonic()
        next_hb = next_tel = next_slow = next_prearm = last
        started = last
        while not self._stop.is_set():
            while True:
                msg = self.conn.recv_match(blocking=False)
                if msg is None:
                    break
                if self._lost():
                    self.record.dropped_in += 1
                    continue
                if time.monotonic() < self._silent_until:
                    continue  # rebooting: nothing is heard
                with self.lock:
                    if self.blocked or self.frozen:
                        self._queue.append(msg)
                        continue
                    if self._queue:  # delivered late, in order, like TCP after a block
                        queued, self._queue = self._queue, []
                        self.record.late += len(queued)
                        for m in queued:
                            self._handle(m)
                    self._handle(msg)
            now = time.monotonic()
            with self.lock:
                if not (self.blocked or self.frozen) and self._queue:
                    queued, self._queue = self._queue, []
                    self.record.late += len(queued)
                    for m in queued:
                        self._handle(m)
                self._step(now - last)
            last = now
            if now >= next_hb:
                next_hb = now + 1.0 / self.heartbeat_rate
                self._heartbeats(now - started >= self.autopilot_heartbeat_delay)
            if now >= next_tel:
                next_tel = now + 1.0 / self.telemetry_rate
                if self.telemetry_enabled:
                    self._telemetry()
            if now >= next_slow:
                next_slow = now + 0.25
                if self.telemetry_enabled:
                    self._slow_telemetry()
            if now >= next_prearm:
                next_prearm = now + 1.0
                if not self.ekf_ready and not self.armed:
                    self.say("PreArm: Need Position Estimate", mav.MAV_SEVERITY_CRITICAL)
            time.sleep(0.004)

    def _ms(self) -> int:
        return max(0, int((time.monotonic() - self._boot) * 1000))

    def _heartbeats(self, autopilot: bool) -> None:
        if autopilot and self.heartbeat_enabled:
            base = mav.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED | (mav.MAV_MODE_FLAG_SAFETY_ARMED if self.armed else 0)
            status = mav.MAV_STATE_ACTIVE if self.armed else mav.MAV_STATE_STANDBY
            self._send("heartbeat_send", mav.MAV_TYPE_QUADROTOR, mav.MAV_AUTOPILOT_ARDUPILOTMEGA, base,
                       MODES[self.mode], status)
        for comp, mtype, ap in self.components:
            self._send_as(self.system, comp, "heartbeat_send", mtype, ap, 0, 0, mav.MAV_STATE_ACTIVE)
            self._send_as(self.system, comp, "attitude_send", self._ms(), 0.0, 0.3, 1.0, 0.0, 0.0, 0.0)
        for other in self.other_systems:
            self._send_as(other, 1, "heartbeat_send", mav.MAV_TYPE_QUADROTOR, mav.MAV_AUTOPILOT_ARDUPILOTMEGA,
                          mav.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, MODES["LOITER"], mav.MAV_STATE_STANDBY)
            self._send_as(other, 1, "local_position_ned_send", self._ms(), 9.0, 9.0, -3.0, 0.0, 0.0, 0.0)

    def _telemetry(self) -> None:
        with self.lock:
            p, v, yaw = list(self.pos), list(self.vel), self.yaw
        c = self.corrupt
        if self.ekf_ready and "LOCAL_POSITION_NED" in self.streaming:
            vals = [c.get(k, d) for k, d in zip(("x", "y", "z", "vx", "vy", "vz"), p + v)]
            self._send("local_position_ned_send", self._ms(), *vals)
        if "ATTITUDE" in self.streaming:
            self._send("attitude_send", self._ms(), 0.0, 0.0, c.get("yaw", yaw), 0.0, 0.0, 0.0)

    def _slow_telemetry(self) -> None:
        if "EXTENDED_SYS_STATE" in self.streaming:
            self._send("extended_sys_state_send", mav.MAV_VTOL_STATE_UNDEFINED, self.landed_state)
        if "SYS_STATUS" in self.streaming:
            prearm = mav.MAV_SYS_STATUS_PREARM_CHECK
            healthy = prearm if self.ekf_ready and not self.prearm_failure else 0
            self._send("sys_status_send", prearm, prearm, healthy, 500, 15800, -1, int(self.battery), 0, 0, 0,
                       0, 0, 0)
        if "EKF_STATUS_REPORT" in self.streaming:
            self._send("ekf_status_report_send", EKF_GOOD if self.ekf_ready else 1 | 2, 0.1, 0.1, 0.1, 0.1, 0.0)

    # --- behaviour -------------------------------------------------------------------------------
    def _handle(self, msg: Any) -> None:
        kind = msg.get_type()
        if kind == "HEARTBEAT":
            self.record.gcs_heartbeats += 1
        elif kind == "COMMAND_LONG":
            if msg.target_component not in (0, 1) or msg.target_system not in (0, self.system):
                self.record.to_others.append((int(msg.command), int(msg.target_component)))
                return
            self._command(msg)
        elif kind == "SET_POSITION_TARGET_LOCAL_NED":
            self._position_target(msg)
        elif kind == "REQUEST_DATA_STREAM":
            self.record.data_streams.append((int(msg.req_stream_id), int(msg.req_message_rate)))
            if msg.start_stop:
                self.streaming.update(DATA_STREAM_GROUPS.get(int(msg.req_stream_id), ()))
        elif kind == "PARAM_REQUEST_READ":
            name = msg.param_id.rstrip("\x00") if isinstance(msg.param_id, str) else msg.param_id.decode()
            if name in self.params:
                self._send("param_value_send", name.encode(), self.params[name], mav.MAV_PARAM_TYPE_REAL32,
                           len(self.params), list(self.params).index(name))

    def _command(self, m: Any) -> None:
        cmd, conf = int(m.command), int(m.confirmation)
        self.record.received.append((cmd, conf))
        if cmd in self.ignore_commands:
            return
        if cmd in self.refuse_commands:
            return self._ack(cmd, mav.MAV_RESULT_UNSUPPORTED, conf)
        if cmd == mav.MAV_CMD_DO_SET_MODE:
            name = NAMES.get(int(m.param2))
            if name is None:
                return self._ack(cmd, mav.MAV_RESULT_FAILED, conf)
            if name in self.ignore_modes:
                return None
            if self.deny_modes.get(name, 0) > 0:
                self.deny_modes[name] -= 1
                return self._ack(cmd, mav.MAV_RESULT_DENIED, conf)
            self._enter_mode(name)
            return self._ack(cmd, mav.MAV_RESULT_ACCEPTED, conf)
        if cmd == mav.MAV_CMD_COMPONENT_ARM_DISARM:
            if m.param1 >= 0.5:
                if not self.armed and self.mode not in ARMABLE:
                    return self._ack(cmd, mav.MAV_RESULT_FAILED, conf)
                reason = self.prearm_failure or (None if self.ekf_ready else "Need Position Estimate")
                if not self.armed and reason:
                    text = reason if reason.startswith(("PreArm:", "Arm:")) else f"PreArm: {reason}"
                    if not self.reason_after_ack:
                        self.say(text, mav.MAV_SEVERITY_CRITICAL)
                    self._ack(cmd, mav.MAV_RESULT_FAILED, conf)
                    if self.reason_after_ack:
                        self.say(text, mav.MAV_SEVERITY_CRITICAL)
                    return None
                self.armed = True
            else:
                if self.landed_state != mav.MAV_LANDED_STATE_ON_GROUND and int(m.param2) != 21196:
                    return self._ack(cmd, mav.MAV_RESULT_FAILED, conf)
                self.armed = False
            return self._ack(cmd, mav.MAV_RESULT_ACCEPTED, conf)
        if cmd == mav.MAV_CMD_NAV_TAKEOFF:
            alt = float(m.param7)
            if (self.mode != "GUIDED" or not self.armed
                    or self.landed_state != mav.MAV_LANDED_STATE_ON_GROUND or alt <= -self.pos[2]):
                return self._ack(cmd, mav.MAV_RESULT_FAILED, conf)
            self.record.takeoff_altitudes.append(alt)
            self.takeoff_alt = alt
            self.landed_state = mav.MAV_LANDED_STATE_TAKEOFF
            self.target = None
            return self._ack(cmd, mav.MAV_RESULT_ACCEPTED, conf)
        if cmd == mav.MAV_CMD_DO_CHANGE_SPEED:
            kind, speed = int(m.param1), float(m.param2)
            self.record.speeds.append((kind, speed))
            if not (speed > 0 and math.isfinite(speed)):
                return self._ack(cmd, mav.MAV_RESULT_FAILED, conf)
            if kind in (0, 1):
                self.cmd_speed = speed
            elif kind == 2:
                self.climb_rate = speed
            elif kind == 3:
                self.descent_rate = speed
            return self._ack(cmd, mav.MAV_RESULT_ACCEPTED, conf)
        if cmd == mav.MAV_CMD_SET_MESSAGE_INTERVAL:
            if not self.message_interval_supported:
                return self._ack(cmd, mav.MAV_RESULT_UNSUPPORTED, conf)
            self.record.intervals.append((int(m.param1), float(m.param2)))
            name = mav.mavlink_map[int(m.param1)].msgname if int(m.param1) in mav.mavlink_map else ""
            if name in STREAMS:
                self.streaming.add(name)
            return self._ack(cmd, mav.MAV_RESULT_ACCEPTED, conf)
        if cmd == mav.MAV_CMD_REQUEST_MESSAGE:
            self._ack(cmd, mav.MAV_RESULT_ACCEPTED, conf)
            if int(m.param1) == mav.MAVLINK_MSG_ID_GPS_GLOBAL_ORIGIN:
                lat, lon, alt = self.origin
                self._send("gps_global_origin_send", int(lat * 1e7), int(lon * 1e7), int(alt * 1000))
            return None
        if cmd == mav.MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN:
            if self.armed:
                return self._ack(cmd, mav.MAV_RESULT_FAILED, conf)
            self._ack(cmd, mav.MAV_RESULT_ACCEPTED, conf)
            return self.reboot()
        self._ack(cmd, mav.MAV_RESULT_UNSUPPORTED, conf)

    def _enter_mode(self, name: str) -> None:
        self.mode = name
        self.record.modes.append(name)
        self.record.mode_times.append((name, time.monotonic()))
        self.vtarget = None
        if name in ("BRAKE", "LOITER", "GUIDED"):
            if name != "GUIDED" and self.landed_state == mav.MAV_LANDED_STATE_TAKEOFF:
                self.landed_state = mav.MAV_LANDED_STATE_IN_AIR  # stop climbing where it is
            self.target = None  # BRAKE / GUIDED without a target: stop (decelerating) and hold
        if name == "GUIDED":
            self.cmd_speed = None  # ArduPilot resets the speed to WPNAV_SPEED when GUIDED starts
        if name == "LAND" and self.landed_state != mav.MAV_LANDED_STATE_ON_GROUND:
            self.landed_state = mav.MAV_LANDED_STATE_LANDING
            self.takeoff_alt = None

    def _position_target(self, m: Any) -> None:
        mask = int(m.type_mask)
        self.record.targets.append((float(m.x), float(m.y), float(m.z), mask))
        if self.mode != "GUIDED" or m.coordinate_frame != mav.MAV_FRAME_LOCAL_NED:
            return
        on_ground = self.landed_state == mav.MAV_LANDED_STATE_ON_GROUND
        if not mask & 1024:
            self.yaw = float(m.yaw)
        if not mask & 0b111:  # position target
            if on_ground and abs(m.z - 0.0) > 0.2:
                return  # a landed copter ignores targets in the air (take off first)
            self.target = [float(m.x), float(m.y), 0.0 if on_ground else float(m.z)]
            self.vtarget = None
        elif not mask & 0b111000:  # velocity target
            self.vtarget = [float(m.vx), float(m.vy), 0.0 if on_ground else float(m.vz)]
            self.target = None

    def _brake(self, dt: float, horizontal_only: bool = False) -> None:
        axes = 2 if horizontal_only else 3
        n = math.sqrt(sum(self.vel[i] ** 2 for i in range(axes)))
        if n > 1e-9:
            k = max(0.0, n - self.brake_decel * dt) / n
            for i in range(axes):
                self.vel[i] *= k

    def _approach(self, dt: float, speed: float) -> None:
        d = [self.target[i] - self.pos[i] for i in range(3)] if self.target else [0.0, 0.0, 0.0]
        n = math.sqrt(sum(c * c for c in d))
        want = min(speed, math.sqrt(2 * self.accel * n)) if n > 1e-6 else 0.0
        desired = [d[i] / n * want if n > 1e-6 else 0.0 for i in range(3)]
        dv = [desired[i] - self.vel[i] for i in range(3)]
        m = math.sqrt(sum(c * c for c in dv))
        k = min(1.0, self.accel * dt / m) if m > 1e-9 else 0.0
        self.vel = [self.vel[i] + dv[i] * k for i in range(3)]
        if n <= 1e-3 and m < 1e-3:
            self.pos = list(self.target)

    def _step(self, dt: float) -> None:
        """Advance the motion by ``dt`` [s] in steps of at most ``PHYSICS_STEP``: a loop woken late on
        a loaded machine integrates as finely as an idle one (no overshoot from one long step)."""
        n = max(1, math.ceil(dt / PHYSICS_STEP))
        for _ in range(min(n, 2000)):
            self._physics(dt / n)

    def _physics(self, dt: float) -> None:
        if dt <= 0 or self.frozen or time.monotonic() < self._silent_until:
            return
        ls = self.landed_state
        if self.freeze_motion:
            self.vel = [0.0, 0.0, 0.0]
        elif ls == mav.MAV_LANDED_STATE_TAKEOFF and self.takeoff_alt is not None:
            self._brake(dt, horizontal_only=True)
            self.vel[2] = -self.climb_rate
            if self.pos[2] + self.vel[2] * dt <= -self.takeoff_alt:
                self.vel[2] = (-self.takeoff_alt - self.pos[2]) / dt
                self.landed_state = mav.MAV_LANDED_STATE_IN_AIR
                self.target = [self.pos[0], self.pos[1], -self.takeoff_alt]
        elif ls == mav.MAV_LANDED_STATE_LANDING or (self.mode == "LAND" and ls == mav.MAV_LANDED_STATE_IN_AIR):
            self.landed_state = mav.MAV_LANDED_STATE_LANDING
            self._brake(dt, horizontal_only=True)  # LAND does not stop horizontal motion at once
            self.vel[2] = min(self.descent_rate, -self.pos[2] / dt)
            if self.pos[2] + self.vel[2] * dt >= -1e-9:
                self.landed_state = mav.MAV_LANDED_STATE_ON_GROUND
                self.armed = False  # ArduPilot disarms after landing
                self.target = None
                self.vel = [0.0, 0.0, 0.0]
                self.pos[2] = 0.0
        elif self.mode == "GUIDED" and self.vtarget is not None:
            self.vel = list(self.vtarget)
        elif self.mode == "GUIDED" and self.target is not None:
            on_ground = ls == mav.MAV_LANDED_STATE_ON_GROUND
            cap = self.cmd_speed or (self.walk_speed if on_ground else self.wpnav_speed)
            self._approach(dt, min(cap, self.walk_speed) if on_ground else cap)
        else:
            self._brake(dt)  # BRAKE, LOITER, GUIDED without a target, STABILIZE on the ground
        self.pos = [self.pos[i] + self.vel[i] * dt for i in range(3)]
        if self.landed_state == mav.MAV_LANDED_STATE_ON_GROUND:
            self.pos[2], self.vel[2] = 0.0, 0.0
        self.record.max_speed = max(self.record.max_speed, math.hypot(self.vel[0], self.vel[1]))
        self.battery = max(0.0, self.battery - (0.05 if self.armed else 0.001) * dt)


def free_udp_port() -> int:
    """A UDP port free right now on 127.0.0.1."""
    import socket

    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])
