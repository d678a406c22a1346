"""The mission manager's safety parts: failsafe on live facts, segment watchdog, position wait.

:class:`SafetyMixin` is mixed into :class:`~console.link.manager.MissionManager` (it uses its
``link``, ``_emit``, ``_cond``, ``_state``, ``_mission`` and tunables):

- link loss is read live from :meth:`~console.link.base.RobotLink.link_age_now` (heartbeat
  silence or a stale pose), never from a stored state sample;
- the failsafe holds, waits ``failsafe_hold`` and lands where the robot is; a robot heard again
  during the hold, just before the landing, or before the landing has taken effect pauses the
  mission instead (the landing is cancelled); the operator is told what the robot really does
  when the link returns;
- every link segment has a watchdog deadline from its length and ``watchdog_speeds``;
- before a segment the manager waits (up to ``ready_timeout``) for a valid position.

Positions are world frame [m]; times [s].
"""

from __future__ import annotations

import time
from typing import Any

import numpy as np

from planner.mission import MissionSegment, SegmentKind

from console.link.base import LinkError, Mode, RunStatus, SegmentRun


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

    def _robot_now(self) -> str:
        """What the robot is really doing, from a fresh state sample (waits briefly for one)."""
        end = time.monotonic() + 2.0
        st = self.link.latest_state()
        while (st is None or not (st.link_ok and st.position_valid)) and time.monotonic() < end:
            time.sleep(self.poll)
            st = self.link.latest_state()
        if st is None:
            return "no robot state"
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
            if self._link_back():  # heard again at the last moment: no landing
                self._restored("before the failsafe landing")
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
                st = self.link.latest_state()
                if self._link_back() and st is not None and st.mode is not Mode.LANDING and not st.landed:
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
        self._emit("warning", f"link restored {when}: {self._robot_now()}; mission paused (resume or abort)",
                   status=self._status_enum.PAUSED)


__all__ = ["SafetyMixin"]
