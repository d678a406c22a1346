"""MAVLink segment execution: walk, take-off, flight and landing on an ArduPilot (Copter) vehicle.

:class:`SegmentExecutor` runs one :class:`~planner.mission.MissionSegment` on the segment thread of
:class:`~console.link.mavlink.MavlinkLink`, with the link's :class:`~console.link.mavlink_commands.Commander`
(modes, arming, speeds, targets) and :class:`~console.link.mavlink_telemetry.Telemetry` (position,
speed, landed state, readiness):

- walking: ground-motion targets (:class:`~console.link.mavlink_config.GroundMotion`) to each waypoint;
- take-off: wait (bounded) until the vehicle is ready, GUIDED, arm, ``MAV_CMD_NAV_TAKEOFF``, climb;
- flight: ``SET_POSITION_TARGET_LOCAL_NED`` re-sent at the set-point rate until within tolerance; the
  speeds (``MAV_CMD_DO_CHANGE_SPEED``) go out once position control has started and again after every
  controller change, and the measured speed is watched (:mod:`~console.link.mavlink_speed`);
- landing: above the spot, *stopped* there (``STILL_DWELL`` of still samples), then LAND until
  ``EXTENDED_SYS_STATE`` says on ground;
- turn: yaw in place, the position target at where the vehicle is with the turn's yaw (ground or
  air), until ``ATTITUDE`` says the heading is within ``YAW_TOLERANCE``.

Nothing is sent or decided from an invalid or stale position: the execution waits (the mission
manager's failsafe decides). Positions are world frame (z up) [m], speeds [m/s], times [s].
"""

from __future__ import annotations

import logging
import math
import threading
import time
from typing import Callable

import numpy as np

from planner.mission import SegmentKind

from console.link.base import LinkError, LinkTimeout, RunStatus, SegmentRun
from console.link.closing_speed import ClosingTrack
from console.link.mavlink_commands import Commander, Stopped
from console.link.mavlink_config import MavlinkConfig
from console.link.mavlink_authority import VehicleInControl
from console.link.mavlink_speed import SpeedGuard
from console.link.mavlink_state import landed
from console.link.mavlink_telemetry import LANDED_IN_AIR, LANDED_TAKEOFF, Telemetry

log = logging.getLogger(__name__)

CONFIRM_GAP_S = 0.2
"""A mission's LAND waits for a heartbeat received at least this long [s] after it was decided."""

QUIET_S = 0.3
"""No target is sent while the vehicle has sent nothing at all for this long [s]."""

STILL_DWELL = 0.3
"""How long [s] the vehicle must stay still over a spot before a landing starts there."""

YAW_TOLERANCE = math.radians(5.0)
"""How close [rad] the vehicle's heading (ATTITUDE yaw) must come to a turn's heading."""

TURN_RATE_EXPECTED = math.radians(30.0)
"""The slowest yaw rate [rad/s] a turn's time-out allows for (ArduCopter's ATC_RATE_Y_MAX is
higher; ground robots may be slower)."""


