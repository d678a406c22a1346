"""MAVLink command handshakes (ArduPilot Copter conventions).

:class:`Commander` sends COMMAND_LONGs to the vehicle's (system, component), waits for each
COMMAND_ACK and re-sends with ``confirmation`` counting up on silence; a refusal raises
:class:`~console.link.base.CommandRejected` naming the command, the MAV_RESULT and the vehicle's
own reasons: only ``PreArm:`` / ``Arm:`` lines or lines of severity WARNING and worse, received
after the command was first sent and no later than ``nack_window`` after the refusal (ArduPilot
sends ``Arm: Need Position Estimate`` just after the ACK). A command is never re-sent more than
``max_age`` seconds after it was decided, so nothing goes out late after a link outage.

Late ACKs: COMMAND_ACK carries no sequence number (only the command id; ArduPilot does not echo
``confirmation``), so the ACK of a re-sent copy that arrives after its command has ended would be read
as the answer to the next command of the same id (a stale ACCEPTED hiding a refusal). As QGroundControl
does (one command of an id on the wire at a time), the copies an ended command left unanswered are
*owed* ACKs: the vehicle answers in the order it receives, so the first ACKs of that id read after the
next command was sent (within the retry window, ``(retries + 1) x ack_timeout``, at most ``max_age``,
from the last copy) answer those copies and are dropped (``stats["late_acks"]``). An owed ACK that was
lost costs the next command one ``ack_timeout`` (its own answer is dropped in its place; the re-send is
answered), never a wrong answer. Only a command that was re-sent or ended without its ACK leaves ACKs
owed.

Mode authority: every mode command, arming, take-off and target first checks that the vehicle is
still in the console's control (:class:`~console.link.mavlink_authority.ModeAuthority`); a vehicle that
switched mode by itself gets nothing (:class:`~console.link.mavlink_authority.VehicleInControl`).
The controller in use is tracked (``controller``: ``pos`` after a position target, ``vel``, ``other``
after a mode change or a take-off) because ArduCopter resets the speed when GUIDED enters position
control (``ArduCopter/mode_guided.cpp``): ``controller_changes`` counts the entries into position
control so the speed can be sent again after each.

Also here: modes by name (``MAV_CMD_DO_SET_MODE`` with Copter custom mode numbers), arming,
take-off (``MAV_CMD_NAV_TAKEOFF``, altitude above home in ``param7``), speeds
(``MAV_CMD_DO_CHANGE_SPEED``) and ``SET_POSITION_TARGET_LOCAL_NED`` targets (world frame in,
``MAV_FRAME_LOCAL_NED`` out).
"""

from __future__ import annotations

import logging
import math
import threading
import time
from typing import Any, Callable

from console.link.base import CommandRejected, LinkError, LinkTimeout
from console.link.mavlink_authority import VehicleInControl
from console.link.mavlink_telemetry import Telemetry
from console.link.mavlink_transport import MavTransport, mavutil
from console.link.ned import NedFrame

log = logging.getLogger(__name__)

Vec3 = tuple[float, float, float]

POSITION_ONLY_MASK = 0b0000_1101_1111_1000
"""SET_POSITION_TARGET type_mask: use x, y, z; ignore velocity, acceleration, yaw, yaw rate (3576)."""

POSITION_YAW_MASK = POSITION_ONLY_MASK & ~(1 << 10)
"""... and use yaw (2552)."""

VELOCITY_ONLY_MASK = 0b0000_1001_1100_0111
"""SET_POSITION_TARGET type_mask: use vx, vy, vz and yaw; ignore position, acceleration, yaw rate (2503)."""

SPEED_GROUND, SPEED_CLIMB, SPEED_DESCENT = 1, 2, 3
"""MAV_CMD_DO_CHANGE_SPEED speed types (param1) ArduPilot Copter understands."""


def copter_modes() -> dict[str, int]:
    """ArduPilot Copter mode names -> custom mode numbers (``GUIDED`` -> 4, ``LAND`` -> 9 ...)."""
    return {name: num for num, name in mavutil().mode_mapping_acm.items()}


