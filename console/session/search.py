"""Find: search for an object with the robot's own viewpoints, off the UI thread.

The loop (one search at a time), as the mission manager runs missions, observable and pausable:

1. capture & map where the robot stands (the console's :class:`~console.session.mapping_job.MappingJob`);
2. when the target is mapped with confidence (seen in :data:`CONFIRM_CAPTURES` captures, or once with
   a score of at least :data:`SURE_SCORE` and a position sigma of at most :data:`SURE_SIGMA`), plan to
   it with go-to-object (:func:`planner.object_goal.goal_beside`), go there and end: *found*; seen
   once but not sure: turn to face it and capture again;
3. otherwise pick the next viewpoint (:func:`console.session.search_choose.choose_viewpoint`) over seen
   space: every move of the search (the last one beside the target too) plans with unknown space
   closed, never through space no capture has seen;
4. in step mode wait for **Approve**; go there with an Aerial-Ground A* mission through the mission
   runner (walk, take off, fly, land), turn to the viewpoint's heading (a ``TURN`` segment), repeat.

Budgets (captures, time, battery: :class:`~console.session.search_types.SearchConfig`) end it with a
report that says what was left unseen and why; the console's battery rules still act on any mission.
**Pause** ends the move under way where the robot is (it holds; a turn holds too) and the loop waits;
Hold / Land here / Return then act on the robot as after aborting a mission (Land here lands on the
nearest seen-free floor when the floor below was not seen: :mod:`console.session.search_landing`);
**Resume** plans again from wherever the robot is (walking if it landed, taking off again if needed).
The mission panel's Pause / Resume / Abort act on the move under way as on any mission
(:mod:`console.session.search_moves`). **Stop** aborts the move and ends the search.

Every step is a session job update (``Find: robot dog``), a line in :attr:`SearchJob.steps` and a
``search`` event (:mod:`console.session.search_report`) the recording writes to ``/search/step`` and
``/search/result``. World frame [m], headings [rad].
"""

from __future__ import annotations

import logging
import math
import threading
import time
import uuid
from typing import Any

import numpy as np

from planner.mission import heading_to
from planner.object_goal import ObjectGoalError, goal_beside
from planner.route import Route
from planner.search_viewpoints import Viewpoint, cells_in_view

from console.session.job_thread import JobThread
from console.session.mapping_job import MappingJob
from console.session.operator_state import battery_level
from console.session.search_choose import GridCache, choose_viewpoint, confirm_choice
from console.session.search_finish import SearchFinish, is_contact, untried
from console.session.search_moves import BATTERY, PAUSED, STOPPED, SearchMoves
from console.session.search_report import (battery_low, left_unseen, result_event, result_headline, result_line,
                                           step_event, viewpoint_json)
from console.session.search_types import (
    CONFIRM_CAPTURES, GAIN_MIN, MISSION_TIMEOUT, MODES, SURE_SCORE, SURE_SIGMA, SearchConfig, SearchResult,
    target_height, target_matches,
)
from console.session.session import RUN, JobStatus, Session, SessionError
from console.wording import plural

log = logging.getLogger(__name__)


