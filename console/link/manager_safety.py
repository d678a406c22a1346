"""The mission manager's safety parts: failsafe on live facts, segment watchdog, position wait.

:class:`SafetyMixin` is mixed into :class:`~console.link.manager.MissionManager` (it uses its
``link``, ``_emit``, ``_cond``, ``_state``, ``_mission`` and tunables):

- link loss is read live from :meth:`~console.link.base.RobotLink.link_age_now` (heartbeat
  silence or a stale pose), never from a stored state sample;
- the failsafe holds, waits ``failsafe_hold`` and lands where the robot is; a robot heard again
  during the hold, just before the landing, or before the landing has taken effect pauses the
  mission instead (the landing is cancelled); the operator is told what the robot really does
  when the link returns;
- a failsafe action is decided only while the link is still stale: heartbeats that return without a
  fresh position first get ``FRESH_WAIT`` seconds to bring one; whatever is said or decided after the
  link returns is built from telemetry received after it returned (:meth:`_fresh_state`);
- mode authority: a robot that switched to a mode the console did not command (RTL, LAND, BRAKE by a
  fence, the pilot's switch ...) ends the console's control: no hold, no mode command, the mission
  pauses naming the mode and the vehicle's reason; resume is refused until the operator takes control
  (:meth:`take_control`, which says first what the vehicle is doing);
- estimator trust: a position jump or estimator fault during a segment holds and pauses;
- flight outside the mission's workspace (an RTL climbing above it) is warned about;
- every link segment has a watchdog deadline from its length and ``watchdog_speeds``; when it passes
  while the robot still closes in (slower than those speeds: a vehicle flying its own speed), it moves to
  the time the rest takes at the measured closing speed, the rule of the MAVLink link's own time-outs
  (:mod:`~console.link.closing_speed`); a robot that stopped closing in is held and the mission paused;
- before a segment the manager waits (up to ``ready_timeout``) for a valid position.

Positions are world frame [m]; times [s].
"""

from __future__ import annotations

import time
from typing import Any

import numpy as np

from planner.mission import MissionSegment, SegmentKind

from console.link.base import LinkError, Mode, RobotState, RunStatus, SegmentRun
from console.link.closing_speed import ClosingTrack

FRESH_WAIT = 2.0
"""How long [s] a failsafe waits, once heartbeats return, for fresh telemetry before acting on staleness."""
WORKSPACE_MARGIN = 0.3
"""How far [m] outside the mission's bounds the robot may be before it is warned about."""