class SegmentExecutor:
    """Runs mission segments on the vehicle (one at a time, on the caller's thread).

    Args:
        config: Frames, command set, speeds, tolerances and time-outs.
        telemetry: The vehicle's validated telemetry (position, velocity, landed state).
        commander: The command handshakes (modes, arming, speeds, targets).
    """

    def __init__(self, config: MavlinkConfig, telemetry: Telemetry, commander: Commander) -> None:
        self.config = config
        self.telemetry = telemetry
        self.commander = commander
        self.speed_guard = SpeedGuard(config, telemetry, commander)

    def airborne(self) -> bool:
        """Whether the vehicle is in the air (from its landed state and height)."""
        with self.telemetry.lock:
            return not landed(self.telemetry.v, self.config)

    def execute(self, run: SegmentRun, cancel: threading.Event) -> None:
        """Run ``run``'s segment to its end (the segment thread's target): finishes the run DONE or
        FAILED with the reason; a ``cancel`` (hold / abort) leaves finishing it to the caller."""
        self.telemetry.clear_warning("slow")  # said again if this segment's vehicle is slow too
        try:
            {SegmentKind.WALK: self._do_walk, SegmentKind.TAKEOFF: self._do_takeoff, SegmentKind.FLY: self._do_fly,
             SegmentKind.LAND: self._do_land, SegmentKind.TURN: self._do_turn}[run.segment.kind](run, cancel)
            run.finish(RunStatus.DONE)
        except Stopped:
            pass  # hold()/abort() finishes the run
        except LinkError as exc:
            run.finish(RunStatus.FAILED, str(exc))
        except Exception as exc:  # keep the console alive whatever happens
            log.exception("segment execution failed")
            run.finish(RunStatus.FAILED, f"internal error: {exc}")

    def pos(self) -> np.ndarray | None:
        """The world position if valid and fresh, else None."""
        with self.telemetry.lock:
            v = self.telemetry.v
            if v.pos_ned is None or time.monotonic() - v.pos_time > self.config.pose_timeout:
                return None
            return np.asarray(self.config.ned.to_world(v.pos_ned))

    def speed(self) -> float:
        with self.telemetry.lock:
            return float(np.linalg.norm(self.telemetry.v.vel_ned))

    def position(self, cancel: threading.Event | None = None) -> np.ndarray:
        """The world position; waits up to ``pose_timeout`` for a valid one, else LinkError."""
        deadline = time.monotonic() + self.config.pose_timeout
        while True:
            p = self.pos()
            if p is not None:
                return p
            if time.monotonic() > deadline:
                age = self.telemetry.pose_age()
                raise LinkError("no valid position from the vehicle" + (
                    f" for {age:.1f} s" if math.isfinite(age) else ": it has no local position estimate yet"))
            if cancel is not None and cancel.wait(0.05):
                raise Stopped()
            elif cancel is None:
                time.sleep(0.05)

    def _motion_timeout(self, distance: float, speed: float) -> float:
        t = distance / speed * self.config.timeout_factor + self.config.timeout_slack
        if not math.isfinite(t):
            raise LinkError(f"motion time-out not finite (distance {distance}, speed {speed})")
        return t

    def _wait(self, done: Callable[[np.ndarray], bool], timeout: float, what: str, cancel: threading.Event,
              each: Callable[[np.ndarray], None] | None = None,
              remaining: Callable[[np.ndarray], float] | None = None, commanded: float | None = None) -> None:
        """Poll ``done(position)`` at the set-point rate (calling ``each(position)`` first) until true
        or time-out; while the position is invalid or stale nothing is sent or decided.

        With ``remaining`` (distance left [m]) the time-out follows the speed the vehicle really flies
        (LOCAL_POSITION_NED): when it passes while the vehicle still closes in (a vehicle flying its own,
        slower speed: a refused or lost MAV_CMD_DO_CHANGE_SPEED), it moves to the time the rest takes at
        the measured closing speed (x ``timeout_factor`` + ``timeout_slack``), with a warning naming both
        speeds; a vehicle that stopped closing in times out."""
        period = 1.0 / self.config.setpoint_rate
        deadline = time.monotonic() + timeout
        track = ClosingTrack()  # remaining [m] over the last PROGRESS_WINDOW (console/link/closing_speed.py)
        while True:
            if cancel.is_set():
                raise Stopped()
            with self.telemetry.lock:
                taken = self.telemetry.authority.describe()
            if taken:  # the vehicle chose another mode: nothing more is sent or decided here
                raise VehicleInControl(taken)
            here = self.pos()
            if here is not None:
                # a vehicle silent for QUIET_S gets no target: on TCP it would queue and arrive late
                if each is not None and self.telemetry.silence() <= QUIET_S:
                    each(here)
                if done(here):
                    return
                if remaining is not None:
                    track.add(time.monotonic(), remaining(here))
            if time.monotonic() > deadline:
                later = track.later_deadline(time.monotonic(), self.config.timeout_factor, self.config.timeout_slack)
                if later is None:
                    raise LinkTimeout(f"{what} not reached within {timeout:.0f} s")
                deadline, closing = later
                if commanded is not None:
                    self.telemetry.warn("slow", f"{what}: the vehicle flies at {closing:.2f} m/s, {commanded:.2f} m/s "
                                                "was commanded: its time-out follows the measured speed")
            cancel.wait(period)

    def _speeds(self, ground: bool, cancel: threading.Event) -> None:
        """Velocity targets carry their speed (sent here too); position targets get theirs once position
        control has started (:meth:`SpeedGuard.before_target`: ArduCopter resets the speed then)."""
        if ground and self.config.ground.command == "velocity":
            self.speed_guard.send_speeds(True, cancel)

    def _go_to(self, run: SegmentRun, cancel: threading.Event, target: np.ndarray, index: int, ground: bool,
               progress: Callable[[float], float], stop: bool = False) -> None:
        """Stream targets to one waypoint until within tolerance (horizontal on the ground); with
        ``stop`` also until the vehicle is still there."""
        cfg = self.config
        start = self.position(cancel)
        dist0 = float(np.linalg.norm((target - start)[:2] if ground else target - start))
        heading = math.atan2(target[1] - start[1], target[0] - start[0]) if dist0 > 0.05 else None
        yaw = heading if cfg.face_travel else None
        comp = cfg.ground.target_component if ground else None
        speed = cfg.ground.speed if ground else cfg.fly_speed

        def remaining(here: np.ndarray) -> float:
            d = target - here
            return float(np.linalg.norm(d[:2] if ground else d))

        def send(here: np.ndarray) -> None:
            if ground and cfg.ground.command == "velocity":
                d = target - here
                d[2] = 0.0
                n = float(np.linalg.norm(d))
                v = d / n * min(cfg.ground.speed, n * cfg.setpoint_rate) if n > 1e-6 else np.zeros(3)
                self.commander.send_velocity_target((float(v[0]), float(v[1]), 0.0), yaw, comp)
            else:
                self.speed_guard.before_target(here, ground, yaw, comp, cancel)
                self.commander.send_position_target((float(target[0]), float(target[1]), float(target[2])), yaw, comp)
                self.speed_guard.watch(ground, cancel)
            run.update(progress(max(0.0, dist0 - remaining(here))), index)

        still_since: list[float] = []  # when the vehicle was first seen there and still (stop only)

        def reached(here: np.ndarray) -> bool:
            if remaining(here) > cfg.position_tolerance:
                return False
            if not stop:
                return True
            if self.speed() >= cfg.still_speed:
                still_since.clear()
                return False
            # one slow sample is not a stop (a late sample on a busy link, the turn of an overshoot):
            # still over the spot for STILL_DWELL [s] of samples in a row
            if not still_since:
                still_since.append(time.monotonic())
            return time.monotonic() - still_since[0] >= STILL_DWELL

        what = f"{'walk' if ground else 'flight'} waypoint {index} ({target[0]:.2f}, {target[1]:.2f}, {target[2]:.2f})"
        timeout = self._motion_timeout(dist0, speed) + (cfg.settle_timeout if stop else 0.0)
        self._wait(reached, timeout, what, cancel, send, remaining=remaining, commanded=speed)
        if ground and cfg.ground.command == "velocity":
            self.commander.send_velocity_target((0.0, 0.0, 0.0), None, comp)

    def _follow(self, run: SegmentRun, cancel: threading.Event, points: list[np.ndarray], ground: bool,
                first_index: int = 0, stop_at_end: bool = False) -> None:
        legs = [self.position(cancel)] + points
        lengths = [float(np.linalg.norm((legs[i + 1] - legs[i])[:2] if ground else legs[i + 1] - legs[i]))
                   for i in range(len(points))]
        total = sum(lengths) or 1.0
        done = 0.0
        for i, p in enumerate(points):
            base = done
            self._go_to(run, cancel, p, first_index + i, ground, lambda d, b=base: (b + d) / total,
                        stop=stop_at_end and i == len(points) - 1)
            done += lengths[i]
            run.update(done / total, first_index + i + 1)

    def _do_walk(self, run: SegmentRun, cancel: threading.Event) -> None:
        g = self.config.ground
        if self.airborne():
            raise LinkError("cannot walk: the vehicle is in the air (land first)")
        if g.mode is not None:
            self.commander.set_mode(g.mode, cancel)
        if g.arm and not self.commander.armed():
            self.commander.arm(cancel)
        self._speeds(True, cancel)
        floor = float(self.config.floor)
        pts = [np.array([w[0], w[1], floor]) for w in run.segment.waypoints]
        here = self.position(cancel)
        first = 1 if float(np.linalg.norm((pts[0] - here)[:2])) <= self.config.position_tolerance else 0
        self._follow(run, cancel, pts[first:], ground=True, first_index=first)

    def _wait_ready(self, cancel: threading.Event) -> None:
        """Wait (up to ``ready_timeout``) until the vehicle has a position estimate and passes
        its pre-arm checks."""
        deadline = time.monotonic() + self.config.ready_timeout
        while True:
            why = self.telemetry.readiness(self.config.pose_timeout)
            if not why:
                return
            if time.monotonic() > deadline:
                raise LinkTimeout(f"the vehicle is not ready to take off after {self.config.ready_timeout:.0f} s: {why}")
            if cancel.wait(0.1):
                raise Stopped()

    def _do_takeoff(self, run: SegmentRun, cancel: threading.Event) -> None:
        cfg = self.config
        spot, top = (np.asarray(w, dtype=np.float64) for w in run.segment.waypoints)
        if self.airborne():
            self.commander.set_mode(cfg.flight_mode, cancel)
            self._speeds(False, cancel)
            self._follow(run, cancel, [top], ground=False, first_index=1)
            return
        self._wait_ready(cancel)
        here = self.position(cancel)
        gap = float(np.linalg.norm((spot - here)[:2]))
        if gap > max(0.5, 3 * cfg.position_tolerance):
            raise LinkError(f"take-off spot ({spot[0]:.2f}, {spot[1]:.2f}) is {gap:.2f} m from the vehicle")
        self.commander.set_mode(cfg.flight_mode, cancel)
        armed_here = not self.commander.armed()
        if armed_here:
            self.commander.arm(cancel)
        self._speeds(False, cancel)
        ground_down = -cfg.ned.altitude(float(here[2]))  # where it stands (a box top is above the floor)

        def climbing() -> bool:
            with self.telemetry.lock:
                v = self.telemetry.v
                rising = v.pos_ned is not None and v.pos_ned[2] < ground_down - 0.05
                return rising or v.landed_state in (LANDED_TAKEOFF, LANDED_IN_AIR)

        # NAV_TAKEOFF's altitude is above home, where the vehicle last armed (takeoff.cpp do_user_takeoff_U_m;
        # AP_Arming_Copter::arm), not above the EKF origin: it differs when it armed on a box, say
        with self.telemetry.lock:  # armed just now: home is here; before: where its heartbeat first said armed
            home = None if armed_here else self.telemetry.v.home_ned
        home_up = -home[2] if home is not None else -ground_down  # home's height above the EKF origin [m]
        self.commander.takeoff(cfg.ned.altitude(float(top[2])) - home_up, climbing, cancel)
        z0 = float(here[2])

        def climbed(p: np.ndarray) -> bool:
            z = float(p[2])
            run.update(0.9 * max(0.0, z - z0) / max(1e-6, float(top[2]) - z0), 1)
            return z >= float(top[2]) - cfg.altitude_tolerance

        self._wait(climbed, self._motion_timeout(float(top[2]) - z0, cfg.climb_rate),
                   f"take-off height {top[2]:.2f} m", cancel)
        if float(np.linalg.norm((top - self.position(cancel))[:2])) > cfg.position_tolerance:
            self._go_to(run, cancel, top, 1, False, lambda d: 0.95)

    def _do_fly(self, run: SegmentRun, cancel: threading.Event) -> None:
        if not self.airborne():
            raise LinkError("cannot fly: the vehicle is on the ground (take off first)")
        self.commander.set_mode(self.config.flight_mode, cancel)
        self._speeds(False, cancel)
        pts = [np.asarray(w, dtype=np.float64) for w in run.segment.waypoints]
        first = 1 if float(np.linalg.norm(pts[0] - self.position(cancel))) <= self.config.position_tolerance else 0
        self._follow(run, cancel, pts[first:], ground=False, first_index=first)

    def _do_land(self, run: SegmentRun, cancel: threading.Event) -> None:
        """Above the spot, stopped there, then LAND until on the ground."""
        cfg = self.config
        if not self.airborne():
            return
        above, spot = (np.asarray(w, dtype=np.float64) for w in run.segment.waypoints)
        here = self.position(cancel)
        if float(np.linalg.norm((above - here)[:2])) > cfg.position_tolerance or self.speed() >= cfg.still_speed:
            self.commander.set_mode(cfg.flight_mode, cancel)
            self._speeds(False, cancel)
        # always confirmed stopped over the spot (STILL_DWELL of still samples), not on one sample
        z = float(here[2]) if here[2] > above[2] + cfg.altitude_tolerance else float(above[2])  # never descend first
        self._go_to(run, cancel, np.array([above[0], above[1], z]), 0, False, lambda d: 0.2, stop=True)
        self.land(run, cancel, confirm_mode=True)

    def _do_turn(self, run: SegmentRun, cancel: threading.Event) -> None:
        """Yaw in place to the segment's heading (world frame [rad]).

        ArduCopter in GUIDED takes the yaw of SET_POSITION_TARGET_LOCAL_NED unless the type mask's
        YAW_IGNORE bit is set (GCS_Mavlink.cpp, handle_message_set_position_target_local_ned ->
        ModeGuided::set_destination with use_yaw); the target is where the vehicle is when the turn
        starts, so it holds its place (on the ground: the ground-motion command set, at floor
        height). Done when ATTITUDE's yaw is within :data:`YAW_TOLERANCE`.
        """
        cfg, g = self.config, self.config.ground
        yaw = float(run.segment.yaw if run.segment.yaw is not None else 0.0)
        ground = not self.airborne()
        if ground:
            if g.mode is not None:
                self.commander.set_mode(g.mode, cancel)
            if g.arm and not self.commander.armed():
                self.commander.arm(cancel)
        else:
            self.commander.set_mode(cfg.flight_mode, cancel)
        hold = self.position(cancel)
        if ground:
            hold[2] = float(cfg.floor)
        comp = g.target_component if ground else None

        def error() -> float:
            with self.telemetry.lock:
                now = cfg.ned.yaw_to_world(self.telemetry.v.yaw_ned)
            return abs((yaw - now + math.pi) % (2 * math.pi) - math.pi)

        err0 = max(error(), 1e-6)

        def send(here: np.ndarray) -> None:
            if ground and g.command == "velocity":
                self.commander.send_velocity_target((0.0, 0.0, 0.0), yaw, comp)
            else:
                self.commander.send_position_target((float(hold[0]), float(hold[1]), float(hold[2])), yaw, comp)
            run.update(max(0.0, 1.0 - error() / err0), 0)

        self._wait(lambda here: error() <= YAW_TOLERANCE,
                   self._motion_timeout(err0, TURN_RATE_EXPECTED), f"heading {math.degrees(yaw):.0f} deg", cancel, send)

    def land(self, run: SegmentRun, cancel: threading.Event, confirm_mode: bool = False) -> None:
        """LAND until on the ground; with ``confirm_mode`` (a mission's landing, not the failsafe's) only
        after a heartbeat received from now on shows the vehicle still in the console's mode (ArduPilot
        heartbeats come at 1 Hz: an RTL it began a moment ago is not replaced by our LAND)."""
        cfg = self.config
        if confirm_mode:
            # a heartbeat received in the same instant may have left the vehicle before a mode change:
            # only one received CONFIRM_GAP_S after the decision counts
            since = time.monotonic() + CONFIRM_GAP_S
            with self.telemetry.lock:
                heard = self.telemetry.lock.wait_for(lambda: self.telemetry.v.last_heartbeat > since,
                                                     cfg.heartbeat_timeout + CONFIRM_GAP_S)
            if cancel.is_set():
                raise Stopped()
            if not heard:
                raise LinkTimeout(f"no heartbeat within {cfg.heartbeat_timeout:g} s to confirm the vehicle's mode "
                                  "before LAND")
            self.commander.check_control("LAND")
        self.commander.set_mode(cfg.land_mode, cancel)
        here = self.pos()
        z0 = float(here[2]) if here is not None else cfg.floor + 1.0

        def landed(p: np.ndarray) -> bool:
            run.update(0.2 + 0.8 * max(0.0, z0 - float(p[2])) / max(1e-6, z0 - cfg.floor), 1)
            return not self.airborne()

        self._wait(landed, self._motion_timeout(max(0.0, z0 - cfg.floor), cfg.descent_rate), "landing (on ground)",
                   cancel)


__all__ = ["SegmentExecutor", "STILL_DWELL", "YAW_TOLERANCE"]
