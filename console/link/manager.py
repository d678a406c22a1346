"""The mission manager: runs a mission segment by segment over a robot link.

Like the paper's manager it switches between ground control (walking) and flight control
(take-off, flight, landing) per segment, and reports progress. It adds what a console needs to
stay in charge:

- **geofence**: every target is checked against the mission's workspace bounds before it is sent;
- **pause / resume / abort**: pause holds the robot and keeps the mission; resume continues the
  interrupted segment from where the robot is now (taking off again first if a flight segment
  finds the robot on the ground, landing first if a walk finds it in the air);
- **failures** (a refused command, a blocked path, a time-out) pause the mission with the reason;
  nothing is lost and resume retries;
- **failsafe**: when the robot has not been heard from with fresh telemetry (the link's live
  :meth:`~console.link.base.RobotLink.link_age_now`: heartbeat silence, or a stale position) for
  ``failsafe_after`` seconds the manager holds, waits ``failsafe_hold`` seconds for the link to
  come back and otherwise lands where the robot is. Every decision reads the live age, never a
  stored sample: a robot heard again before the landing takes effect cancels it (the mission
  pauses). When the link returns after a failsafe the manager says what the robot is really
  doing (its mode, landed or not). The console is told at every step; the mission stays resumable;
- **watchdog**: every segment has a deadline from its length and the expected speeds (with
  margin); on expiry the robot holds and the mission pauses with the reason;
- **reboot / reconnect** of the robot (``RobotState.link_epoch`` changes) during a segment holds
  and pauses the mission with the reason and the link's warnings (e.g. a moved EKF origin);
- **readiness**: before a segment the manager waits (up to ``ready_timeout``) for a valid
  position instead of failing at once;
- **mode authority, estimator trust, workspace** (:mod:`~console.link.manager_safety`): a vehicle
  that chose its own mode pauses the mission without a command and resume waits for
  :meth:`take_control`; a position jump or estimator fault holds and pauses; flight outside the
  workspace is warned about.

Positions are world frame (z up) [m]; times [s]. Listeners receive :class:`MissionEvent` on the
manager's thread and must return quickly.

This module is :class:`MissionManager` (control, the worker, geofence, events); the status /
progress / event types are in :mod:`~console.link.manager_types` (re-exported here), where a
segment starts again in :mod:`~console.link.manager_resume`, the failsafe, watchdog and position
wait in :mod:`~console.link.manager_safety`.
"""

from __future__ import annotations

import logging
import math
import threading
import time
from dataclasses import replace
from typing import Callable, Sequence

import numpy as np

from planner.mission import Mission, MissionSegment, SegmentKind

from console.wording import kind_text, plural  # plain words (take-off), no UI
from console.link.base import LinkError, RobotLink, RobotState, RunStatus, SegmentRun
from console.link.manager_resume import original_index, segment_parts
from console.link.manager_safety import SafetyMixin
from console.link.manager_types import (EventListener, GeofenceError, MissionEvent, MissionProgress, MissionStateError,
                            MissionStatus)

log = logging.getLogger(__name__)

Vec3 = tuple[float, float, float]


def _control(kind: SegmentKind | None) -> str:
    if kind is None:
        return ""
    return "ground" if kind is SegmentKind.WALK else "flight"


def _seg_length(seg: MissionSegment) -> float:
    return max(seg.length, 0.05)


FAILSAFE_WRAP_UP_S = 1.0
"""How long a resume waits for a failsafe that has said its last word to end [s] (a hold or a landing
still under way takes longer and is refused)."""


