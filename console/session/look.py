"""Look around and Look at: turn the robot in place and capture & map, off the UI thread.

- **Look around** turns the robot through ``headings`` evenly spaced headings (a full turn,
  starting with the one it faces), capturing and mapping at each: one button, progress per heading
  ("Look around: heading 3/6 (210°): capturing and mapping"). The camera's 62° field of view
  covers the full circle in six headings.
- **Look at** turns the robot to face a point (world frame) and captures and maps once.

Each turn is a ``TURN`` mission segment run on the link (:mod:`planner.mission`), each capture
the console's :class:`~console.session.mapping_job.MappingJob` run in this job's thread. **Pause**
holds the robot (a turn under way stops) and the job waits; **Resume** turns again to the heading
it was going to and carries on; **Stop** ends it. A look is refused while a mission is under way
or a capture is being mapped. Headings are world frame, counter-clockwise from +x [rad]; positions
world frame [m].
"""

from __future__ import annotations

import logging
import math
import time
from typing import Any, Sequence

from planner.mission import MissionError, heading_to, turn_segment

from console.session.job_thread import JobThread
from console.session.mapping_job import MappingJob
from console.session.session import JobStatus, Session, SessionError

log = logging.getLogger(__name__)

LOOK_AROUND = "Look around"
LOOK_AT = "Look at"
DEFAULT_HEADINGS = 6
TURN_TIMEOUT = 60.0
"""Longest wait for one turn [s] before the look stops with the reason."""


def headings_around(yaw: float, n: int) -> list[float]:
    """``n`` headings [rad] a full turn apart, the first ``yaw`` (wrapped into [-pi, pi))."""
    if isinstance(n, bool) or not isinstance(n, int) or not 2 <= n <= 36:
        raise SessionError(f"headings: must be a whole number within 2..36, got {n!r}")
    return [((yaw + 2 * math.pi * i / n) + math.pi) % (2 * math.pi) - math.pi for i in range(n)]


def _deg(yaw: float) -> int:
    return int(round(math.degrees(yaw))) % 360


