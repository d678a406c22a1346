"""MAVLink link to an ArduPilot (Copter conventions) vehicle, with pymavlink.

Connection strings are pymavlink's: ``udpin:0.0.0.0:14550`` (listen; what ArduPilot SITL's
``--out=udp:127.0.0.1:14550`` talks to), ``udpout:192.168.1.10:14550``, ``tcp:127.0.0.1:5760``
(SITL's first serial port), ``/dev/ttyACM0,115200`` (USB / telemetry radio, baud after the comma).

What the link does, in ArduPilot Copter terms:

- sends a GCS HEARTBEAT at 1 Hz and watches the vehicle's (``link_ok`` turns False after
  ``heartbeat_timeout``);
- sets modes by name through ``MAV_CMD_DO_SET_MODE`` with the Copter custom mode numbers
  (GUIDED 4, LOITER 5, LAND 9, BRAKE 17 ...);
- take-off: GUIDED, arm (``MAV_CMD_COMPONENT_ARM_DISARM``), then ``MAV_CMD_NAV_TAKEOFF`` with the
  altitude above the local origin in ``param7``;
- flight: streams ``SET_POSITION_TARGET_LOCAL_NED`` (``MAV_FRAME_LOCAL_NED``, position-only type
  mask, optionally with yaw) until the target is reached;
- landing: flies above the spot, switches to LAND and waits for ``EXTENDED_SYS_STATE`` to report
  ``MAV_LANDED_STATE_ON_GROUND`` (ArduPilot then disarms by itself);
- walking: the ground-motion command set :class:`GroundMotion` (default: GUIDED, position targets
  at ground height, motors not armed);
- every COMMAND_LONG waits for its COMMAND_ACK, is retried (``confirmation`` counting up) on
  timeout, and a refusal raises :class:`~console.link.base.CommandRejected` naming the command
  and the MAV_RESULT.

State comes from LOCAL_POSITION_NED, ATTITUDE, HEARTBEAT, SYS_STATUS and EXTENDED_SYS_STATE,
converted to the world frame by a :class:`~console.link.ned.NedFrame`.
"""

from __future__ import annotations

import logging
import math
import re
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Literal

import numpy as np

from pipeline.geometry import CameraMount, Intrinsics, camera_pose_in_world
from planner.mission import MissionSegment, SegmentKind

from .base import (CaptureResult, CommandRejected, LinkError, LinkTimeout, Mode, RobotLink, RobotState,
                   RunStatus, SegmentRun)
from .captures import CapturesFolder
from .ned import NedFrame

log = logging.getLogger(__name__)

Vec3 = tuple[float, float, float]

POSITION_ONLY_MASK = 0b0000_1101_1111_1000
"""SET_POSITION_TARGET type_mask: use x, y, z; ignore velocity, acceleration, yaw, yaw rate (3576)."""

POSITION_YAW_MASK = POSITION_ONLY_MASK & ~(1 << 10)
"""... and use yaw (2552)."""

VELOCITY_ONLY_MASK = 0b0000_1001_1100_0111
"""SET_POSITION_TARGET type_mask: use vx, vy, vz and yaw; ignore position, acceleration, yaw rate (2503)."""

LANDED_UNDEFINED, LANDED_ON_GROUND, LANDED_IN_AIR, LANDED_TAKEOFF, LANDED_LANDING = 0, 1, 2, 3, 4
"""MAV_LANDED_STATE values (EXTENDED_SYS_STATE.landed_state)."""

STATUSTEXT_KEPT = 10
"""How many of the vehicle's latest STATUSTEXT messages the link keeps."""
STATUSTEXT_IN_STATE = 5
"""How many of them each state sample carries."""
STATUSTEXT_LEAD = 0.5
"""A refusal is explained by the STATUSTEXT lines from this long [s] before the command on."""

_URL_RE = re.compile(r"^(udpin|udpout|udp|udpbcast|tcp|tcpin):([^:]+):(\d+)$")


def _mavutil() -> Any:
    from pymavlink import mavutil

    return mavutil


def copter_modes() -> dict[str, int]:
    """ArduPilot Copter mode names -> custom mode numbers (``GUIDED`` -> 4, ``LAND`` -> 9 ...)."""
    return {name: num for num, name in _mavutil().mode_mapping_acm.items()}


def statustext_line(msg: Any) -> str:
    """``"SEVERITY: text"`` of a STATUSTEXT message (``"WARNING: PreArm: Need 3D Fix"``)."""
    sev = _mavutil().mavlink.enums["MAV_SEVERITY"].get(int(msg.severity))
    name = sev.name.removeprefix("MAV_SEVERITY_") if sev is not None else f"SEVERITY {int(msg.severity)}"
    text = msg.text.decode(errors="replace") if isinstance(msg.text, bytes) else str(msg.text)
    return f"{name}: {text.rstrip(chr(0)).strip()}"