class MissionManager(SafetyMixin):
    """Executes missions on one :class:`~console.link.base.RobotLink`.

    Args:
        link: A connected robot link.
        failsafe_after: Robot silence that triggers the failsafe [s].
        failsafe_hold: How long the failsafe holds before landing [s].
        geofence_margin: Tolerance added around the mission bounds [m].
        resume_tolerance: How far the robot may be from a segment's start [m] (the segment is
            then started from where the robot is).
        poll: Monitoring period [s].
        progress_rate: Maximum rate of ``progress`` events [Hz].
        watchdog_speeds: Slowest expected (walk, fly, vertical) speeds [m/s] for segment deadlines.
        watchdog_factor: Deadline = expected time x this + ``watchdog_slack``.
        watchdog_slack: [s].
        ready_timeout: Longest wait for a valid position (and, in a take-off, for readiness) [s].
    """

    _status_enum = MissionStatus  # for SafetyMixin

    def __init__(self, link: RobotLink, *, failsafe_after: float = 3.0, failsafe_hold: float = 5.0,
                 geofence_margin: float = 0.0, resume_tolerance: float = 0.6, poll: float = 0.02,
                 progress_rate: float = 5.0, watchdog_speeds: tuple[float, float, float] = (0.1, 0.2, 0.1),
                 watchdog_factor: float = 2.0, watchdog_slack: float = 30.0, ready_timeout: float = 60.0) -> None:
        for name, v in (("failsafe_after", failsafe_after), ("failsafe_hold", failsafe_hold),
                        ("resume_tolerance", resume_tolerance), ("poll", poll), ("progress_rate", progress_rate),
                        ("watchdog_factor", watchdog_factor), ("watchdog_slack", watchdog_slack),
                        ("ready_timeout", ready_timeout), *((f"watchdog_speeds[{i}]", w)
                                                           for i, w in enumerate(watchdog_speeds))):
            if not (v > 0 and math.isfinite(v)):
                raise ValueError(f"{name} must be a positive number of seconds/metres, got {v}")
        if len(watchdog_speeds) != 3:
            raise ValueError("watchdog_speeds must be (walk, fly, vertical) [m/s]")
        self.watchdog_speeds = tuple(float(w) for w in watchdog_speeds)
        self.watchdog_factor, self.watchdog_slack, self.ready_timeout = watchdog_factor, watchdog_slack, ready_timeout
        if not (geofence_margin >= 0 and math.isfinite(geofence_margin)):
            raise ValueError(f"geofence_margin must be >= 0 m, got {geofence_margin}")
        self.link = link
        self.failsafe_after = failsafe_after
        self.failsafe_hold = failsafe_hold
        self.geofence_margin = geofence_margin
        self.resume_tolerance = resume_tolerance
        self.poll = poll
        self._min_progress_gap = 1.0 / progress_rate
        self._cond = threading.Condition()
        self._progress = MissionProgress()
        self._listeners: list[EventListener] = []
        self._mission: Mission | None = None
        self._thread: threading.Thread | None = None
        self._resume = False
        self._abort = False
        self._pausing = False
        self._run: SegmentRun | None = None
        self._segment_done = 0.0  # fraction of the current original segment done before this run
        self._last_progress_event = 0.0
        self._failsafe_acting = False
        self._told_back = False
        self._resume_point: int | None = None
        self.events: list[MissionEvent] = []  # the last 200, for late listeners and tests

    # --- observation -----------------------------------------------------------------------------
    def subscribe(self, callback: EventListener) -> Callable[[], None]:
        """Call ``callback(event)`` for every event; returns an unsubscribe function."""
        with self._cond:
            self._listeners.append(callback)

        def unsubscribe() -> None:
            with self._cond:
                if callback in self._listeners:
                    self._listeners.remove(callback)

        return unsubscribe

    def progress(self) -> MissionProgress:
        with self._cond:
            return self._progress

    @property
    def mission(self) -> Mission | None:
        with self._cond:
            return self._mission

    def wait(self, timeout: float | None = None, until: Sequence[MissionStatus] = (
            MissionStatus.DONE, MissionStatus.ABORTED, MissionStatus.PAUSED, MissionStatus.FAILSAFE,
            MissionStatus.IDLE)) -> MissionStatus:
        """Block until the status is one of ``until`` (default: anything but running)."""
        with self._cond:
            self._cond.wait_for(lambda: self._progress.status in until, timeout)
            return self._progress.status

    def _emit(self, level: str, message: str, **changes: object) -> None:
        with self._cond:
            if message and level != "progress":
                changes.setdefault("message", message)
            self._progress = replace(self._progress, **changes)  # type: ignore[arg-type]
            ev = MissionEvent(time.time(), level, message, self._progress)
            if level != "progress":
                self.events = (self.events + [ev])[-200:]
            listeners = list(self._listeners)
            self._cond.notify_all()
        if level in ("warning", "error"):
            log.warning("mission: %s", message)
        elif level == "info":
            log.info("mission: %s", message)
        for cb in listeners:
            try:
                cb(ev)
            except Exception:
                log.exception("mission event listener %r failed", cb)

    # --- geofence --------------------------------------------------------------------------------
    def check_geofence(self, mission: Mission, segments: Sequence[MissionSegment] | None = None) -> None:
        """Raise :class:`GeofenceError` if any waypoint is outside the mission's bounds."""
        lo = np.asarray(mission.bounds_min, dtype=np.float64) - self.geofence_margin
        hi = np.asarray(mission.bounds_max, dtype=np.float64) + self.geofence_margin
        for i, seg in enumerate(mission.segments if segments is None else segments):
            for j, w in enumerate(seg.waypoints):
                p = np.asarray(w, dtype=np.float64)
                if not np.all(np.isfinite(p)) or np.any(p < lo - 1e-9) or np.any(p > hi + 1e-9):
                    raise GeofenceError(
                        f"segment {i + 1} ({kind_text(seg.kind)}) waypoint {j + 1} ({p[0]:.2f}, {p[1]:.2f}, {p[2]:.2f}) "
                        f"is outside the geofence ({lo[0]:.2f}, {lo[1]:.2f}, {lo[2]:.2f})-"
                        f"({hi[0]:.2f}, {hi[1]:.2f}, {hi[2]:.2f}) m")

    # --- control ---------------------------------------------------------------------------------
    def start(self, mission: Mission) -> None:
        """Check and start a mission (returns at once).

        Raises:
            MissionStateError: Another mission is active, or the robot is not where it starts.
            GeofenceError: A waypoint is outside the bounds.
        """
        self.check_geofence(mission)
        st = self.link.latest_state()
        if st is None:
            raise MissionStateError("no state from the robot yet: is the link connected?")
        if not st.link_ok:
            raise MissionStateError(f"the robot link is not healthy ({st.health}): not starting")
        first = mission.segments[0]
        gap = math.dist(st.position[:2], first.start[:2])
        if st.position_valid and gap > self.resume_tolerance:  # unknown yet: checked once it is known
            raise MissionStateError(
                f"the mission starts at ({first.start[0]:.2f}, {first.start[1]:.2f}) but the robot is at "
                f"({st.position[0]:.2f}, {st.position[1]:.2f}), {gap:.2f} m away: plan from the robot's position")
        with self._cond:
            if self._progress.status.active:
                raise MissionStateError(f"mission {self._progress.mission_id} is {self._progress.status.value}: "
                                        "abort it first")
            self._mission = mission
            self._resume = self._abort = self._pausing = False
            self._progress = MissionProgress(MissionStatus.RUNNING, mission.id, 0, len(mission.segments),
                                             mission.segments[0].kind)
            self._thread = threading.Thread(target=self._work, args=(mission,), name="mission", daemon=True)
        self._emit("info", f"mission {mission.id} started: {plural(len(mission.segments), 'segment')}, {mission.length:.1f} m")
        self._thread.start()

    def pause(self) -> None:
        """Hold the robot and pause the mission (resume continues it)."""
        with self._cond:
            status = self._progress.status
            if status is MissionStatus.PAUSED:
                return
            if status is not MissionStatus.RUNNING:
                raise MissionStateError(f"cannot pause: the mission is {status.value}")
            self._pausing = True
        try:
            self.link.hold()
        except LinkError as exc:
            self._emit("error", f"hold command failed: {exc}")
            raise

    def resume(self) -> None:
        """Continue a paused mission (or one stopped by the failsafe once the link is back)."""
        with self._cond:
            status = self._progress.status
            if status not in (MissionStatus.PAUSED, MissionStatus.FAILSAFE):
                raise MissionStateError(f"cannot resume: the mission is {status.value}")
            # the failsafe's last words ("landed ... resume once the link is back") come just before it
            # ends: a resume pressed on reading them waits for that end, not for a hold or a landing
            if self._failsafe_acting and not self._cond.wait_for(lambda: not self._failsafe_acting,
                                                                 FAILSAFE_WRAP_UP_S):
                raise MissionStateError("the failsafe is still acting (holding / landing): wait for it")
        st = self.link.latest_state()
        if st is None or not st.link_ok or st.link_age > self.failsafe_after:
            raise MissionStateError("cannot resume: the robot is not heard from "
                                    f"({st.health if st else 'no state'})")
        taken = self._vehicle_control()
        if taken:
            raise MissionStateError(f"cannot resume: {taken}; take control first (the console then switches "
                                    "the vehicle back to GUIDED)")
        with self._cond:
            self._resume = True
            self._progress = replace(self._progress, status=MissionStatus.RUNNING, message="resuming")
            self._cond.notify_all()

    def abort(self) -> None:
        """Stop the mission for good; the robot holds where it is."""
        with self._cond:
            status = self._progress.status
            if not status.active:
                raise MissionStateError(f"cannot abort: the mission is {status.value}")
            self._abort = True
            self._cond.notify_all()
            failsafe = status is MissionStatus.FAILSAFE or self._failsafe_acting
        if not failsafe and status is MissionStatus.RUNNING:  # never interrupt a failsafe landing
            try:
                self.link.abort()
            except LinkError as exc:
                self._emit("error", f"abort command failed: {exc}")
        else:  # the worker is waiting (paused / failsafe): the mission ends now
            self._emit_aborted()

    def _emit_aborted(self) -> None:
        with self._cond:
            if self._progress.status is MissionStatus.ABORTED:
                return
            self._progress = replace(self._progress, status=MissionStatus.ABORTED)
        self._emit("warning", "mission aborted", status=MissionStatus.ABORTED)

    def close(self) -> None:
        """Abort any active mission and wait for the worker."""
        if self._progress.status.active:
            try:
                self.abort()
            except MissionStateError:
                pass
        if self._thread is not None:
            self._thread.join(timeout=5.0)

    # --- worker ----------------------------------------------------------------------------------
    def _work(self, mission: Mission) -> None:
        try:
            self._execute(mission)
        except Exception as exc:  # never die silently
            log.exception("mission worker failed")
            self._emit("error", f"mission stopped by an internal error: {exc}", status=MissionStatus.ABORTED)
        finally:  # the mission is over: the vehicle's later mode changes are its own
            self.link.release_control()

    def _execute(self, mission: Mission) -> None:
        segs = mission.segments
        lengths = [_seg_length(s) for s in segs]
        total = sum(lengths)
        index = 0
        next_wp: int | None = None  # waypoint to continue from after an interruption
        resumed = False  # this segment was interrupted before
        while index < len(segs):
            base = sum(lengths[:index])
            self._resume_point = next_wp
            try:
                self._wait_position(index, len(segs))
                pending = self._prepare(segs[index], next_wp, fresh=not resumed)
            except LinkError as exc:
                self._emit("error", f"segment {index + 1}/{len(segs)} cannot start: {exc}; mission paused",
                           status=MissionStatus.PAUSED, segment=index, kind=segs[index].kind)
                outcome = "paused"
                pending = []
            else:
                if pending is None:
                    index, next_wp, resumed = index + 1, None, False
                    continue
                outcome = "done"
            for part, is_main in pending:
                outcome = self._run_part(mission, index, part, is_main, base, lengths[index], total)
                if outcome != "done":
                    break
            if outcome == "done":
                index, next_wp, resumed = index + 1, None, False
                continue
            if outcome == "aborted" or not self._wait_resume():
                self._emit_aborted()
                return
            next_wp, resumed = self._resume_point, True
        self._emit("info", f"mission {mission.id} done", status=MissionStatus.DONE, fraction=1.0,
                   segment_fraction=1.0)

    def _prepare(self, seg: MissionSegment, next_wp: int | None,
                 fresh: bool = True) -> list[tuple[MissionSegment, bool]] | None:
        """The segment's parts from where the robot is now (:func:`~console.link.manager_resume.segment_parts`)."""
        floor = float(self._mission.bounds_min[2]) if self._mission else 0.0
        return segment_parts(seg, self._state_now(), floor, next_wp, fresh, self.resume_tolerance)

    def _state(self) -> RobotState:
        st = self.link.latest_state()
        if st is None:
            raise LinkError("no robot state")
        return st

    def _run_part(self, mission: Mission, index: int, part: MissionSegment, is_main: bool, base: float,
                  length: float, total: float) -> str:
        """Run one link segment; returns ``done``, ``paused``, ``aborted`` or ``failsafe``."""
        n = len(mission.segments)
        with self._cond:
            if self._abort:
                return "aborted"
            pausing, self._pausing = self._pausing, False
        if pausing:  # the pause came between two segments
            self._emit("info", f"mission paused before segment {index + 1}/{n}", status=MissionStatus.PAUSED)
            return "paused"
        ctl = self._progress.control if part.kind is SegmentKind.TURN else _control(part.kind)  # a turn keeps it
        if ctl != self._progress.control:
            self._emit("info", f"switching to {ctl} control", control=ctl)
        what = f"segment {index + 1}/{n}: {kind_text(part.kind)}" + ("" if is_main else " (recovery)")
        try:
            self.check_geofence(mission, [part])
        except GeofenceError as exc:
            self._emit("error", f"{what} refused: {exc}", status=MissionStatus.PAUSED)
            return "paused"
        start_fraction = self._progress.segment_fraction if self._progress.segment == index else 0.0
        self._emit("info", what, segment=index, kind=mission.segments[index].kind, control=ctl,
                   segment_fraction=start_fraction, fraction=(base + start_fraction * length) / total)
        try:
            run = self.link.run_segment(part)
        except LinkError as exc:
            self._emit("error", f"{what} not started: {exc}", status=MissionStatus.PAUSED)
            return "paused"
        with self._cond:
            self._run = run
        epoch, resets = self._state().link_epoch, self._state().estimator_resets
        watchdog = self._watchdog(part, what)
        while not run.done:
            st = self._state()
            self._check_workspace(st)
            if st.link_epoch != epoch and not self._link_lost():
                if is_main:
                    self._resume_point = original_index(mission.segments[index], part, run.next_waypoint)
                return self._stop_paused(run, f"{what}: the robot reconnected or rebooted ("
                                         + "; ".join((st.health,) + st.warnings) + ")")
            if st.estimator_resets != resets and not self._link_lost():
                if is_main:
                    self._resume_point = original_index(mission.segments[index], part, run.next_waypoint)
                return self._stop_paused(run, f"{what}: the robot's position estimate is not trusted "
                                              f"({st.estimator or 'estimator reset'})")
            taken = self._vehicle_control()
            if taken and not self._rebooted(epoch):
                if is_main:
                    self._resume_point = original_index(mission.segments[index], part, run.next_waypoint)
                return self._took_control(run, what, taken)
            if watchdog.overran(run.progress):
                if is_main:
                    self._resume_point = original_index(mission.segments[index], part, run.next_waypoint)
                return self._stop_paused(run, f"{what} overran its deadline of {self._deadline(part):.0f} s "
                                              f"({part.length:.1f} m)")
            if self._link_lost():
                if is_main:
                    self._resume_point = original_index(mission.segments[index], part, run.next_waypoint)
                self._failsafe()
                return "failsafe"
            with self._cond:
                abort = self._abort
            if abort:
                run.wait(1.0)
                break
            if is_main:
                frac = start_fraction + (1 - start_fraction) * run.progress
                now = time.monotonic()
                if now - self._last_progress_event >= self._min_progress_gap:
                    self._last_progress_event = now
                    self._emit("progress", "", segment_fraction=frac, fraction=(base + frac * length) / total)
            run.wait(self.poll)
        status = run.status
        with self._cond:
            aborting = self._abort
        if aborting or status is RunStatus.ABORTED:
            return "aborted"
        if status is RunStatus.DONE:  # a pause that came too late is caught before the next segment
            if is_main:
                self._emit("progress", "", segment_fraction=1.0, fraction=(base + length) / total)
            return "done"
        with self._cond:
            pausing, self._pausing = self._pausing, False
        frac = start_fraction + (1 - start_fraction) * run.progress
        if is_main:
            self._resume_point = original_index(mission.segments[index], part, run.next_waypoint)
        where = {"segment_fraction": frac, "fraction": (base + frac * length) / total} if is_main else {}
        taken = self._vehicle_control()
        if status is RunStatus.FAILED and (taken or (run.error or "").startswith("vehicle took control")):
            if self._rebooted(epoch):
                return self._stop_paused(run, f"{what}: the robot reconnected or rebooted ("
                                         + "; ".join((self._state().health,) + self._state().warnings) + ")")
            if taken:
                return self._took_control(None, what, taken)
        if status is RunStatus.HELD or pausing:
            self._emit("info", f"mission paused during {what}", status=MissionStatus.PAUSED, **where)
        else:
            self._emit("error", f"{what} failed: {run.error}; mission paused (resume retries, abort ends it)",
                       status=MissionStatus.PAUSED, **where)
        return "paused"

    def _wait_resume(self) -> bool:
        """Wait (paused or after the failsafe) for resume (True) or abort (False); runs the
        failsafe if the link dies meanwhile."""
        while True:
            with self._cond:
                if self._abort:
                    return False
                if self._resume:
                    self._resume = False
                    break
                status = self._progress.status
                self._cond.wait(self.poll)
            self._check_workspace(self.link.latest_state())
            if status is not MissionStatus.FAILSAFE and self._link_lost():
                self._failsafe()
            elif status is MissionStatus.FAILSAFE and not self._told_back and self._link_back():
                self._told_back = True
                taken = self._vehicle_control()  # its own failsafe's mode: resume is refused, do not offer it
                self._emit("warning", f"link restored after the failsafe: {self._robot_now()} " + (
                    f"({taken}: the console sends nothing; take control first, or abort)" if taken
                    else "(resume or abort)"))
        self._emit("info", "mission resumed", status=MissionStatus.RUNNING)
        return True

__all__ = ["MissionManager", "MissionStatus", "MissionProgress", "MissionEvent", "MissionStateError",
           "GeofenceError"]