class LookJob(JobThread):
    """Runs Look around / Look at in a worker thread (one at a time).

    Args:
        session: Where progress and notices go; a mission under way refuses a look.
        link: The robot link (``latest_state``, ``run_segment``, ``hold``).
        mapping: The capture & map job, run once per heading.
    """

    def __init__(self, session: Session, link: Any, mapping: MappingJob) -> None:
        super().__init__(session)
        self._link = link
        self._mapping = mapping
        self._turning: Any = None  # the SegmentRun of a turn under way
        self.last_mapped: list[int] = []  # objects in the map after each capture of the last look (tests, reports)

    # --- control -------------------------------------------------------------------------------------
    def look_around(self, headings: int = DEFAULT_HEADINGS) -> None:
        """Start a Look around of ``headings`` headings (returns at once).

        Raises:
            SessionError: Another look, a capture or a mission is under way, no robot state, or a bad count.
        """
        st = self._ready()
        yaws = headings_around(float(st.yaw), headings)
        self._start(LOOK_AROUND, yaws)

    def look_at(self, point: Sequence[float]) -> float:
        """Start a Look at ``point`` (world [m]); returns the heading it turns to [rad].

        Raises:
            SessionError: As :meth:`look_around`, or the point is not finite / right at the robot.
        """
        p = tuple(float(v) for v in point)
        if len(p) < 2 or not all(math.isfinite(v) for v in p):
            raise SessionError(f"look at: the point must be finite numbers (x, y[, z]) [m], got {point!r}")
        st = self._ready()
        try:
            yaw = heading_to(st.position, (p[0], p[1], 0.0))
        except MissionError as exc:
            raise SessionError(f"look at: {exc}") from None
        self._start(f"{LOOK_AT} ({p[0]:.2f}, {p[1]:.2f})", [yaw])
        return yaw

    def pause(self) -> None:
        """Hold the robot and wait (a turn under way stops where it is)."""
        if not self.running:
            raise SessionError("no look is running")
        self._request_pause()
        self._hold()

    def resume(self) -> None:
        if not self.paused:
            raise SessionError("no look is paused")
        self._request_resume()

    def stop(self) -> None:
        """End the look; the robot holds."""
        if not self.running:
            return
        self._request_stop()
        self._hold()

    # --- worker --------------------------------------------------------------------------------------
    def _ready(self) -> Any:
        st = self._robot_ready(self._link, self._mapping, "a look is already running: pause or stop it first",
                               "looking around")
        if not getattr(st, "position_valid", True):
            raise SessionError("the robot's position is unknown: it cannot turn to look yet")
        return st

    def _start(self, name: str, yaws: list[float]) -> None:
        with self._lock:
            if self._alive():
                raise SessionError("a look is already running: pause or stop it first")
            self.last_mapped = []
            self._launch(self._run, "look", (name, yaws), announce=lambda: self._report(
                name, 0.0, f"starting ({len(yaws)} heading{'s' if len(yaws) > 1 else ''})"))

    def _report(self, name: str, fraction: float, message: str, running: bool = True, error: str | None = None) -> None:
        self._set_job(JobStatus(name, running, max(0.0, min(1.0, fraction)), message, error))

    def _hold(self) -> None:
        try:
            if self._turning is not None and not self._turning.done:
                self._link.hold()
        except Exception as exc:  # the link's errors: say so, the look still pauses / stops
            log.warning("look: hold failed: %s", exc)

    def _wait_if_paused(self, name: str, fraction: float, where: str) -> bool:
        """Wait while paused; ``False`` when stopped."""
        return self._wait_resumed(
            lambda: self._report(name, fraction, f"paused at {where} (Resume continues, Stop ends)"))

    def _turn(self, yaw: float) -> str | None:
        """Turn to ``yaw``; ``None`` when done, else why not (``paused`` when paused)."""
        st = self._link.latest_state()
        if st is None:
            return "no state from the robot"
        run = self._link.run_segment(turn_segment(st.position, yaw))
        self._turning = run
        deadline = time.monotonic() + TURN_TIMEOUT
        while not run.done:
            if self._pause.is_set() or self._stop.is_set():
                self._hold()
                run.wait(2.0)
                return "paused"
            if time.monotonic() > deadline:
                self._hold()
                return f"the turn to {_deg(yaw)}° did not end within {TURN_TIMEOUT:.0f} s"
            run.wait(0.05)
        self._turning = None
        if getattr(run.status, "value", "") != "done":
            if self._pause.is_set() or self._stop.is_set():
                return "paused"
            return f"the turn to {_deg(yaw)}° failed: {run.error}"
        return None

    def _run(self, name: str, yaws: list[float]) -> None:
        n = len(yaws)
        done = 0
        try:
            i = 0
            while i < n:
                where = f"heading {i + 1}/{n} ({_deg(yaws[i])}°)"
                if not self._wait_if_paused(name, i / n, where):
                    break
                self._report(name, (i + 0.1) / n, f"{where}: turning")
                why = self._turn(yaws[i])
                if why == "paused":
                    continue  # wait (or stop), then turn again to this heading
                if why is not None:
                    self._report(name, i / n, "stopped", running=False, error=why)
                    self._session.notify(name, f"stopped at {where}: {why}", "error")
                    return
                if not self._wait_if_paused(name, (i + 0.5) / n, where):
                    break
                self._report(name, (i + 0.5) / n, f"{where}: capturing and mapping")
                ok = self._mapping.run_as(f"{name} · {where}")
                if not ok:
                    job = self._session.job
                    why = job.error or job.message or "the capture failed"
                    self._report(name, (i + 1) / n, "stopped", running=False, error=f"{where}: {why}")
                    return
                self.last_mapped.append(len(self._session.scene.objects))
                done += 1
                i += 1
            if self._stop.is_set():
                self._report(name, done / n, f"stopped by the operator after {done} of {n} headings", running=False)
                return
            total = len(self._session.scene.objects)
            self._report(name, 1.0, f"done: {n} heading{'s' if n > 1 else ''} captured; the map has "
                                    f"{total} object{'s' if total != 1 else ''}", running=False)
        except Exception as exc:  # a bug or a link error: report it, keep the console alive
            log.exception("look failed")
            self._report(name, done / max(n, 1), "failed", running=False, error=str(exc))
            self._session.notify(name, f"failed: {exc}", "error")
        finally:
            self._turning = None


__all__ = ["LookJob", "headings_around", "LOOK_AROUND", "LOOK_AT", "DEFAULT_HEADINGS"]