class SafetyMixin:
    """Failsafe, watchdog and readiness for :class:`~console.link.manager.MissionManager`."""

    link: Any
    failsafe_after: float
    failsafe_hold: float
    poll: float
    ready_timeout: float
    watchdog_speeds: tuple[float, ...]
    watchdog_factor: float
    watchdog_slack: float
    _status_enum: Any  # MissionStatus

    def _wait_position(self, index: int, n: int) -> None:
        """Wait (up to ``ready_timeout``) for a valid position; raises LinkError naming why not."""
        st = self._state()
        if st.position_valid:
            return
        self._emit("info", f"segment {index + 1}/{n}: waiting for the robot's position ({st.health})")
        deadline = time.monotonic() + self.ready_timeout
        while not st.position_valid:
            with self._cond:
                if self._abort:
                    return
            if time.monotonic() > deadline:
                raise LinkError(f"no valid robot position after {self.ready_timeout:.0f} s ({st.health}"
                                + (f"; {st.readiness}" if st.readiness else "") + ")")
            if self._link_lost():
                raise LinkError(f"the robot is not heard from ({st.health})")
            time.sleep(self.poll)
            st = self._state()

    def _deadline(self, part: MissionSegment) -> float:
        """Watchdog time for one link segment [s]: expected time x factor + slack."""
        walk, fly, vertical = self.watchdog_speeds
        pts = np.asarray(part.waypoints, dtype=np.float64)
        d = np.diff(pts, axis=0)
        horizontal = float(np.linalg.norm(d[:, :2], axis=1).sum())
        up_down = float(np.abs(d[:, 2]).sum())
        if part.kind is SegmentKind.WALK:
            t = horizontal / walk
        else:
            t = horizontal / fly + up_down / vertical
        extra = self.ready_timeout if part.kind is SegmentKind.TAKEOFF else 0.0
        return t * self.watchdog_factor + self.watchdog_slack + extra

    def _watchdog(self, part: MissionSegment, what: str) -> "SegmentWatchdog":
        """The watchdog of one link segment (deadline :meth:`_deadline` from now)."""
        return SegmentWatchdog(self._deadline(part), float(part.length), self.watchdog_factor, self.watchdog_slack,
                               lambda text: self._emit("warning", f"{what}: {text}"))

    def _stop_paused(self, run: SegmentRun, why: str) -> str:
        """Hold the robot and pause the mission with ``why``; returns ``paused``."""
        try:
            self.link.hold()
        except LinkError as exc:
            why += f"; hold failed: {exc}"
        run.wait(1.0)
        self._emit("error", f"{why}: robot held, mission paused (resume continues, abort ends it)",
                   status=self._status_enum.PAUSED)
        return "paused"

    def _link_lost(self) -> bool:
        """Live: the robot has not been heard with fresh telemetry for ``failsafe_after``."""
        return self.link.link_age_now() > self.failsafe_after

    def _link_back(self) -> bool:
        return self.link.link_age_now() <= self.failsafe_after

    def _heard_again(self) -> bool:
        """Heartbeats are back (the position may still be stale): not the moment to act on staleness."""
        hb = getattr(self.link, "heartbeat_age", None)
        return hb is not None and hb() <= self.failsafe_after

    def _fresh_state(self, timeout: float = 3.0) -> RobotState | None:
        """A state built only from telemetry received from now on (the link's ``fresh_state``), else
        the latest sample when the link cannot tell."""
        fresh = getattr(self.link, "fresh_state", None)
        if fresh is None:
            return self.link.latest_state()
        return fresh(time.monotonic(), timeout)

    def _state_now(self) -> RobotState:
        """The robot's state as the link knows it now (its ``state_now``): where the previous segment
        really ended, not a stored sample that a loaded machine's sampler may have taken before; else the
        latest sample."""
        now = getattr(self.link, "state_now", None)
        st = now() if now is not None else None
        return st if st is not None else self._state()

    def _vehicle_control(self) -> str:
        """Live: ``""`` while the console may command the robot, else ``vehicle took control: ...``."""
        return str(self.link.vehicle_control or "")

    def take_control(self, confirm: bool = False) -> str:
        """Take control back from a vehicle that chose its own mode. Without ``confirm`` only returns
        the question to put to the operator (what the vehicle is doing now); with ``confirm`` the
        console may command it again (resume then switches it to GUIDED). Returns what was done."""
        taken = self._vehicle_control()
        if not taken:
            return "the console already has control"
        st = self._fresh_state(2.0) or self.link.latest_state()
        doing = self._describe(st) if st is not None else "no state"
        if not confirm:
            return (f"{taken}; {doing}. Take control? Resume will then switch the vehicle to GUIDED and fly the "
                    "mission from where it is")
        self.link.take_control()
        self._emit("warning", f"operator took control back ({taken}; {doing}): resume continues the mission")
        return "control taken: resume continues the mission"

    def _rebooted(self, epoch: int, wait: float = 1.0) -> bool:
        """Whether a mode the console did not command is the robot's reboot (its first heartbeats are in
        the boot mode before its clock shows the reboot): waits up to ``wait`` [s] for a state sample
        with a new link epoch."""
        end = time.monotonic() + wait
        while time.monotonic() < end:
            st = self.link.latest_state()
            if st is not None and st.link_epoch != epoch:  # the state sample that says so (and why)
                return True
            time.sleep(self.poll)
        return False

    def _took_control(self, run: SegmentRun | None, what: str, taken: str) -> str:
        """The vehicle chose its own mode: pause without sending anything; returns ``paused``."""
        if run is not None:
            run.wait(1.0)  # the segment stops by itself (it sends nothing more)
        self._emit("error", f"{what}: {taken}; mission paused: the console sends nothing until the operator "
                            "takes control (take control, then resume)", status=self._status_enum.PAUSED)
        return "paused"

    def _check_workspace(self, st: RobotState | None) -> None:
        """Warn once per excursion when the robot is outside the mission's bounds."""
        mission = getattr(self, "_mission", None)
        if mission is None or st is None or not st.position_valid:
            return
        lo = np.asarray(mission.bounds_min, dtype=np.float64) - WORKSPACE_MARGIN
        hi = np.asarray(mission.bounds_max, dtype=np.float64) + WORKSPACE_MARGIN
        p = np.asarray(st.position, dtype=np.float64)
        outside = bool(np.any(p < lo) or np.any(p > hi))
        if outside and not getattr(self, "_outside_told", False):
            axes = []
            for i, name in enumerate("xyz"):
                if p[i] > hi[i]:
                    axes.append(f"{name} {p[i]:.2f} m is above the workspace's {mission.bounds_max[i]:.2f} m")
                elif p[i] < lo[i]:
                    axes.append(f"{name} {p[i]:.2f} m is below the workspace's {mission.bounds_min[i]:.2f} m")
            mode = f" (autopilot mode {st.autopilot_mode})" if st.autopilot_mode else ""
            self._emit("warning", f"the robot is outside the workspace{mode}: {'; '.join(axes)}")
        self._outside_told = outside

    def _robot_now(self) -> str:
        """What the robot is really doing, from telemetry received after now (waits up to 3 s for it)."""
        st = self._fresh_state()
        if st is None:
            st = self.link.latest_state()
            if st is None:
                return "no robot state"
            return "no fresh telemetry yet; last known: " + self._describe(st)
        return self._describe(st)

    @staticmethod
    def _describe(st: RobotState) -> str:
        where = "on the ground" if st.landed else "in the air"
        ap = f", autopilot mode {st.autopilot_mode}" if st.autopilot_mode else ""
        pos = (f" at ({st.position[0]:.2f}, {st.position[1]:.2f}, {st.position[2]:.2f})" if st.position_valid
               else ", position unknown")
        return f"the robot is {st.mode.value}{ap}, {where}{pos}"

    def _failsafe(self) -> None:
        """Hold, wait ``failsafe_hold`` for the link, then land where the robot is; every decision
        reads the link's live age."""
        st = self.link.latest_state()
        why = st.health if st is not None and not st.link_ok else "no fresh state from the robot"
        with self._cond:
            self._failsafe_acting = True
            self._told_back = False
        try:
            taken = self._vehicle_control()
            if taken:  # the vehicle flies its own mode: the console neither holds nor lands it
                self._emit("warning", f"FAILSAFE: robot not heard for {self.link.link_age_now():.1f} s ({why}); "
                                      f"{taken}: the console sends nothing", status=self._status_enum.FAILSAFE)
                return
            self._emit("warning", f"FAILSAFE: robot not heard for {self.link.link_age_now():.1f} s ({why}): "
                                  "holding", status=self._status_enum.FAILSAFE)
            deadline = time.monotonic() + self.failsafe_hold  # counted from the failsafe, not the hold's ACK
            try:
                self.link.hold()
            except LinkError as exc:
                self._emit("error", f"failsafe hold not delivered: {exc}")
            while True:  # checked at least once after the hold, even when its retries outlasted the deadline
                if self._link_back():
                    self._restored("during the failsafe hold")
                    return
                if time.monotonic() >= deadline:
                    break
                time.sleep(self.poll)
            st = self.link.latest_state()
            if st is None or st.landed:
                self._emit("warning", "FAILSAFE: the robot is on the ground; the mission is kept "
                                      "(resume once the link is back)")
                return
            if self._heard_again() and not self._link_back():  # heartbeats back, position not yet: wait for it
                end = time.monotonic() + FRESH_WAIT
                while not self._link_back() and time.monotonic() < end:
                    time.sleep(self.poll)
            if self._link_back():  # heard again at the last moment: no landing
                self._restored("before the failsafe landing")
                return
            if self._vehicle_control():
                self._emit("warning", f"FAILSAFE: {self._vehicle_control()}: the console does not land it")
                return
            self._emit("warning", f"FAILSAFE: link still lost after {self.failsafe_hold:.1f} s "
                                  f"({self.link.link_age_now():.1f} s without fresh telemetry): landing where the "
                                  "robot is")
            floor = float(self._mission.bounds_min[2]) if self._mission else 0.0
            try:
                land = self.link.land_here(floor)
            except LinkError as exc:
                self._emit("error", f"FAILSAFE landing not delivered ({exc}): the autopilot's own failsafe "
                                    "(ArduPilot FS_GCS_ENABLE) must act")
                return
            end = time.monotonic() + max(30.0, 10 * self.failsafe_hold)
            while not land.done and time.monotonic() < end:
                if self._link_back():
                    st = self._fresh_state(1.0)  # only what the vehicle said after it came back
                    if st is not None and st.mode is not Mode.LANDING and not st.landed \
                            and st.autopilot_mode != "LAND" and not self._vehicle_control():
                        self.link.abort()  # heard again before the landing took effect: cancel it
                        self._restored("before the failsafe landing took effect (landing cancelled)")
                        return
                land.wait(self.poll)
            if land.status is RunStatus.DONE:
                self._emit("warning", "FAILSAFE: landed; the mission is kept (resume once the link is back)")
            else:
                self._emit("error", f"FAILSAFE landing not confirmed: {land.error or land.status.value}; "
                                    "the robot's state is reported when the link returns")
        finally:
            with self._cond:
                self._failsafe_acting = False
                self._cond.notify_all()  # a resume may be waiting for the end (MissionManager.resume)

    def _restored(self, when: str) -> None:
        self._told_back = True
        taken = self._vehicle_control()  # the vehicle's own failsafe mode: resume is refused, do not offer it
        then = f"{taken}: the console sends nothing; take control first, or abort" if taken else "resume or abort"
        self._emit("warning", f"link restored {when}: {self._robot_now()}; mission paused ({then})",
                   status=self._status_enum.PAUSED)