def parse_connection(url: str) -> tuple[str, int | None]:
    """Check a pymavlink connection string; returns ``(device, baud or None)``.

    Raises:
        LinkError: The string is not ``udpin|udpout|udp|tcp|tcpin:HOST:PORT`` nor a serial device
            with an optional ``,BAUD``.
    """
    text = url.strip()
    if not text:
        raise LinkError("empty MAVLink connection string")
    m = _URL_RE.match(text)
    if m:
        port = int(m.group(3))
        if port > 65535:
            raise LinkError(f"MAVLink connection {url!r}: port {port} is out of range")
        return text, None
    if re.match(r"^[a-z]+:", text) and not re.match(r"^[A-Za-z]:[\\/]", text):
        raise LinkError(
            f"MAVLink connection {url!r}: expected udpin:HOST:PORT, udpout:HOST:PORT, tcp:HOST:PORT, "
            "tcpin:HOST:PORT or a serial device like /dev/ttyACM0,115200")
    device, _, baud_text = text.partition(",")
    baud: int | None = None
    if baud_text:
        try:
            baud = int(baud_text)
        except ValueError:
            raise LinkError(f"MAVLink connection {url!r}: baud rate {baud_text!r} is not a number") from None
        if baud <= 0:
            raise LinkError(f"MAVLink connection {url!r}: baud rate must be > 0")
    if not (device.startswith("/") or device.upper().startswith("COM")):
        raise LinkError(f"MAVLink connection {url!r}: not a udp/tcp address nor a serial device path")
    return device, baud


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
        speed: Walking speed for ``velocity`` targets, and the expected speed for time-outs [m/s].
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
        ack_timeout: Wait for one COMMAND_ACK [s].
        retries: Re-sends of an unacknowledged command.
        setpoint_rate: Position / velocity target re-send rate [Hz].
        position_tolerance: A waypoint counts as reached within this distance [m].
        altitude_tolerance: Take-off height reached within this [m].
        fly_speed: Expected flight speed, for time-outs [m/s].
        climb_rate: Expected climb rate, for time-outs [m/s].
        descent_rate: Expected landing descent rate, for time-outs [m/s].
        timeout_factor: Motion time-out = expected time x this + ``timeout_slack``.
        timeout_slack: [s].
        face_travel: Send a yaw with flight targets so the camera looks where the robot goes.
        state_rate: State stream rate [Hz].
        source_system: Our MAVLink system id (255: a GCS).
        source_component: Our component id (190: MAV_COMP_ID_MISSIONPLANNER).
        message_rate: Rate requested for LOCAL_POSITION_NED / ATTITUDE / EXTENDED_SYS_STATE [Hz]
            (MAV_CMD_SET_MESSAGE_INTERVAL; 0 leaves the vehicle's stream rates alone).
    """

    ned: NedFrame = field(default_factory=NedFrame)
    floor: float = 0.0
    ground: GroundMotion = field(default_factory=GroundMotion)
    flight_mode: str = "GUIDED"
    land_mode: str = "LAND"
    hold_mode: str = "BRAKE"
    heartbeat_timeout: float = 3.0
    ack_timeout: float = 1.5
    retries: int = 3
    setpoint_rate: float = 4.0
    position_tolerance: float = 0.15
    altitude_tolerance: float = 0.1
    fly_speed: float = 0.5
    climb_rate: float = 0.5
    descent_rate: float = 0.3
    timeout_factor: float = 3.0
    timeout_slack: float = 10.0
    face_travel: bool = True
    state_rate: float = 20.0
    source_system: int = 255
    source_component: int = 190
    message_rate: float = 10.0

    def __post_init__(self) -> None:
        modes = copter_modes()
        for name in ("flight_mode", "land_mode", "hold_mode"):
            if getattr(self, name) not in modes:
                raise ValueError(f"MavlinkConfig.{name}: unknown ArduPilot Copter mode {getattr(self, name)!r}")
        if self.ground.mode is not None and self.ground.mode not in modes:
            raise ValueError(f"GroundMotion.mode: unknown ArduPilot Copter mode {self.ground.mode!r}")
        for name in ("heartbeat_timeout", "ack_timeout", "setpoint_rate", "position_tolerance",
                     "altitude_tolerance", "fly_speed", "climb_rate", "descent_rate", "state_rate"):
            v = getattr(self, name)
            if not (v > 0 and math.isfinite(v)):
                raise ValueError(f"MavlinkConfig.{name} must be > 0, got {v}")
        if self.retries < 0:
            raise ValueError(f"MavlinkConfig.retries must be >= 0, got {self.retries}")


class _Stopped(Exception):
    """The running segment was held or aborted."""


@dataclass
class _Vehicle:
    """Latest telemetry (NED, as received)."""

    system: int | None = None
    component: int = 1
    last_heartbeat: float = -math.inf  # monotonic [s]
    custom_mode: int | None = None
    base_mode: int = 0
    system_status: int = 0
    pos_ned: Vec3 | None = None
    vel_ned: Vec3 = (0.0, 0.0, 0.0)
    yaw_ned: float = 0.0
    landed_state: int = LANDED_UNDEFINED
    battery: float | None = None
    voltage: float | None = None
    statustext: list[tuple[int, float, str]] = field(default_factory=list)  # (number, monotonic [s], text)
    statustext_count: int = 0

    @property
    def armed(self) -> bool:
        return bool(self.base_mode & 128)  # MAV_MODE_FLAG_SAFETY_ARMED


class MavlinkLink(RobotLink):
    """A robot reached over MAVLink (ArduPilot Copter firmware).

    Args:
        url: pymavlink connection string (see the module docstring).
        config: Frames, command set and time-outs.
        captures: Photos to serve as the robot's camera (``--captures DIR``).
        camera: Alternatively, a callable returning ``(RGB image, Intrinsics)`` from the robot's
            camera; photos then carry source ``mavlink`` and the pose reported over MAVLink.
        mount: Camera on the robot (robot body frame), for the camera pose of captures.
    """

    def __init__(self, url: str, config: MavlinkConfig = MavlinkConfig(),
                 captures: str | Path | CapturesFolder | None = None,
                 camera: Callable[[], tuple[np.ndarray, Intrinsics]] | None = None,
                 mount: CameraMount = CameraMount()) -> None:
        super().__init__()
        self.url = url
        self.device, self.baud = parse_connection(url)
        self.config = config
        self.captures = (captures if isinstance(captures, CapturesFolder) or captures is None
                         else CapturesFolder(captures))
        self.camera = camera
        self.mount = mount
        self._modes = copter_modes()
        self._mode_names = {v: k for k, v in self._modes.items()}
        self._conn: Any = None
        self._send_lock = threading.Lock()
        self._vlock = threading.Condition()
        self._v = _Vehicle()
        self._acks: dict[int, Any] = {}
        self._stop = threading.Event()
        self._hb_now = threading.Event()
        self._threads: list[threading.Thread] = []
        self._run: SegmentRun | None = None
        self._run_cancel = threading.Event()
        self._run_thread: threading.Thread | None = None
        self._run_lock = threading.Lock()
        self._boot = time.monotonic()
        self.stats = {"sent": 0, "received": 0, "retries": 0, "nacks": 0}

    # --- connection ------------------------------------------------------------------------------
    @property
    def description(self) -> str:
        sysid = self._v.system
        return f"MAVLink {self.url}" + (f" (vehicle system {sysid})" if sysid is not None else "")

    @property
    def connected(self) -> bool:
        return self._conn is not None and not self._stop.is_set()

    @property
    def local_port(self) -> int | None:
        """Our UDP/TCP port (useful with ``udpin:127.0.0.1:0``), or ``None``."""
        try:
            return int(self._conn.port.getsockname()[1])
        except Exception:
            return None

    def open(self) -> None:
        """Open the connection and start the threads without waiting for the vehicle."""
        if self._conn is not None:
            return
        mavutil = _mavutil()
        kwargs: dict[str, Any] = {"source_system": self.config.source_system,
                                  "source_component": self.config.source_component,
                                  "autoreconnect": True}
        if self.baud is not None:
            kwargs["baud"] = self.baud
        try:
            self._conn = mavutil.mavlink_connection(self.device, **kwargs)
        except ImportError as exc:  # pymavlink imports pyserial only for serial devices
            raise LinkError(f"serial MAVLink connections need pyserial (pip install pyserial): {exc}") from None
        except (OSError, ValueError) as exc:
            raise LinkError(f"cannot open MAVLink connection {self.url!r}: {exc}") from None
        self._stop.clear()
        for target, name in ((self._rx_loop, "mav-rx"), (self._heartbeat_loop, "mav-heartbeat"),
                             (self._state_loop, "mav-state")):
            t = threading.Thread(target=target, name=name, daemon=True)
            t.start()
            self._threads.append(t)

    def connect(self, timeout: float = 10.0) -> None:
        """Open the connection and wait for the vehicle's first heartbeat."""
        self.open()
        if not self.wait_heartbeat(timeout):
            self.close()
            raise LinkTimeout(
                f"no heartbeat from a vehicle on {self.url} within {timeout:.0f} s "
                "(is the autopilot / SITL sending to this address?)")
        self._request_streams()

    def wait_heartbeat(self, timeout: float) -> bool:
        with self._vlock:
            return self._vlock.wait_for(lambda: self._v.system is not None, timeout)

    def close(self) -> None:
        self._cancel_run(RunStatus.ABORTED, "link closed")
        self._stop.set()
        self._hb_now.set()
        for t in self._threads:
            t.join(timeout=2.0)
        self._threads = []
        if self._conn is not None:
            try:
                self._conn.close()
            except Exception:
                pass
        self._conn = None

    # --- sending ---------------------------------------------------------------------------------
    def _send(self, fn_name: str, *args: Any) -> None:
        conn = self._conn
        if conn is None:
            raise LinkError("MAVLink link is not open")
        with self._send_lock:
            getattr(conn.mav, fn_name)(*args)
            self.stats["sent"] += 1

    def _target(self) -> tuple[int, int]:
        with self._vlock:
            if self._v.system is None:
                raise LinkError("no vehicle heard yet on " + self.url)
            return self._v.system, self._v.component

    def _heartbeat_loop(self) -> None:
        mav = _mavutil().mavlink
        while not self._stop.is_set():
            self._hb_now.wait(1.0)
            self._hb_now.clear()
            if self._stop.is_set():
                return
            try:
                self._send("heartbeat_send", mav.MAV_TYPE_GCS, mav.MAV_AUTOPILOT_INVALID, 0, 0,
                           mav.MAV_STATE_ACTIVE)
            except Exception as exc:  # a closed socket while shutting down
                log.debug("heartbeat not sent: %s", exc)

    def _request_streams(self) -> None:
        """Ask for the telemetry we read (fire and forget; ArduPilot streams by default too)."""
        if self.config.message_rate <= 0:
            return
        mav = _mavutil().mavlink
        interval_us = 1e6 / self.config.message_rate
        for msg_id in (mav.MAVLINK_MSG_ID_LOCAL_POSITION_NED, mav.MAVLINK_MSG_ID_ATTITUDE,
                       mav.MAVLINK_MSG_ID_EXTENDED_SYS_STATE, mav.MAVLINK_MSG_ID_SYS_STATUS):
            try:
                sys_id, comp = self._target()
                self._send("command_long_send", sys_id, comp, mav.MAV_CMD_SET_MESSAGE_INTERVAL, 0,
                           msg_id, interval_us, 0, 0, 0, 0, 0)
            except LinkError as exc:
                log.debug("stream request not sent: %s", exc)

    # --- receiving -------------------------------------------------------------------------------
    def _rx_loop(self) -> None:
        while not self._stop.is_set():
            conn = self._conn
            if conn is None:
                return
            try:
                msg = conn.recv_match(blocking=True, timeout=0.05)
            except Exception as exc:  # socket closed under us, serial unplugged
                if self._stop.is_set():
                    return
                log.warning("MAVLink receive error on %s: %s", self.url, exc)
                time.sleep(0.2)
                continue
            if msg is not None:
                self._handle(msg)

    def _handle(self, msg: Any) -> None:
        mav = _mavutil().mavlink
        kind = msg.get_type()
        if kind == "BAD_DATA":
            return
        src = msg.get_srcSystem()
        with self._vlock:
            v = self._v
            if kind == "HEARTBEAT":
                if v.system is None and msg.type != mav.MAV_TYPE_GCS and msg.autopilot != mav.MAV_AUTOPILOT_INVALID:
                    v.system, v.component = src, msg.get_srcComponent()
                    log.info("vehicle found on %s: system %d component %d", self.url, v.system, v.component)
                    self._hb_now.set()  # answer with our heartbeat at once
                if src == v.system and msg.get_srcComponent() == v.component:
                    v.last_heartbeat = time.monotonic()
                    v.custom_mode = int(msg.custom_mode)
                    v.base_mode = int(msg.base_mode)
                    v.system_status = int(msg.system_status)
                self._vlock.notify_all()
                return
            if v.system is None or src != v.system:
                return
            self.stats["received"] += 1
            if kind == "LOCAL_POSITION_NED":
                v.pos_ned = (float(msg.x), float(msg.y), float(msg.z))
                v.vel_ned = (float(msg.vx), float(msg.vy), float(msg.vz))
            elif kind == "ATTITUDE":
                v.yaw_ned = float(msg.yaw)
            elif kind == "EXTENDED_SYS_STATE":
                v.landed_state = int(msg.landed_state)
            elif kind == "SYS_STATUS":
                v.battery = None if msg.battery_remaining < 0 else msg.battery_remaining / 100.0
                v.voltage = None if msg.voltage_battery in (0, 65535) else msg.voltage_battery / 1000.0
            elif kind == "COMMAND_ACK":
                self._acks[int(msg.command)] = msg
            elif kind == "STATUSTEXT":
                v.statustext_count += 1
                entry = (v.statustext_count, time.monotonic(), statustext_line(msg))
                v.statustext = (v.statustext + [entry])[-STATUSTEXT_KEPT:]
            self._vlock.notify_all()

    # --- state -----------------------------------------------------------------------------------
    def _state_loop(self) -> None:
        period = 1.0 / self.config.state_rate
        while not self._stop.wait(period):
            st = self._make_state()
            if st is not None:
                self._stream.publish(st)

    def heartbeat_age(self) -> float:
        """Seconds since the vehicle's last heartbeat (``inf`` before the first)."""
        with self._vlock:
            return time.monotonic() - self._v.last_heartbeat

    def _landed(self, v: _Vehicle) -> bool:
        if v.landed_state != LANDED_UNDEFINED:
            return v.landed_state == LANDED_ON_GROUND
        if v.pos_ned is None:
            return not v.armed
        floor_down = -self.config.ned.altitude(self.config.floor)
        return not v.armed and v.pos_ned[2] > floor_down - 0.1

    def _make_state(self) -> RobotState | None:
        ned = self.config.ned
        with self._vlock:
            v = self._v
            if v.system is None:
                return None
            age = time.monotonic() - v.last_heartbeat
            pos = ned.to_world(v.pos_ned) if v.pos_ned is not None else ned.origin
            vel = ned.velocity_to_world(v.vel_ned)
            yaw = ned.yaw_to_world(v.yaw_ned)
            landed = self._landed(v)
            mode_name = self._mode_names.get(v.custom_mode, f"mode {v.custom_mode}") if v.custom_mode is not None else ""
            status, armed = v.system_status, v.armed
            battery, voltage, landed_state, has_pos = v.battery, v.voltage, v.landed_state, v.pos_ned is not None
            messages = tuple((n, text) for n, _, text in v.statustext[-STATUSTEXT_IN_STATE:])
        run = self._run
        if run is not None and not run.done:
            mode = {SegmentKind.WALK: Mode.WALKING, SegmentKind.TAKEOFF: Mode.TAKING_OFF,
                    SegmentKind.FLY: Mode.FLYING, SegmentKind.LAND: Mode.LANDING}[run.segment.kind]
        elif status >= 5:  # MAV_STATE_CRITICAL / EMERGENCY: the autopilot's failsafe acts
            mode = Mode.FAILSAFE
        elif landed_state == LANDED_TAKEOFF:
            mode = Mode.TAKING_OFF
        elif landed_state == LANDED_LANDING or (mode_name == self.config.land_mode and not landed):
            mode = Mode.LANDING
        else:
            mode = Mode.IDLE if landed else Mode.HOLDING
        link_ok = age <= self.config.heartbeat_timeout
        if not link_ok:
            health = f"no heartbeat for {age:.1f} s"
        elif not has_pos:
            health = "no LOCAL_POSITION_NED yet (no position estimate?)"
        elif status >= 5:
            health = "autopilot failsafe (system status CRITICAL/EMERGENCY)"
        else:
            health = "ok"
        return RobotState(time=time.time(), position=pos, yaw=yaw, velocity=vel, mode=mode, armed=armed,
                          landed=landed, battery=battery, battery_voltage=voltage, link_ok=link_ok,
                          link_age=age if math.isfinite(age) else 1e9, health=health, autopilot_mode=mode_name,
                          messages=messages)

    # --- commands --------------------------------------------------------------------------------
    def command(self, command: int, params: tuple[float, ...], what: str,
                verify: Callable[[], bool] | None = None, cancel: threading.Event | None = None,
                component: int | None = None) -> None:
        """Send a COMMAND_LONG and wait for its COMMAND_ACK, retrying on silence.

        Args:
            command: MAV_CMD number.
            params: Up to 7 parameters.
            what: Human description for errors (``mode change to GUIDED``).
            verify: Returns True once the command's effect is seen in the telemetry; a lost ACK
                (or the refusal of a retry whose first copy worked) then counts as success.
            cancel: Stop waiting when set (raises the internal stop signal).
            component: Target component (default: the autopilot).

        Raises:
            CommandRejected: The vehicle answered with a MAV_RESULT other than ACCEPTED.
            LinkTimeout: No answer after ``retries`` re-sends.
        """
        mav = _mavutil().mavlink
        sys_id, comp = self._target()
        if component is not None:
            comp = component
        p = list(params) + [0.0] * (7 - len(params))
        attempts = self.config.retries + 1
        sent_at = time.monotonic()
        for attempt in range(attempts):
            if cancel is not None and cancel.is_set():
                raise _Stopped()
            with self._vlock:
                self._acks.pop(command, None)
            if attempt:
                self.stats["retries"] += 1
                log.info("%s: no COMMAND_ACK, retry %d/%d", what, attempt, attempts - 1)
            self._send("command_long_send", sys_id, comp, command, attempt, *p)
            deadline = time.monotonic() + self.config.ack_timeout
            ack = None
            with self._vlock:
                while True:
                    ack = self._acks.pop(command, None)
                    if ack is not None and ack.result == mav.MAV_RESULT_IN_PROGRESS:
                        deadline = time.monotonic() + self.config.ack_timeout
                        ack = None
                    if ack is not None:
                        break
                    left = deadline - time.monotonic()
                    if left <= 0 or (cancel is not None and cancel.is_set()):
                        break
                    self._vlock.wait(min(left, 0.05))
            if ack is None:
                if verify is not None and verify():
                    return
                continue
            if ack.result == mav.MAV_RESULT_ACCEPTED:
                return
            if verify is not None and verify():
                return  # the refusal answers a re-send of a command that had already worked
            self.stats["nacks"] += 1
            result = mav.enums["MAV_RESULT"][ack.result].name if ack.result in mav.enums["MAV_RESULT"] else str(ack.result)
            said = self._statustext_since(sent_at - STATUSTEXT_LEAD)
            raise CommandRejected(f"{what} rejected by the vehicle: {result}"
                                  + (f" (vehicle says: {'; '.join(said)})" if said else ""))
        if cancel is not None and cancel.is_set():
            raise _Stopped()
        raise LinkTimeout(f"{what}: no COMMAND_ACK from the vehicle after {attempts} attempt(s) "
                          f"({self.config.ack_timeout:.1f} s each)")

    def _statustext_since(self, t: float) -> list[str]:
        """The vehicle's STATUSTEXT lines received since monotonic time ``t`` (a refusal's reasons:
        ArduPilot sends e.g. ``PreArm: Need 3D Fix`` with a refused arming)."""
        with self._vlock:
            return [text for _, when, text in self._v.statustext if when >= t]

    def vehicle_mode(self) -> str | None:
        """The autopilot's current mode name, from its heartbeat."""
        with self._vlock:
            cm = self._v.custom_mode
        return None if cm is None else self._mode_names.get(cm, f"mode {cm}")

    def set_mode(self, name: str, cancel: threading.Event | None = None) -> None:
        """Switch the autopilot to a mode by name (``GUIDED``, ``LAND``, ``BRAKE`` ...)."""
        mav = _mavutil().mavlink
        key = name.upper()
        if key not in self._modes:
            raise LinkError(f"unknown ArduPilot Copter mode {name!r}; known: {', '.join(sorted(self._modes))}")
        if self.vehicle_mode() == key:
            return
        number = self._modes[key]
        self.command(mav.MAV_CMD_DO_SET_MODE, (mav.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, number),
                     f"mode change to {key}", verify=lambda: self.vehicle_mode() == key, cancel=cancel)

    def arm(self, cancel: threading.Event | None = None) -> None:
        mav = _mavutil().mavlink
        self.command(mav.MAV_CMD_COMPONENT_ARM_DISARM, (1,), "arming", verify=lambda: self._v.armed, cancel=cancel)

    def disarm(self, cancel: threading.Event | None = None) -> None:
        mav = _mavutil().mavlink
        self.command(mav.MAV_CMD_COMPONENT_ARM_DISARM, (0,), "disarming", verify=lambda: not self._v.armed,
                     cancel=cancel)

    def _airborne(self) -> bool:
        with self._vlock:
            return not self._landed(self._v)

    def takeoff(self, altitude: float, cancel: threading.Event | None = None) -> None:
        """MAV_CMD_NAV_TAKEOFF to ``altitude`` [m] above the local origin (GUIDED, armed)."""
        mav = _mavutil().mavlink
        floor_down = -self.config.ned.altitude(self.config.floor)  # NED down of the floor [m]

        def climbing() -> bool:
            with self._vlock:
                v = self._v
                rising = v.pos_ned is not None and v.pos_ned[2] < floor_down - 0.05
                return rising or v.landed_state in (LANDED_TAKEOFF, LANDED_IN_AIR)

        self.command(mav.MAV_CMD_NAV_TAKEOFF, (0, 0, 0, math.nan, 0, 0, altitude),
                     f"take-off to {altitude:.2f} m", verify=climbing, cancel=cancel)

    def send_position_target(self, world: Vec3, yaw: float | None = None, component: int | None = None) -> None:
        """One SET_POSITION_TARGET_LOCAL_NED (MAV_FRAME_LOCAL_NED) to a world point [m]."""
        mav = _mavutil().mavlink
        sys_id, comp = self._target()
        n, e, d = self.config.ned.to_ned(world)
        mask = POSITION_ONLY_MASK if yaw is None else POSITION_YAW_MASK
        y = 0.0 if yaw is None else self.config.ned.yaw_to_ned(yaw)
        self._send("set_position_target_local_ned_send", self._ms(), sys_id,
                   comp if component is None else component, mav.MAV_FRAME_LOCAL_NED, mask,
                   n, e, d, 0, 0, 0, 0, 0, 0, y, 0)

    def send_velocity_target(self, v_world: Vec3, yaw: float | None = None, component: int | None = None) -> None:
        """One SET_POSITION_TARGET_LOCAL_NED with a world velocity [m/s]."""
        mav = _mavutil().mavlink
        sys_id, comp = self._target()
        vn, ve, vd = self.config.ned.velocity_to_ned(v_world)
        mask = VELOCITY_ONLY_MASK if yaw is not None else VELOCITY_ONLY_MASK | (1 << 10)
        y = 0.0 if yaw is None else self.config.ned.yaw_to_ned(yaw)
        self._send("set_position_target_local_ned_send", self._ms(), sys_id,
                   comp if component is None else component, mav.MAV_FRAME_LOCAL_NED, mask,
                   0, 0, 0, vn, ve, vd, 0, 0, 0, y, 0)

    def _ms(self) -> int:
        return int((time.monotonic() - self._boot) * 1000) & 0xFFFFFFFF

    # --- segments --------------------------------------------------------------------------------
    def run_segment(self, segment: MissionSegment) -> SegmentRun:
        if not self.connected:
            raise LinkError("the MAVLink link is not connected")
        with self._run_lock:
            if self._run is not None and not self._run.done:
                raise LinkError(f"a {self._run.segment.kind.value} segment is still running: hold or abort it first")
            run = SegmentRun(segment)
            cancel = threading.Event()
            self._run, self._run_cancel = run, cancel
            t = threading.Thread(target=self._execute, args=(run, cancel), name="mav-segment", daemon=True)
            self._run_thread = t
            t.start()
        return run

    def _execute(self, run: SegmentRun, cancel: threading.Event) -> None:
        try:
            kind = run.segment.kind
            if kind is SegmentKind.WALK:
                self._do_walk(run, cancel)
            elif kind is SegmentKind.TAKEOFF:
                self._do_takeoff(run, cancel)
            elif kind is SegmentKind.FLY:
                self._do_fly(run, cancel)
            else:
                self._do_land(run, cancel)
            run.finish(RunStatus.DONE)
        except _Stopped:
            pass  # hold()/abort() already finished the run
        except LinkError as exc:
            run.finish(RunStatus.FAILED, str(exc))
        except Exception as exc:  # keep the console alive whatever happens
            log.exception("segment execution failed")
            run.finish(RunStatus.FAILED, f"internal error: {exc}")

    def _position(self) -> np.ndarray:
        with self._vlock:
            ned = self._v.pos_ned
        if ned is None:
            raise LinkError("no LOCAL_POSITION_NED from the vehicle: it has no local position estimate")
        return np.asarray(self.config.ned.to_world(ned))

    def _floor(self) -> float:
        return float(self.config.floor)

    def _motion_timeout(self, distance: float, speed: float) -> float:
        return distance / speed * self.config.timeout_factor + self.config.timeout_slack

    def _wait(self, done: Callable[[], bool], timeout: float, what: str, cancel: threading.Event,
              each: Callable[[], None] | None = None) -> None:
        """Poll ``done`` at the set-point rate (calling ``each`` first) until true or time-out."""
        period = 1.0 / self.config.setpoint_rate
        deadline = time.monotonic() + timeout
        while True:
            if cancel.is_set():
                raise _Stopped()
            if each is not None:
                each()
            if done():
                return
            if time.monotonic() > deadline:
                raise LinkTimeout(f"{what} not reached within {timeout:.0f} s")
            cancel.wait(period)

    def _go_to(self, run: SegmentRun, cancel: threading.Event, target: np.ndarray, index: int, ground: bool,
               progress: Callable[[float], float]) -> None:
        """Stream targets to one waypoint until within tolerance (horizontal on the ground)."""
        cfg = self.config
        start = self._position()
        dist0 = float(np.linalg.norm((target - start)[:2] if ground else target - start))
        heading = math.atan2(target[1] - start[1], target[0] - start[0]) if dist0 > 0.05 else None
        yaw = heading if cfg.face_travel else None
        comp = cfg.ground.target_component if ground else None
        speed = cfg.ground.speed if ground else cfg.fly_speed

        def remaining() -> float:
            d = target - self._position()
            return float(np.linalg.norm(d[:2] if ground else d))

        def send() -> None:
            if ground and cfg.ground.command == "velocity":
                d = target - self._position()
                d[2] = 0.0
                n = float(np.linalg.norm(d))
                v = d / n * min(cfg.ground.speed, n * cfg.setpoint_rate) if n > 1e-6 else np.zeros(3)
                self.send_velocity_target((float(v[0]), float(v[1]), 0.0), yaw, comp)
            else:
                self.send_position_target((float(target[0]), float(target[1]), float(target[2])), yaw, comp)
            run.update(progress(max(0.0, dist0 - remaining())), index)

        what = f"{'walk' if ground else 'flight'} waypoint {index} ({target[0]:.2f}, {target[1]:.2f}, {target[2]:.2f})"
        self._wait(lambda: remaining() <= cfg.position_tolerance, self._motion_timeout(dist0, speed), what,
                   cancel, send)
        if ground and cfg.ground.command == "velocity":
            self.send_velocity_target((0.0, 0.0, 0.0), None, comp)

    def _follow(self, run: SegmentRun, cancel: threading.Event, points: list[np.ndarray], ground: bool,
                first_index: int = 0) -> None:
        here = self._position()
        legs = [here] + points
        lengths = [float(np.linalg.norm((legs[i + 1] - legs[i])[:2] if ground else legs[i + 1] - legs[i]))
                   for i in range(len(points))]
        total = sum(lengths) or 1.0
        done = 0.0
        for i, p in enumerate(points):
            base = done
            self._go_to(run, cancel, p, first_index + i, ground, lambda d, b=base: (b + d) / total)
            done += lengths[i]
            run.update(done / total, first_index + i + 1)

    def _do_walk(self, run: SegmentRun, cancel: threading.Event) -> None:
        g = self.config.ground
        if self._airborne():
            raise LinkError("cannot walk: the vehicle is in the air (land first)")
        if g.mode is not None:
            self.set_mode(g.mode, cancel)
        if g.arm:
            with self._vlock:
                armed = self._v.armed
            if not armed:
                self.arm(cancel)
        floor = self._floor()
        pts = [np.array([w[0], w[1], floor]) for w in run.segment.waypoints]
        here = self._position()
        if float(np.linalg.norm((pts[0] - here)[:2])) <= self.config.position_tolerance:
            pts = pts[1:]
            first = 1
        else:
            first = 0
        self._follow(run, cancel, pts, ground=True, first_index=first)

    def _do_takeoff(self, run: SegmentRun, cancel: threading.Event) -> None:
        cfg = self.config
        spot, top = (np.asarray(w, dtype=np.float64) for w in run.segment.waypoints)
        here = self._position()
        if self._airborne():
            self.set_mode(cfg.flight_mode, cancel)
            self._follow(run, cancel, [top], ground=False, first_index=1)
            return
        gap = float(np.linalg.norm((spot - here)[:2]))
        if gap > max(0.5, 3 * cfg.position_tolerance):
            raise LinkError(f"take-off spot ({spot[0]:.2f}, {spot[1]:.2f}) is {gap:.2f} m from the vehicle")
        self.set_mode(cfg.flight_mode, cancel)
        with self._vlock:
            armed = self._v.armed
        if not armed:
            self.arm(cancel)
        alt = cfg.ned.altitude(float(top[2]))
        self.takeoff(alt, cancel)
        z0 = float(here[2])

        def climbed() -> bool:
            z = float(self._position()[2])
            run.update(0.9 * max(0.0, z - z0) / max(1e-6, float(top[2]) - z0), 1)
            return z >= float(top[2]) - cfg.altitude_tolerance

        self._wait(climbed, self._motion_timeout(float(top[2]) - z0, cfg.climb_rate), f"take-off height {top[2]:.2f} m",
                   cancel)
        if float(np.linalg.norm((top - self._position())[:2])) > cfg.position_tolerance:
            self._go_to(run, cancel, top, 1, False, lambda d: 0.95)

    def _do_fly(self, run: SegmentRun, cancel: threading.Event) -> None:
        if not self._airborne():
            raise LinkError("cannot fly: the vehicle is on the ground (take off first)")
        self.set_mode(self.config.flight_mode, cancel)
        pts = [np.asarray(w, dtype=np.float64) for w in run.segment.waypoints]
        if float(np.linalg.norm(pts[0] - self._position())) <= self.config.position_tolerance:
            self._follow(run, cancel, pts[1:], ground=False, first_index=1)
        else:
            self._follow(run, cancel, pts, ground=False, first_index=0)

    def _do_land(self, run: SegmentRun, cancel: threading.Event) -> None:
        cfg = self.config
        if not self._airborne():
            return
        above, spot = (np.asarray(w, dtype=np.float64) for w in run.segment.waypoints)
        here = self._position()
        if float(np.linalg.norm((above - here)[:2])) > cfg.position_tolerance:
            self.set_mode(cfg.flight_mode, cancel)
            self._go_to(run, cancel, np.array([above[0], above[1], max(above[2], here[2])]), 0, False,
                        lambda d: 0.2)
        self.set_mode(cfg.land_mode, cancel)
        z0 = float(self._position()[2])

        def landed() -> bool:
            z = float(self._position()[2])
            run.update(0.2 + 0.8 * max(0.0, z0 - z) / max(1e-6, z0 - self._floor()), 1)
            return not self._airborne()

        self._wait(landed, self._motion_timeout(z0 - self._floor(), cfg.descent_rate), "landing (on ground)", cancel)

    # --- hold / abort ----------------------------------------------------------------------------
    def _cancel_run(self, status: RunStatus, why: str) -> SegmentRun | None:
        with self._run_lock:
            run, cancel, thread = self._run, self._run_cancel, self._run_thread
        if run is None or run.done:
            return None
        run.finish(status, why)
        cancel.set()
        if thread is not None and thread is not threading.current_thread():
            thread.join(timeout=self.config.ack_timeout + 1.0)
        return run

    def hold(self) -> None:
        """Stop: BRAKE (``hold_mode``) in the air, a target at the current spot on the ground."""
        self._cancel_run(RunStatus.HELD, "held by the operator")
        self._stop_here()

    def abort(self) -> None:
        self._cancel_run(RunStatus.ABORTED, "aborted by the operator")
        self._stop_here()

    def _stop_here(self) -> None:
        if not self.connected:
            raise LinkError("the MAVLink link is not connected")
        if self._airborne():
            self.set_mode(self.config.hold_mode)
            return
        g = self.config.ground
        try:
            here = self._position()
        except LinkError:
            return
        if g.command == "velocity":
            self.send_velocity_target((0.0, 0.0, 0.0), None, g.target_component)
        else:
            self.send_position_target((float(here[0]), float(here[1]), self._floor()), None, g.target_component)

    # --- camera ----------------------------------------------------------------------------------
    def capture(self) -> CaptureResult:
        st = self.latest_state()
        if st is None:
            raise LinkError("no state from the vehicle yet: cannot place a photo")
        robot = st.pose
        cam = camera_pose_in_world(robot, self.mount)
        if self.camera is not None:
            image, intr = self.camera()
            return CaptureResult(image, intr, cam, robot, self.mount, time.time(), "mavlink", "camera")
        if self.captures is not None:
            p = self.captures.next()
            return CaptureResult(p.image, p.intrinsics, cam, robot, self.mount, time.time(), "captures-folder",
                                 p.name, p.ground_truth)
        raise LinkError("this MAVLink link has no camera: start the console with --captures DIR "
                        "to use photos from a folder")


__all__ = ["MavlinkLink", "MavlinkConfig", "GroundMotion", "NedFrame", "parse_connection", "copter_modes",
           "POSITION_ONLY_MASK", "POSITION_YAW_MASK", "VELOCITY_ONLY_MASK"]