class Stopped(Exception):
    """The running segment was held or aborted (raised inside segment execution)."""


def _reason_line(text: str, severity: int) -> bool:
    body = text.split(": ", 1)[-1]
    return body.startswith(("PreArm:", "Arm:")) or severity <= 4  # MAV_SEVERITY_WARNING and worse


class Commander:
    """Command handshakes with one vehicle.

    Args:
        transport: Where commands go.
        telemetry: Where ACKs, mode and STATUSTEXT come from.
        ned: World <-> local NED.
        target: Returns the vehicle's ``(system, component)``.
        ack_timeout: Wait for one COMMAND_ACK [s].
        retries: Re-sends of an unacknowledged command.
        max_age: No re-send later than this after the first send [s].
        nack_window: How long after a refusal its reasons are collected [s].
        stats: Shared counters (``retries``, ``nacks``).
    """

    def __init__(self, transport: MavTransport, telemetry: Telemetry, ned: NedFrame,
                 target: Callable[[], tuple[int, int]], ack_timeout: float, retries: int, max_age: float,
                 nack_window: float, stats: dict[str, int]) -> None:
        self.transport, self.tel, self.ned, self.target = transport, telemetry, ned, target
        self.ack_timeout, self.retries, self.max_age, self.nack_window = ack_timeout, retries, max_age, nack_window
        self.stats = stats
        self.modes = copter_modes()
        self.mode_names = {v: k for k, v in self.modes.items()}
        self._boot = time.monotonic()
        self.bad_signatures: Callable[[], int] = lambda: transport.bad_signatures
        self.controller = "other"  # "pos", "vel" or "other" (after a mode change, a take-off)
        self.controller_changes = 0  # entries into position control
        self._owed: dict[int, tuple[int, float]] = {}  # command -> (ACKs owed to ended copies, drain until)

    def check_control(self, what: str) -> None:
        '''Raise VehicleInControl if the vehicle switched to a mode the console did not command.'''
        with self.tel.lock:
            self.tel.authority.check(what)

    # --- the handshake ---------------------------------------------------------------------------
    def command(self, command: int, params: tuple[float, ...], what: str,
                verify: Callable[[], bool] | None = None, cancel: threading.Event | None = None,
                component: int | None = None, retries: int | None = None) -> None:
        """Send a COMMAND_LONG and wait for its COMMAND_ACK, retrying on silence.

        Args:
            command: MAV_CMD number.
            params: Up to 7 parameters.
            what: Human description for errors (``mode change to GUIDED``).
            verify: Returns True once the command's effect is seen in the telemetry; a lost ACK
                (or the refusal of a retry whose first copy worked) then counts as success.
            cancel: Stop waiting when set (raises :class:`Stopped`).
            component: Target component (default: the autopilot).
            retries: Re-sends (default: the configured number).

        Raises:
            CommandRejected: The vehicle answered with a MAV_RESULT other than ACCEPTED.
            LinkTimeout: No answer after the re-sends (or ``max_age`` reached).
        """
        mav = mavutil().mavlink
        sys_id, comp = self.target()
        if component is not None:
            comp = component
        p = list(params) + [0.0] * (7 - len(params))
        attempts = (self.retries if retries is None else retries) + 1
        with self.tel.lock:
            owed = list(self._owed.pop(command, (0, 0.0)))  # [ACKs owed to an earlier command, until]
        sent_at = time.monotonic()
        counts = [0, 0, sent_at]  # copies sent, ACKs read, last send [monotonic s]
        try:
            self._handshake(mav, command, p, what, verify, cancel, sys_id, comp, attempts, sent_at, counts, owed)
        finally:
            sent, answered, last_sent = counts
            if sent > answered:  # ACKs owed: dropped when they come after the next command of this id
                window = min(self.max_age, (self.retries + 1) * self.ack_timeout)
                with self.tel.lock:
                    self._owed[command] = (sent - answered, last_sent + window)

    def _handshake(self, mav: Any, command: int, p: list[float], what: str, verify: Callable[[], bool] | None,
                   cancel: threading.Event | None, sys_id: int, comp: int, attempts: int, sent_at: float,
                   counts: list[Any], owed: list[Any]) -> None:
        """The send / wait / re-send loop of :meth:`command`; ``counts`` = [copies sent, ACKs read, last send
        [monotonic s]] for the ACKs left owed; ``owed`` = [ACKs owed to an earlier command of this id, until
        [monotonic s]]: the first ones read are theirs."""
        sent = 0
        for attempt in range(attempts):
            if cancel is not None and cancel.is_set():
                raise Stopped()
            if attempt and time.monotonic() - sent_at > self.max_age:
                break  # too old to send now: the situation it was decided for has passed
            with self.tel.lock:
                early = self.tel.acks.pop(command, None)
                if early is not None and not self._late(early, owed):  # a late answer to an earlier copy
                    counts[1] += 1
            if attempt:
                self.stats["retries"] = self.stats.get("retries", 0) + 1
                log.info("%s: no COMMAND_ACK, retry %d/%d", what, attempt, attempts - 1)
            self.transport.send("command_long_send", sys_id, comp, command, attempt, *p)
            sent += 1
            counts[0], counts[2] = sent, time.monotonic()
            ack = self._wait_ack(command, cancel, owed)
            if ack is not None:
                counts[1] += 1
            if ack is None:
                if verify is not None and verify():
                    return
                continue
            msg, acked_at = ack
            if msg.result == mav.MAV_RESULT_ACCEPTED:
                return
            if verify is not None and verify():
                return  # the refusal answers a re-send of a command that had already worked
            self.stats["nacks"] = self.stats.get("nacks", 0) + 1
            result = (mav.enums["MAV_RESULT"][msg.result].name if msg.result in mav.enums["MAV_RESULT"]
                      else str(msg.result))
            said = self._reasons(sent_at, acked_at)
            raise CommandRejected(f"{what} rejected by the vehicle: {result}"
                                  + (f" (vehicle says: {'; '.join(said)})" if said else ""))
        if cancel is not None and cancel.is_set():
            raise Stopped()
        raise LinkTimeout(f"{what}: no COMMAND_ACK from the vehicle after {sent} attempt(s) "
                          f"({self.ack_timeout:g} s each)" + self.signing_hint())

    def signing_hint(self) -> str:
        """Why commands may go unanswered: the vehicle signs its messages (MAVLink 2 signing) and so
        ignores unsigned commands (GCS_Signing.cpp), or our key does not match its signatures."""
        if self.tel.quality.signed and not self.tel.signing_key_set:
            return ("; signing required: the vehicle signs its messages and ignores unsigned commands: set a key "
                    "with --mavlink-key (the vehicle's MAVLink 2 signing passphrase)")
        if self.tel.signing_key_set and self.bad_signatures() > 0:
            return ("; signing key mismatch: the vehicle's signatures do not match --mavlink-key, so it ignores "
                    "our commands: use the vehicle's key")
        return ""

    def _late(self, ack: tuple[Any, float], owed: list[Any]) -> bool:
        """Whether ``ack`` answers a copy of an earlier command of this id (and is dropped); counts it."""
        if owed[0] <= 0 or ack[1] > owed[1] or ack[0].result == mavutil().mavlink.MAV_RESULT_IN_PROGRESS:
            return False
        owed[0] -= 1
        self.stats["late_acks"] = self.stats.get("late_acks", 0) + 1
        log.info("late COMMAND_ACK for command %d dropped: it answers an earlier command's copy",
                 int(ack[0].command))
        return True

    def _wait_ack(self, command: int, cancel: threading.Event | None,
                  owed: list[Any] | None = None) -> tuple[Any, float] | None:
        mav = mavutil().mavlink
        deadline = time.monotonic() + self.ack_timeout
        with self.tel.lock:
            while True:
                ack = self.tel.acks.pop(command, None)
                if ack is not None and owed is not None and self._late(ack, owed):
                    ack = None
                if ack is not None and ack[0].result == mav.MAV_RESULT_IN_PROGRESS:
                    deadline = time.monotonic() + self.ack_timeout
                    ack = None
                if ack is not None:
                    return ack
                left = deadline - time.monotonic()
                if left <= 0 or (cancel is not None and cancel.is_set()):
                    return None
                self.tel.lock.wait(min(left, 0.05))

    def _reasons(self, sent_at: float, acked_at: float) -> list[str]:
        """The refusal's reasons: lines after ``sent_at`` up to ``nack_window`` after the ACK."""
        end = acked_at + self.nack_window
        with self.tel.lock:
            self.tel.lock.wait_for(lambda: time.monotonic() >= end, max(0.0, end - time.monotonic()))
        return [s.text for s in self.tel.lines_between(sent_at, end)
                if not s.text.startswith("WARNING: link:") and _reason_line(s.text, s.severity)]

    # --- modes, arming, take-off, speeds ---------------------------------------------------------
    def vehicle_mode(self) -> str | None:
        """The autopilot's current mode name, from its heartbeat."""
        with self.tel.lock:
            cm = self.tel.v.custom_mode
        return None if cm is None else self.mode_names.get(cm, f"mode {cm}")

    def set_mode(self, name: str, cancel: threading.Event | None = None) -> None:
        """Switch the autopilot to a mode by name (``GUIDED``, ``LAND``, ``BRAKE`` ...)."""
        mav = mavutil().mavlink
        key = name.upper()
        if key not in self.modes:
            raise LinkError(f"unknown ArduPilot Copter mode {name!r}; known: {', '.join(sorted(self.modes))}")
        auth = self.tel.authority
        with self.tel.lock:
            auth.check(f"mode change to {key}")
            # already there (a heartbeat from before our last mode command does not count)
            if self.vehicle_mode() == key and auth.expected in (None, key):
                auth.commanded(key, True)
                return
            auth.commanding(key)
        ok = False
        try:
            self.command(mav.MAV_CMD_DO_SET_MODE, (mav.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, self.modes[key]),
                         f"mode change to {key}", verify=lambda: self.vehicle_mode() == key, cancel=cancel)
            ok = True
        finally:
            with self.tel.lock:
                auth.commanded(key, ok)
            self.controller = "other"


    def armed(self) -> bool:
        with self.tel.lock:
            return self.tel.v.armed

    def arm(self, cancel: threading.Event | None = None) -> None:
        mav = mavutil().mavlink
        self.check_control("arming")
        self.command(mav.MAV_CMD_COMPONENT_ARM_DISARM, (1,), "arming", verify=self.armed, cancel=cancel)

    def disarm(self, cancel: threading.Event | None = None) -> None:
        mav = mavutil().mavlink
        self.command(mav.MAV_CMD_COMPONENT_ARM_DISARM, (0,), "disarming", verify=lambda: not self.armed(),
                     cancel=cancel)

    def takeoff(self, altitude: float, climbing: Callable[[], bool], cancel: threading.Event | None = None) -> None:
        """MAV_CMD_NAV_TAKEOFF to ``altitude`` [m] above home (where the vehicle armed: ArduCopter reads
        param7 in MAV_FRAME_GLOBAL_RELATIVE_ALT, takeoff.cpp); refused (FAILED) unless GUIDED, armed, landed
        and above the vehicle's own height."""
        mav = mavutil().mavlink
        if not math.isfinite(altitude):
            raise LinkError(f"take-off altitude must be finite, got {altitude}")
        self.check_control("take-off")
        self.controller = "other"
        self.command(mav.MAV_CMD_NAV_TAKEOFF, (0, 0, 0, math.nan, 0, 0, altitude),
                     f"take-off to {altitude:.2f} m", verify=climbing, cancel=cancel)

    def change_speed(self, speed_type: int, speed: float, cancel: threading.Event | None = None,
                     component: int | None = None) -> bool:
        """MAV_CMD_DO_CHANGE_SPEED (type 1 ground, 2 climb, 3 descent) [m/s]; False if refused or not
        acknowledged. An optional command: a lost ACK is a warning, never a failure (the measured
        speed is watched, :mod:`~console.link.mavlink_segments`)."""
        mav = mavutil().mavlink
        if not (speed > 0 and math.isfinite(speed)):
            raise LinkError(f"speed must be > 0 m/s, got {speed}")
        self.check_control("speed")
        try:
            self.command(mav.MAV_CMD_DO_CHANGE_SPEED, (speed_type, speed, -1), f"speed {speed:.2f} m/s (type {speed_type})",
                         cancel=cancel, component=component)
            self.tel.clear_warning(f"speed{speed_type}")
            return True
        except CommandRejected as exc:
            self.tel.warn(f"speed{speed_type}", f"{exc}: the vehicle flies at its own configured speed")
            return False
        except VehicleInControl:
            raise
        except LinkTimeout as exc:
            self.tel.warn(f"speed{speed_type}", f"{exc}: continuing; the measured speed is watched")
            return False

    # --- targets ---------------------------------------------------------------------------------
    def _ms(self) -> int:
        return int((time.monotonic() - self._boot) * 1000) & 0xFFFFFFFF

    def send_position_target(self, world: Vec3, yaw: float | None = None, component: int | None = None) -> None:
        """One SET_POSITION_TARGET_LOCAL_NED (MAV_FRAME_LOCAL_NED) to a world point [m]."""
        mav = mavutil().mavlink
        if not all(math.isfinite(c) for c in world) or (yaw is not None and not math.isfinite(yaw)):
            raise LinkError(f"position target must be finite, got {world} yaw {yaw}")
        self.check_control("position target")
        sys_id, comp = self.target()
        n, e, d = self.ned.to_ned(world)
        mask = POSITION_ONLY_MASK if yaw is None else POSITION_YAW_MASK
        y = 0.0 if yaw is None else self.ned.yaw_to_ned(yaw)
        self.transport.send("set_position_target_local_ned_send", self._ms(), sys_id,
                            comp if component is None else component, mav.MAV_FRAME_LOCAL_NED, mask,
                            n, e, d, 0, 0, 0, 0, 0, 0, y, 0)
        if self.controller != "pos":  # GUIDED enters position control: ArduCopter resets the speed
            self.controller = "pos"
            self.controller_changes += 1

    def send_velocity_target(self, v_world: Vec3, yaw: float | None = None, component: int | None = None) -> None:
        """One SET_POSITION_TARGET_LOCAL_NED with a world velocity [m/s]."""
        mav = mavutil().mavlink
        if not all(math.isfinite(c) for c in v_world) or (yaw is not None and not math.isfinite(yaw)):
            raise LinkError(f"velocity target must be finite, got {v_world} yaw {yaw}")
        self.check_control("velocity target")
        self.controller = "vel"
        sys_id, comp = self.target()
        vn, ve, vd = self.ned.velocity_to_ned(v_world)
        mask = VELOCITY_ONLY_MASK if yaw is not None else VELOCITY_ONLY_MASK | (1 << 10)
        y = 0.0 if yaw is None else self.ned.yaw_to_ned(yaw)
        self.transport.send("set_position_target_local_ned_send", self._ms(), sys_id,
                            comp if component is None else component, mav.MAV_FRAME_LOCAL_NED, mask,
                            0, 0, 0, vn, ve, vd, 0, 0, 0, y, 0)


__all__ = ["Commander", "Stopped", "copter_modes", "POSITION_ONLY_MASK", "POSITION_YAW_MASK",
           "VELOCITY_ONLY_MASK", "SPEED_GROUND", "SPEED_CLIMB", "SPEED_DESCENT"]