class SegmentWatchdog:
    """A segment's deadline that follows the measured closing speed once it has passed.

    Args:
        seconds: Time allowed from now [s] (from the segment's length and ``watchdog_speeds``).
        length: The segment's path length [m]; the remaining distance is ``(1 - progress) x length``.
        factor, slack: ``watchdog_factor`` and ``watchdog_slack`` of the later deadline
            (:meth:`~console.link.closing_speed.ClosingTrack.later_deadline`).
        warn: Told once when the deadline first follows the measured speed.
    """

    def __init__(self, seconds: float, length: float, factor: float, slack: float, warn: Any) -> None:
        self.deadline = time.monotonic() + seconds
        self.length, self.factor, self.slack, self.warn = length, factor, slack, warn
        self.track = ClosingTrack()
        self.extended = False

    def overran(self, progress: float) -> bool:
        """Record ``progress`` (0..1) now; True once the deadline has passed and the robot no longer closes
        in (a later deadline from the measured closing speed otherwise)."""
        now = time.monotonic()
        self.track.add(now, (1.0 - progress) * self.length)
        if now <= self.deadline:
            return False
        later = self.track.later_deadline(now, self.factor, self.slack)
        if later is None:
            return True
        self.deadline, closing = later
        if not self.extended:
            self.extended = True
            self.warn(f"the robot moves at {closing:.2f} m/s, slower than the watchdog expected: its deadline "
                      "follows the measured speed")
        return False


__all__ = ["SafetyMixin", "SegmentWatchdog"]
