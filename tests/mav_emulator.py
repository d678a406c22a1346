"""An ArduPilot-Copter-like vehicle for tests: real MAVLink over UDP on 127.0.0.1 (pymavlink).

It implements the behaviours the MAVLink link relies on, the way ArduPilot Copter does them:

- HEARTBEAT (type QUADROTOR, autopilot ARDUPILOTMEGA, Copter custom mode, armed flag);
- MAV_CMD_DO_SET_MODE with Copter mode numbers, answered by COMMAND_ACK;
- MAV_CMD_COMPONENT_ARM_DISARM (arming only in armable modes; disarming only when landed);
- MAV_CMD_NAV_TAKEOFF (only in GUIDED, armed and landed, else MAV_RESULT_FAILED: "can't take off
  again"), altitude above the origin in param7;
- SET_POSITION_TARGET_LOCAL_NED in GUIDED: flies there in the air; on the ground, a target at
  ground height makes the robot *walk* (the aerial-ground robot's ground-motion command set);
- LAND mode descends, reports MAV_LANDED_STATE_ON_GROUND and disarms; BRAKE / LOITER stop;
- telemetry: LOCAL_POSITION_NED, ATTITUDE, SYS_STATUS, EXTENDED_SYS_STATE.

Faults for tests: ``heartbeat_enabled = False`` (silence the heartbeat only), ``drop`` (fraction of
packets lost in each direction), ``deny_modes`` (NACK the next n changes to a mode),
``ignore_commands`` (never answer these MAV_CMDs), ``prearm_failure`` (refuse arming as ArduPilot
does when a pre-arm check fails: a STATUSTEXT ``PreArm: ...`` of severity CRITICAL, then
MAV_RESULT_FAILED); :meth:`say` sends any STATUSTEXT. Speeds are fast so tests stay short.
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


@dataclass
class Record:
    """What the emulator received (for assertions)."""

    received: list[tuple[int, int]] = field(default_factory=list)  # every COMMAND_LONG: (command, confirmation)
    commands: list[tuple[int, int, int]] = field(default_factory=list)  # answered: (command, confirmation, result)
    modes: list[str] = field(default_factory=list)  # accepted mode changes, in order
    takeoff_altitudes: list[float] = field(default_factory=list)
    targets: list[tuple[float, float, float, int]] = field(default_factory=list)  # NED + type_mask
    gcs_heartbeats: int = 0
    dropped_in: int = 0
    dropped_out: int = 0


class ArduCopterEmulator:
    """A simulated ArduPilot Copter sending to a GCS listening on ``127.0.0.1:gcs_port``.

    Args:
        gcs_port: UDP port of the GCS (the link under test, ``udpin:127.0.0.1:<port>``).
        walk_speed, fly_speed, climb_rate, descent_rate: Motion [m/s].
        heartbeat_rate: HEARTBEAT rate [Hz] (ArduPilot: 1 Hz; faster here to keep tests short).
        telemetry_rate: LOCAL_POSITION_NED / ATTITUDE rate [Hz].
        drop: Fraction of packets lost, each direction.
        seed: Random seed of the packet loss.
        start_ned: Initial position (NED) [m].
    """

    def __init__(self, gcs_port: int, *, walk_speed: float = 2.0, fly_speed: float = 4.0,
                 climb_rate: float = 3.0, descent_rate: float = 3.0, heartbeat_rate: float = 5.0,
                 telemetry_rate: float = 25.0, drop: float = 0.0, seed: int = 1,
                 start_ned: tuple[float, float, float] = (0.0, 0.0, 0.0), system: int = 1) -> None:
        self.conn = mavutil.mavlink_connection(f"udpout:127.0.0.1:{gcs_port}", source_system=system,
                                               source_component=1)
        self.walk_speed, self.fly_speed = walk_speed, fly_speed
        self.climb_rate, self.descent_rate = climb_rate, descent_rate
        self.heartbeat_rate, self.telemetry_rate = heartbeat_rate, telemetry_rate
        self.drop = drop
        self._rng = random.Random(seed)
        self.heartbeat_enabled = True
        self.deny_modes: dict[str, int] = {}
        self.ignore_commands: set[int] = set()
        self.prearm_failure: str | None = None
        self.record = Record()
        self.lock = threading.RLock()
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
        self.battery = 100.0
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._loop, name="mav-emulator", daemon=True)
        self._boot = time.monotonic()

    # --- lifecycle -------------------------------------------------------------------------------
    def start(self) -> "ArduCopterEmulator":
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

    # --- I/O -------------------------------------------------------------------------------------
    def _lost(self) -> bool:
        return self.drop > 0 and self._rng.random() < self.drop

    def _send(self, name: str, *args: Any) -> None:
        if self._lost():
            self.record.dropped_out += 1
            return
        getattr(self.conn.mav, name)(*args)

    def _ack(self, command: int, result: int, confirmation: int) -> None:
        self.record.commands.append((command, confirmation, result))
        self._send("command_ack_send", command, result)

    def say(self, text: str, severity: int = mav.MAV_SEVERITY_INFO) -> None:
        """Send a STATUSTEXT (at most 50 characters, as MAVLink 1 carries)."""
        self._send("statustext_send", severity, text.encode()[:50])

    def _loop(self) -> None:
        last = time.monotonic()
        next_hb = next_tel = next_slow = last
        while not self._stop.is_set():
            while True:
                msg = self.conn.recv_match(blocking=False)
                if msg is None:
                    break
                if self._lost():
                    self.record.dropped_in += 1
                    continue
                with self.lock:
                    self._handle(msg)
            now = time.monotonic()
            with self.lock:
                self._physics(now - last)
            last = now
            if now >= next_hb:
                next_hb = now + 1.0 / self.heartbeat_rate
                if self.heartbeat_enabled:
                    self._heartbeat()
            if now >= next_tel:
                next_tel = now + 1.0 / self.telemetry_rate
                self._telemetry()
            if now >= next_slow:
                next_slow = now + 0.25
                self._slow_telemetry()
            time.sleep(0.004)

    def _ms(self) -> int:
        return int((time.monotonic() - self._boot) * 1000)

    def _heartbeat(self) -> None:
        base = mav.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED | (mav.MAV_MODE_FLAG_SAFETY_ARMED if self.armed else 0)
        status = mav.MAV_STATE_ACTIVE if self.armed else mav.MAV_STATE_STANDBY
        self._send("heartbeat_send", mav.MAV_TYPE_QUADROTOR, mav.MAV_AUTOPILOT_ARDUPILOTMEGA, base,
                   MODES[self.mode], status)

    def _telemetry(self) -> None:
        with self.lock:
            p, v, yaw = list(self.pos), list(self.vel), self.yaw
        self._send("local_position_ned_send", self._ms(), p[0], p[1], p[2], v[0], v[1], v[2])
        self._send("attitude_send", self._ms(), 0.0, 0.0, yaw, 0.0, 0.0, 0.0)

    def _slow_telemetry(self) -> None:
        self._send("extended_sys_state_send", mav.MAV_VTOL_STATE_UNDEFINED, self.landed_state)
        self._send("sys_status_send", 0, 0, 0, 500, 15800, -1, int(self.battery), 0, 0, 0, 0, 0, 0)

    # --- behaviour -------------------------------------------------------------------------------
    def _handle(self, msg: Any) -> None:
        kind = msg.get_type()
        if kind == "HEARTBEAT":
            self.record.gcs_heartbeats += 1
        elif kind == "COMMAND_LONG":
            self._command(msg)
        elif kind == "SET_POSITION_TARGET_LOCAL_NED":
            self._position_target(msg)

    def _command(self, m: Any) -> None:
        cmd, conf = int(m.command), int(m.confirmation)
        self.record.received.append((cmd, conf))
        if cmd in self.ignore_commands:
            return
        if cmd == mav.MAV_CMD_DO_SET_MODE:
            name = NAMES.get(int(m.param2))
            if name is None:
                return self._ack(cmd, mav.MAV_RESULT_FAILED, conf)
            if self.deny_modes.get(name, 0) > 0:
                self.deny_modes[name] -= 1
                return self._ack(cmd, mav.MAV_RESULT_DENIED, conf)
            self._enter_mode(name)
            return self._ack(cmd, mav.MAV_RESULT_ACCEPTED, conf)
        if cmd == mav.MAV_CMD_COMPONENT_ARM_DISARM:
            if m.param1 >= 0.5:
                if not self.armed and self.mode not in ARMABLE:
                    return self._ack(cmd, mav.MAV_RESULT_FAILED, conf)
                if not self.armed and self.prearm_failure:
                    self.say(f"PreArm: {self.prearm_failure}", mav.MAV_SEVERITY_CRITICAL)
                    return self._ack(cmd, mav.MAV_RESULT_FAILED, conf)
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
        if cmd == mav.MAV_CMD_SET_MESSAGE_INTERVAL:
            return self._ack(cmd, mav.MAV_RESULT_ACCEPTED, conf)
        self._ack(cmd, mav.MAV_RESULT_UNSUPPORTED, conf)

    def _enter_mode(self, name: str) -> None:
        self.mode = name
        self.record.modes.append(name)
        self.vtarget = None
        if name in ("BRAKE", "LOITER", "GUIDED"):
            if name != "GUIDED" and self.landed_state == mav.MAV_LANDED_STATE_TAKEOFF:
                self.landed_state = mav.MAV_LANDED_STATE_IN_AIR  # stop climbing where it is
            self.target = None if self.landed_state == mav.MAV_LANDED_STATE_ON_GROUND else list(self.pos)
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

    def _physics(self, dt: float) -> None:
        before = list(self.pos)
        ls = self.landed_state
        if ls == mav.MAV_LANDED_STATE_TAKEOFF and self.takeoff_alt is not None:
            goal = -self.takeoff_alt
            self.pos[2] = max(goal, self.pos[2] - self.climb_rate * dt)
            if self.pos[2] <= goal + 1e-6:
                self.landed_state = mav.MAV_LANDED_STATE_IN_AIR
                self.target = list(self.pos)
        elif ls == mav.MAV_LANDED_STATE_LANDING or (self.mode == "LAND" and ls == mav.MAV_LANDED_STATE_IN_AIR):
            self.landed_state = mav.MAV_LANDED_STATE_LANDING
            self.pos[2] = min(0.0, self.pos[2] + self.descent_rate * dt)
            if self.pos[2] >= 0.0:
                self.landed_state = mav.MAV_LANDED_STATE_ON_GROUND
                self.armed = False  # ArduPilot disarms after landing
                self.target = None
        elif self.mode == "GUIDED":
            speed = self.walk_speed if ls == mav.MAV_LANDED_STATE_ON_GROUND else self.fly_speed
            if self.target is not None:
                d = [self.target[i] - self.pos[i] for i in range(3)]
                n = math.sqrt(sum(c * c for c in d))
                step = min(n, speed * dt)
                if n > 1e-9:
                    self.pos = [self.pos[i] + d[i] / n * step for i in range(3)]
            elif self.vtarget is not None:
                self.pos = [self.pos[i] + self.vtarget[i] * dt for i in range(3)]
        self.vel = [(self.pos[i] - before[i]) / dt if dt > 0 else 0.0 for i in range(3)]
        self.battery = max(0.0, self.battery - (0.05 if self.armed else 0.001) * dt)


def free_udp_port() -> int:
    """A UDP port free right now on 127.0.0.1."""
    import socket

    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])