class SearchJob(SearchFinish, SearchMoves, JobThread):
    """Runs a search in a worker thread.

    Args:
        session: State, progress and notices.
        link: The robot link (``latest_state``, ``run_segment``, ``hold``).
        mapping: Capture & map, run in this job's thread.
        runner: The mission runner (``execute``, ``pause``, ``resume``, ``abort``).
    """

    def __init__(self, session: Session, link: Any, mapping: MappingJob, runner: Any) -> None:
        super().__init__(session)
        self._link, self._mapping, self._runner = link, mapping, runner
        self._approve = threading.Event()
        self._pause_why = ""
        self.config: SearchConfig | None = None
        self.chosen: Viewpoint | None = None
        self.waiting_approval = False
        self.result: SearchResult | None = None
        self.steps: list[str] = []
        self.search_id = ""
        self._last_pos: tuple[float, float, float] | None = None
        self._path = 0.0
        self._t0 = 0.0
        self._looked: np.ndarray | None = None  # cells in view of a capture that stayed unknown
        self._grids = GridCache()
        self._confirmed_from: list[tuple[float, float, float]] = []  # spots a confirming capture was taken from
        self._contact_routes: list[tuple[tuple[float, ...], tuple[float, ...]]] = []  # (start, goal) that hit
        session.subscribe(self._on_event)

    def _on_event(self, topic: str, payload: Any) -> None:
        """A Land here or Return the operator starts while the search runs pauses it (even mid-capture)."""
        if topic == RUN and getattr(payload, "state", "") == "running" and self.running and not self._pause.is_set():
            self._check_commands()

    # --- state / control ------------------------------------------------------------------------------
    @property
    def pause_reason(self) -> str:
        """Why the search is paused (``""`` when it is not)."""
        return self._pause_why if self.paused else ""

    def start(self, config: SearchConfig) -> None:
        """Start a search (returns at once). Raises :class:`SessionError` when one cannot start now."""
        st = self._robot_ready(self._link, self._mapping, "a search is already running: stop it first", "searching")
        with self._lock:
            self.config, self.chosen, self.result, self.steps = config, None, None, []
            self.search_id = f"search-{uuid.uuid4().hex[:6]}"
            self._approve.clear()
            self._path, self._last_pos = 0.0, tuple(float(v) for v in st.position)
            self._looked = None
            self._t0 = time.monotonic()
            self._land_nearest(True)  # before the thread: its end turns it off
            self._launch(self._run, "search")

    def pause(self) -> None:
        """Pause: the move under way ends where the robot is (it holds); Hold / Land here / Return are
        then free to act; :meth:`resume` plans again from where the robot is."""
        if not self.running:
            raise SessionError("no search is running")
        self._pause_for("paused by the operator")

    def _pause_for(self, why: str) -> None:
        self._pause_why = why
        self._request_pause()

    def resume(self) -> None:
        """Resume a paused search; a move the mission panel paused goes on (the manager's Resume)."""
        if not self.paused:
            raise SessionError("no search is paused")
        s = self._session
        if s.run.state == "paused" and not self._command_under_way() and self._runner is not None:
            try:
                self._runner.resume()
            except Exception as exc:
                raise SessionError(f"the paused move cannot go on: {exc}") from None
        self._request_resume()

    def approve(self) -> None:
        if not self.waiting_approval:
            raise SessionError("no move is waiting for approval")
        self._approve.set()

    def stop(self) -> None:
        """End the search (the move under way is aborted; the robot holds)."""
        if not self.running:
            return
        self._request_stop()

    # --- reporting ------------------------------------------------------------------------------------
    def _name(self) -> str:
        return f"Find: {self.config.target}" if self.config else "Find"

    def _step(self, kind: str, text: str, fraction: float | None = None, level: str = "", **extra: Any) -> None:
        """One step: a line in :attr:`steps`, the job's progress, a notice (``level``) and a ``search`` event."""
        line = f"{len(self.steps) + 1}. {text}"
        self.steps.append(line)
        log.info("search: %s", line)
        if fraction is None:
            fraction = self._session.job.fraction if self._session.job is not None else 0.5
        self._session.set_job(JobStatus(self._name(), True, fraction, text))
        if level:
            self._session.notify(self._name(), text, level)
        st = self._link.latest_state()
        r = self.result
        extra.setdefault("robot", [round(float(v), 3) for v in st.position] if st is not None else None)
        extra.setdefault("battery", getattr(st, "battery", None) if st is not None else None)
        extra.setdefault("captures", r.captures if r is not None else 0)
        extra.setdefault("elapsed", round(time.monotonic() - self._t0, 2))
        self._announce(step_event(self.search_id, len(self.steps), kind, text, **extra))

    def _pos(self) -> tuple[float, float, float]:
        p = tuple(float(v) for v in self._link.latest_state().position)
        if self._last_pos is not None:
            self._path += math.dist(p, self._last_pos)
        self._last_pos = p  # type: ignore[assignment]
        return p  # type: ignore[return-value]

    def _land_nearest(self, on: bool) -> None:
        """Land here lands on the nearest seen-free floor while a search runs (when the session can)."""
        setter = getattr(self._session, "set_land_nearest", None)
        if setter is not None:
            setter(on)

    # --- waiting --------------------------------------------------------------------------------------
    def _wait_paused(self) -> bool:
        """Wait while paused (and for a Land here or Return under way to end); ``False`` when stopped."""
        self._check_commands()
        if not self._pause.is_set() or self._stop.is_set():
            return not self._stop.is_set()
        self._step("paused", f"paused ({self._pause_why}): Hold, Land here and Return act on the robot; Resume plans "
                   "again from where the robot is, Stop ends the search")
        closed = False
        while self._pause.is_set() and not self._stop.is_set():
            if not closed and not self._session.run.active:
                self._set_unknown(False)  # Land here / Return plan over seen space only
                closed = True
            self._pos()  # the travel adds to the path length
            time.sleep(0.05)
        said = False
        while self._session.run.active and not self._stop.is_set():  # Land here / Return finishing
            if not said:
                self._step("paused", f"waiting for {self._command_under_way() or 'the mission under way'} to end")
                said = True
            self._pos()
            time.sleep(0.05)
        if self._stop.is_set():
            return False
        here = self._pos()
        self._step("resumed", f"resumed from ({here[0]:.2f}, {here[1]:.2f}, {here[2]:.2f}) m: planning again from here")
        return True

    # --- the loop -----------------------------------------------------------------------------------
    def _target(self) -> Any:
        cfg = self.config
        assert cfg is not None
        hits = [o for o in self._session.scene.objects if target_matches(o.label, cfg.target)]
        if not hits:
            return None, 0

        def seen(o: Any) -> int:
            return len({s.capture for s in o.history if s.used and s.capture}) or 1
        best = max(hits, key=lambda o: (seen(o), o.score))
        return best, seen(best)

    def _sure(self, obj: Any, n: int) -> bool:
        return n >= CONFIRM_CAPTURES or (obj.score >= SURE_SCORE and obj.sigma is not None and obj.sigma <= SURE_SIGMA)

    def _capture(self, what: str) -> bool:
        assert self.result is not None
        self.result.captures += 1
        ok = self._mapping.run_as(f"{self._name()} · capture {self.result.captures}: {what}")
        self._mark_looked()
        cap = self._session.capture
        self._step("capture", f"capture {self.result.captures} ({what}): " + (self._session.job.message if ok else
                   f"failed: {self._session.job.error or self._session.job.message}"),
                   capture_id=cap.id if ok and cap is not None else None)
        return ok

    def _mark_looked(self) -> None:
        """Unknown cells in the camera's view that stayed unknown after this capture count no more."""
        s, cfg = self._session, self.config
        known, st = s.known_space, self._link.latest_state()
        if known is None or st is None or cfg is None:
            return
        state = known.state()
        grid = s.grid
        if state.shape != grid.workspace.shape:
            return
        p = tuple(float(v) for v in st.position)
        eye = (p[0], p[1], max(p[2], grid.workspace.floor) + grid.robot.camera_height)
        seen = cells_in_view(state, grid, eye, float(st.yaw), cfg.target_height)
        self._looked = seen if self._looked is None else (self._looked | seen)

    def _battery_end(self) -> str | None:
        """The ``battery: ...`` report when the charge is below the search's reserve (or critical), else ``None``."""
        st = self._link.latest_state()
        b = getattr(st, "battery", None) if st is not None else None
        cfg = self.config
        if b is None or cfg is None:
            return None
        if battery_level(st) == "critical":
            return f"battery: {100 * b:.0f} % left: critical, the console lands the robot"
        return battery_low(float(b), cfg.min_battery)

    def _budget_end(self, cfg: SearchConfig, t0: float) -> str | None:
        r = self.result
        assert r is not None
        if r.captures >= cfg.max_captures:
            return f"not found: budget of {plural(cfg.max_captures, 'capture')} used"
        if time.monotonic() - t0 > cfg.max_time:
            return f"not found: time budget of {cfg.max_time:.0f} s used"
        return self._battery_end()

    def _run(self) -> None:
        cfg = self.config
        assert cfg is not None
        self._t0 = t0 = time.monotonic()
        self.result = r = SearchResult(target=cfg.target)
        try:
            r.reason = self._loop(cfg, t0)
        except Exception as exc:  # a bug or a link error: report it, keep the console alive
            log.exception("search failed")
            r.reason = f"failed: {exc}"
        finally:
            self._end(cfg, r, t0)

    def _end(self, cfg: SearchConfig, r: SearchResult, t0: float) -> None:
        s = self._session
        self._abort_move()
        self._set_unknown(False)
        pos = self._pos()
        r.final_position = [round(v, 3) for v in pos]
        r.path_length = round(self._path, 3)
        r.time = round(time.monotonic() - t0, 2)
        st = self._link.latest_state()
        r.battery = getattr(st, "battery", None) if st is not None else None
        if r.target_position is not None:
            r.distance_to_target = round(math.dist(pos[:2], r.target_position[:2]), 3)
        summ = s.known_summary() if s.known_space is not None else None
        r.seen_share = round(summ.seen_share, 3) if summ is not None else None
        if not r.found:
            r.left_unseen = self._unseen_text(pos, r.reason)
        r.steps = list(self.steps)
        text = result_headline(r)
        self._land_nearest(False)
        self._set_job(JobStatus(self._name(), False, 1.0, f"{text}: {plural(r.captures, 'capture')}, {r.path_length:.1f} m, "
                                                            f"{r.time:.0f} s"))
        s.notify(self._name(), result_line(r)
                 + (f"; left unseen: {r.left_unseen}" if r.left_unseen else ""), "success" if r.found else "warning")
        self._announce(result_event(self.search_id, r))

    def _announce(self, event: dict[str, Any]) -> None:
        """Tell the session's listeners (the recorder) a step or the end; never stops the search."""
        announce = getattr(self._session, "announce_search", None)
        if announce is None:
            return
        try:
            announce(event)
        except Exception:
            log.exception("search: cannot announce %s", event.get("kind", "the result"))

    def _unseen_text(self, pos: tuple[float, float, float], reason: str) -> str:
        s = self._session
        known = s.known_space
        why = reason.split(":")[0] if reason else "ended"
        if reason.startswith("not found: budget") or reason.startswith("not found: time"):
            why = "the budget ran out"
        elif reason.startswith("not found: "):
            why = reason[len("not found: "):]
        try:
            grid = self._grids.grid(s, "allow")
            start = (pos[0], pos[1], max(pos[2], grid.workspace.floor))
            cell = grid.workspace.cell_of(start)
            cost = Route(grid, start, s.weights).cost_array if cell is not None else None
            return left_unseen(None if known is None else known.state(), grid, cost, cell, why)
        except Exception as exc:  # the report must not fail the end
            log.info("search: left unseen: %s", exc)
            return ""

    def _loop(self, cfg: SearchConfig, t0: float) -> str:
        r = self.result
        assert r is not None
        self._step("start", f"searching for {cfg.target} ({cfg.mode} mode; budget {plural(cfg.max_captures, 'capture')}, "
                   f"{cfg.max_time:.0f} s, battery down to {100 * cfg.min_battery:.0f} %)", 0.02)
        if not self._capture("where the robot stands"):
            return "a capture failed"
        while True:
            if not self._wait_paused():
                return STOPPED
            obj, n = self._target()
            if obj is not None:
                r.target_id, r.target_position = obj.id, [round(v, 3) for v in obj.position]
                r.seen_by = sorted({s.capture for s in obj.history if s.capture})
                if self._sure(obj, n):
                    self._step("seen", f"{obj.label} {obj.id} mapped at ({obj.position[0]:.2f}, {obj.position[1]:.2f}) "
                               f"m, seen in {n} capture{'s' if n > 1 else ''}: going beside it", 0.9, target_id=obj.id)
                    return self._finish(obj)
                if r.captures >= cfg.max_captures:
                    return f"budget: {plural(cfg.max_captures, 'capture')} used ({obj.id} seen once, not confirmed)"
                here = self._pos()
                if not any(math.dist(here[:2], p[:2]) < 0.5 for p in self._confirmed_from):
                    self._step("seen", f"{obj.label} {obj.id} seen once: facing it to confirm", 0.7, target_id=obj.id)
                    if math.dist(here[:2], obj.position[:2]) > 0.3 and not self._turn(heading_to(here, obj.position)) \
                            and (self._pause.is_set() or self._stop.is_set()):
                        continue
                    self._confirmed_from.append(here)
                    self._capture(f"confirming {obj.id}")
                    continue
                self._step("seen", f"{obj.label} {obj.id} seen once; the confirming capture from here missed it: "
                           "confirming from another viewpoint", 0.7, target_id=obj.id)
            end = self._budget_end(cfg, t0)
            if end is not None:
                return end
            choice = None
            if obj is not None:  # seen once, missed from here: a spot elsewhere that faces it over seen space
                choice = confirm_choice(self._session, self._pos(), obj, self._confirmed_from, self._grids)
            if choice is None or choice.viewpoint is None:
                choice = choose_viewpoint(self._session, self._pos(), cfg.target_height, self._looked, self._grids)
            r.choose_seconds.append(round(choice.seconds, 3))
            here = self._pos()
            vp = self.chosen = untried(choice, here, self._contact_routes)
            if vp is None:
                return f"not found: {choice.why}" if choice.viewpoint is None else \
                    "not found: the moves to the viewpoints left ended in contact (not repeated)"
            self._step("viewpoint", f"next viewpoint {choice.why}: {vp.why}", min(0.85, r.captures / cfg.max_captures),
                       viewpoint=viewpoint_json(vp), candidates=[viewpoint_json(c) for c in choice.candidates],
                       choose_seconds=round(choice.seconds, 3))
            if cfg.mode == "step" and not self._approved():
                if self._stop.is_set():
                    return STOPPED
                continue
            here = self._pos()
            if math.dist(here, vp.goal) > 0.2 and not (vp.mode == "walk" and math.dist(here[:2], vp.goal[:2]) < 0.2
                                                        and here[2] < 0.1):
                self._check_commands()
                if self._pause.is_set():
                    continue
                why_not = self._go(vp.goal, "the viewpoint")
                if why_not in (PAUSED, STOPPED, BATTERY):
                    if why_not == BATTERY:
                        return self._battery_end() or "battery: the console's battery rule ended the move"
                    continue  # stopped: the loop's top says so
                if why_not is not None:
                    if is_contact(why_not):
                        r.contacts += 1
                        self._contact_routes.append((here, tuple(vp.goal)))
                    self._step("move", f"move not done: {why_not}; capturing where the robot is and planning again",
                               level="warning")
            if not self._wait_paused():
                return STOPPED
            if not self._turn(vp.yaw):
                if self._pause.is_set() or self._stop.is_set():
                    continue
            self._capture(f"from the viewpoint, facing {math.degrees(vp.yaw) % 360:.0f}°")

    def _approved(self) -> bool:
        """Step mode: wait for Approve (``False`` when stopped or paused meanwhile)."""
        self.waiting_approval = True
        self._step("approve", "waiting for Approve step")
        try:
            while not self._approve.is_set() and not self._stop.is_set() and not self._pause.is_set():
                self._check_commands()
                time.sleep(0.05)
        finally:
            self.waiting_approval = False
        ok = self._approve.is_set()
        self._approve.clear()
        return ok and not self._stop.is_set()

__all__ = ["GAIN_MIN", "MISSION_TIMEOUT", "MODES", "SearchConfig", "SearchJob", "SearchResult", "target_height",
           "target_matches"]
