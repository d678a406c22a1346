"""An ArduPilot-Copter-like vehicle for tests: real MAVLink over UDP on 127.0.0.1 (pymavlink).

It implements the behaviours the MAVLink link relies on, the way ArduPilot Copter does them:

- HEARTBEAT (type QUADROTOR, autopilot ARDUPILOTMEGA, Copter custom mode, armed flag);
- COMMAND_LONGs answered as ArduPilot Copter answers them (only when addressed to the autopilot,
  component 1 or 0; each COMMAND_ACK addressed to its sender): modes, arming, take-off (altitude above
  home), speeds (GUIDED / AUTO only): :mod:`mav_emulator_commands`; GUIDED entering position
  control (the first position target after a mode change, a take-off or velocity targets) sets the
  speed back to WPNAV_SPEED (``fly_speed``), as ``ArduCopter/mode_guided.cpp`` does (see
  :mod:`mav_emulator_physics`); RTL climbs to ``RTL_ALT`` and flies home (``mode_rtl.cpp``);
- the vehicle's own mode changes (battery / GCS failsafe, fence, a second GCS), EKF resets, TIMESYNC,
  duplicated packets, sequence gaps on loss and MAVLink 2 signing: :mod:`mav_emulator_events`;
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
``message_interval_supported``, ``streams_need_request``, ``speed_ignored``, ``duplicate_delay``,
``signing_passphrase``, ``components`` (other components of
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

from mav_emulator_commands import MODES, VehicleCommands
from mav_emulator_events import EKF_GPS_GLITCH, VehicleEvents
from mav_emulator_physics import CopterPhysics

mav = mavutil.mavlink
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
    mode_positions: list[tuple[str, tuple[float, float, float]]] = field(default_factory=list)  # (mode, NED [m] then)
    takeoff_altitudes: list[float] = field(default_factory=list)
    targets: list[tuple[float, float, float, int]] = field(default_factory=list)  # NED + type_mask
    speeds: list[tuple[int, float]] = field(default_factory=list)  # DO_CHANGE_SPEED (type, m/s)
    intervals: list[tuple[int, float]] = field(default_factory=list)  # SET_MESSAGE_INTERVAL (msg id, us)
    data_streams: list[tuple[int, int]] = field(default_factory=list)  # REQUEST_DATA_STREAM (id, rate)
    gcs_heartbeats: int = 0
    dropped_in: int = 0
    dropped_out: int = 0
    late: int = 0  # messages handled after a block
    late_commands: list[tuple[str, float]] = field(default_factory=list)  # (type, seconds late) after a block
    mode_sources: list[tuple[str, str]] = field(default_factory=list)  # (mode, "gcs" or the vehicle's reason)
    target_times: list[float] = field(default_factory=list)  # monotonic [s] of each position target
    targets_ignored: int = 0  # targets outside GUIDED (ArduPilot ignores them)
    targets_invalid: int = 0  # targets with a frame / type mask GUIDED does not take (the vehicle stopped)
    speed_resets: int = 0  # GUIDED entering position control (speed back to WPNAV_SPEED)
    max_height: float = 0.0  # highest point flown [m above the origin]
    rtl_top: float = 0.0  # height RTL climbed to [m]
    duplicated: int = 0  # duplicate packets sent
    unsigned_ignored: int = 0  # unsigned messages ignored (signing required)
    timesyncs: int = 0
    timesync_ts1: int = 0  # ts1 of the last TIMESYNC handled: the GCS's time.monotonic_ns() when it sent it
    # per position target / mode change: timesync_ts1 when it was handled; it was sent after that (in order)
    target_sent_after: list[int] = field(default_factory=list)
    mode_sent_after: list[int] = field(default_factory=list)

    @property
    def mode_changes(self) -> list[str]:
        """:attr:`modes` with repeats folded: a SET_MODE re-sent because its ACK came late (a loaded
        machine) is accepted twice but changes the mode once."""
        return [m for i, m in enumerate(self.modes) if i == 0 or m != self.modes[i - 1]]
    max_speed: float = 0.0  # fastest horizontal speed flown [m/s]


class ArduCopterEmulator(CopterPhysics, VehicleEvents, VehicleCommands):
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
        start_ned: Initial position (NED) [m], on the ground (the ground's height stays there: a robot
            standing on a box above the EKF origin starts at z < 0).
        system: MAVLink system id.
        reboot_silence: How long a reboot keeps the vehicle silent [s].
        url: Another pymavlink connection instead of UDP to ``gcs_port`` (``tcpin:127.0.0.1:PORT``:
            the vehicle listens on TCP like SITL's serial port 0).
    """

    STREAM_NAMES = STREAMS

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
        self.foreign_acks: dict[int, int] = {}  # command -> result also sent to another GCS (254/190) first
        self.ack_delays: dict[int, list[float]] = {}  # command -> delays [s] of its next ACKs (one per ACK)
        self.late_acks: list[tuple[float, int, int, tuple[int, int]]] = []  # (due, command, result, to)
        self.gcs_blocked_modes: set[str] = set()  # FLTMODE_GCSBLOCK
        self.ekf_ready = True
        self.message_interval_supported = True
        self.streams_need_request = False
        self.components: list[tuple[int, int, int]] = []  # (component, MAV_TYPE, MAV_AUTOPILOT)
        self.autopilot_heartbeat_delay = 0.0  # [s] before the autopilot's first heartbeat
        self.other_systems: list[int] = []
        self.freeze_motion = False
        self.speed_ignored = False  # DO_CHANGE_SPEED accepted but never applied (a firmware quirk)
        self.duplicate_delay = 0.0  # [s] every packet also arrives this late (a second telemetry link)
        self.signing_passphrase: str | None = None  # signing required with this key (GCS_Signing.cpp)
        self.ekf_fault_until = 0.0  # monotonic [s]: EKF_STATUS_REPORT reports a glitch until then
        self.battery_unknown = False  # SYS_STATUS without a battery monitor: voltage UINT16_MAX, remaining -1
        self.origin_set = True  # False: no EKF origin yet (GPS_GLOBAL_ORIGIN requests ACCEPTED, never answered)
        self.position_bad = False  # the EKF failsafe's: the position is not trusted (position modes refused)
        self.physics_step = PHYSICS_STEP
        self.after_heartbeat: Any = None  # called (no arguments) right after each autopilot heartbeat is sent
        self.params = {"FS_GCS_ENABLE": 1.0, "FS_GCS_TIMEOUT": 5.0, "FS_EKF_ACTION": 1.0, "RTL_ALT": 1500.0,
                       "SYSID_MYGCS": 255.0}
        self.gcs_failsafe_auto = False  # the GCS failsafe of events.cpp runs by itself (FS_GCS_*, SYSID_MYGCS)
        self.gcs_last_seen = 0.0  # monotonic [s] of the last heartbeat from SYSID_MYGCS (0: never)
        self.failsafe_gcs = False
        self.record = Record()
        self.lock = threading.RLock()
        self._queue: list[tuple[Any, float]] = []  # (message, monotonic [s] read) while blocked
        self._dups: list[tuple[float, bytes]] = []
        self._boot_ns = time.monotonic_ns()
        self._encoders: dict[tuple[int, int], Any] = {}
        # vehicle state (NED)
        self.mode = "STABILIZE"
        self.armed = False
        self.landed_state = mav.MAV_LANDED_STATE_ON_GROUND
        self.pos = list(start_ned)
        self.ground_down = float(start_ned[2])  # it starts on the ground (a raised one: z < 0)
        self.vel = [0.0, 0.0, 0.0]
        self.yaw = 0.0
        self.target: list[float] | None = None  # position target (NED)
        self.vtarget: list[float] | None = None  # velocity target (NED)
        self.vtarget_time = 0.0  # monotonic [s] of the last velocity target
        self.takeoff_alt: float | None = None
        self.home_down = 0.0  # NED z of home (set where the vehicle arms)
        self.cmd_speed: float | None = None
        self.guided_sub = "vel"
        self.rtl_stage = "climb"
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
        self._setup_signing()
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

    def flushed(self, timeout: float = 30.0) -> bool:
        """Wait (up to ``timeout`` [s]) until everything the console's link sent before this call has been
        handled: a TIMESYNC it sent later was (one socket read in order; the link sends one a second with
        ``ts1`` = its ``time.monotonic_ns()``, the clock of this same process). Not while blocked or frozen."""
        since = time.monotonic_ns()
        deadline = time.monotonic() + timeout
        while self.record.timesync_ts1 <= since:
            if time.monotonic() > deadline:
                return False
            time.sleep(0.02)
        return True

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
            self.home_down = self.ground_down = 0.0
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
        m = self.conn.mav
        msg = getattr(m, name.removesuffix("_send") + "_encode")(*args)
        if self._lost():  # lost on the way: the sequence number is used all the same (a gap)
            self.record.dropped_out += 1
            msg.pack(m)
            m.seq = (m.seq + 1) % 256
            return
        m.send(msg)
        self._duplicate(msg.get_msgbuf())

    def _send_as(self, system: int, component: int, name: str, *args: Any) -> None:
        if self._silent():
            return
        enc = self._encoders.get((system, component))
        if enc is None:
            enc = self._encoders[(system, component)] = mav.MAVLink(self.conn, srcSystem=system, srcComponent=component)
        getattr(enc, name)(*args)

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
                        self._queue.append((msg, time.monotonic()))
                        continue
                    self._handle_queue()
                    self._handle(msg)
            now = time.monotonic()
            with self.lock:
                if not (self.blocked or self.frozen):
                    self._handle_queue()
                self._step(now - last)
                self._send_duplicates()
                self._send_late_acks(now)
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
            with self.lock:
                self._failsafe_gcs_check(now)
            if now >= next_prearm:
                next_prearm = now + 1.0
                if not self.ekf_ready and not self.armed:
                    self.say("PreArm: Need Position Estimate", mav.MAV_SEVERITY_CRITICAL)
            time.sleep(0.004)

    def _handle_queue(self) -> None:
        """Deliver what queued during a block, late and in order (like TCP after a block)."""
        if not self._queue:
            return
        queued, self._queue = self._queue, []
        self.record.late += len(queued)
        now = time.monotonic()
        for m, t in queued:
            if m.get_type() in ("COMMAND_LONG", "SET_MODE", "SET_POSITION_TARGET_LOCAL_NED"):
                name = m.get_type() + (f" {int(m.command)}" if m.get_type() == "COMMAND_LONG" else "")
                self.record.late_commands.append((name, now - t))
            self._handle(m)

    def _ms(self) -> int:
        return max(0, int((time.monotonic() - self._boot) * 1000))

    def _heartbeats(self, autopilot: bool) -> None:
        if autopilot and self.heartbeat_enabled:
            base = mav.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED | (mav.MAV_MODE_FLAG_SAFETY_ARMED if self.armed else 0)
            status = mav.MAV_STATE_ACTIVE if self.armed else mav.MAV_STATE_STANDBY
            self._send("heartbeat_send", mav.MAV_TYPE_QUADROTOR, mav.MAV_AUTOPILOT_ARDUPILOTMEGA, base,
                       MODES[self.mode], status)
            if self.after_heartbeat is not None:
                self.after_heartbeat()
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
            volts, left = (65535, -1) if self.battery_unknown else (15800, int(self.battery))  # UINT16_MAX / -1: unknown
            self._send("sys_status_send", prearm, prearm, healthy, 500, volts, -1, left, 0, 0, 0, 0, 0, 0)
        if "EKF_STATUS_REPORT" in self.streaming:
            flags = EKF_GOOD if self.ekf_ready else 1 | 2
            if time.monotonic() < self.ekf_fault_until:  # a reset / glitch: flagged, variances high
                self._send("ekf_status_report_send", flags | EKF_GPS_GLITCH, 0.3, 1.2, 0.4, 0.2, 0.0)
            else:
                self._send("ekf_status_report_send", flags, 0.1, 0.1, 0.1, 0.1, 0.0)

    # --- behaviour -------------------------------------------------------------------------------
    def _handle(self, msg: Any) -> None:
        kind = msg.get_type()
        if kind == "HEARTBEAT":
            self.record.gcs_heartbeats += 1
            self._gcs_heartbeat(msg)
        elif kind == "TIMESYNC":
            self.record.timesyncs += 1
            self.record.timesync_ts1 = max(self.record.timesync_ts1, int(msg.ts1))
            self._timesync(msg)
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


def free_udp_port() -> int:
    """A UDP port free right now on 127.0.0.1."""
    import socket

    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])
