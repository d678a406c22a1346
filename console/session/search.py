"""Find: search for an object with the robot's own viewpoints, off the UI thread.

The loop (one search at a time), as the mission manager runs missions, observable and pausable:

1. capture & map where the robot stands (the console's :class:`~console.session.mapping_job.MappingJob`);
2. when the target is mapped with confidence (seen in :data:`CONFIRM_CAPTURES` captures, or once with
   a score of at least :data:`SURE_SCORE` and a position sigma of at most :data:`SURE_SIGMA`), plan to
   it with go-to-object (:func:`planner.object_goal.goal_beside`), go there and end: *found*; seen
   once but not sure: turn to face it and capture again;
3. otherwise pick the next viewpoint (:func:`planner.search_viewpoints.score_viewpoints`) over seen
   space; when nothing seen still shows unknown space where the target can be, over unknown space
   too (said in the step: the route's unseen metres), as the operator's *Plan into unknown space*;
4. in step mode wait for **Approve**; go there with an Aerial-Ground A* mission through the mission
   runner (walk, take off, fly, land), turn to the viewpoint's heading (a ``TURN`` segment), repeat.

Budgets (captures, time) end it with a report; the console's battery rules end the mission under
way as they do any mission. **Pause** ends the move under way where the robot is (it holds; a turn
holds too) and the loop waits; Hold / Land here / Return then act on the robot as ever (as after
aborting a mission); **Resume** plans again from wherever the robot is. **Stop** aborts the mission and ends the search.

Every step is a session job update (``Find: robot dog``) and a notice, so the recording's /log and
the job channel carry it; :attr:`SearchJob.steps` keeps the lines. World frame [m], headings [rad].
"""

from __future__ import annotations

import json
import logging
import math
import re
import threading
import time
from dataclasses import asdict, dataclass, field
from typing import Any

import numpy as np

from planner.mission import heading_to, turn_segment
from planner.object_goal import ObjectGoalError, goal_beside
from planner.route import Route
from planner.search_viewpoints import Viewpoint, cells_in_view, score_viewpoints

from console.session.mapping_job import MappingJob
from console.session.session import JobStatus, Session, SessionError

log = logging.getLogger(__name__)

CONFIRM_CAPTURES = 2
SURE_SCORE = 0.8
SURE_SIGMA = 0.15
"""[m]"""
GAIN_MIN = 0.25
"""Least weighted unknown volume [m³] a seen-space viewpoint must show before the search looks into unknown space."""
MODES = ("auto", "step")
MISSION_TIMEOUT = 900.0
"""Longest wait for one move [s]."""


def _norm(text: str) -> str:
    return re.sub(r"[\s_\-]+", "_", text.strip().lower())


@dataclass(frozen=True)
class SearchConfig:
    """What to find and how.

    Attributes:
        target: A catalog class or the operator's words (``robot dog`` = ``robot_dog``).
        mode: ``auto`` (moves on its own) or ``step`` (each move waits for Approve).
        max_captures: Capture budget.
        max_time: Time budget [s].
        target_height: Height of the target [m] (the catalog's for its class; unknown space up to it counts fully).
    """

    target: str
    mode: str = "auto"
    max_captures: int = 20
    max_time: float = 900.0
    target_height: float = 0.6

    def __post_init__(self) -> None:
        if not isinstance(self.target, str) or not self.target.strip() or len(self.target) > 200:
            raise SessionError("target: must be 1..200 characters (a catalog class or a prompt)")
        if self.mode not in MODES:
            raise SessionError(f"mode: must be one of {', '.join(MODES)}, got {self.mode!r}")
        if isinstance(self.max_captures, bool) or not isinstance(self.max_captures, int) or not 1 <= self.max_captures <= 200:
            raise SessionError(f"max_captures: must be a whole number within 1..200, got {self.max_captures!r}")
        for name, hi in (("max_time", 86400.0), ("target_height", 10.0)):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) or not 0 < v <= hi:
                raise SessionError(f"{name}: must be finite and within 0..{hi:g}, got {v!r}")


@dataclass
class SearchResult:
    """How a search ended (``result.json``)."""

    found: bool = False
    target: str = ""
    target_id: str | None = None
    target_position: list[float] | None = None
    seen_by: list[str] = field(default_factory=list)
    final_position: list[float] | None = None
    distance_to_target: float | None = None
    path_length: float = 0.0
    captures: int = 0
    time: float = 0.0
    reason: str = ""
    seen_share: float | None = None
    steps: list[str] = field(default_factory=list)

    def to_json(self) -> str:
        return json.dumps(asdict(self), indent=1)


def target_height(target: str, default: float = 0.6) -> float:
    """The catalog's height [m] of ``target``'s class, else ``default`` (a prompt, an unknown class)."""
    try:
        from pipeline.catalog import Catalog

        entry = Catalog.load().lookup(target.strip().replace(" ", "_"))
        h = entry.height if entry is not None else None
        return float(h) if h else default
    except Exception:  # no catalog: the default
        return default


def target_matches(label: str, target: str) -> bool:
    a, b = _norm(label), _norm(target)
    return a == b or (b.endswith("s") and a == b[:-1])


class SearchJob:
    """Runs a search in a worker thread.

    Args:
        session: State, progress and notices.
        link: The robot link (``latest_state``, ``run_segment``, ``hold``).
        mapping: Capture & map, run in this job's thread.
        runner: The mission runner (``execute``, ``pause``, ``resume``, ``abort``).
    """

    def __init__(self, session: Session, link: Any, mapping: MappingJob, runner: Any) -> None:
        self._session, self._link, self._mapping, self._runner = session, link, mapping, runner
        self._lock = threading.Lock()
        self._thread: threading.Thread | None = None
        self._pause = threading.Event()
        self._stop = threading.Event()
        self._approve = threading.Event()
        self.config: SearchConfig | None = None
        self.chosen: Viewpoint | None = None
        self.waiting_approval = False
        self.result: SearchResult | None = None
        self.steps: list[str] = []
        self._last_pos: tuple[float, float, float] | None = None
        self._path = 0.0
        self._looked: np.ndarray | None = None  # cells in view of a capture that stayed unknown

    # --- state / control ------------------------------------------------------------------------------
    @property
    def running(self) -> bool:
        with self._lock:
            return self._thread is not None and self._thread.is_alive()

    @property
    def paused(self) -> bool:
        return self.running and self._pause.is_set()

    def wait(self, timeout: float | None = None) -> bool:
        with self._lock:
            t = self._thread
        if t is not None:
            t.join(timeout)
            return not t.is_alive()
        return True

    def start(self, config: SearchConfig) -> None:
        """Start a search (returns at once). Raises :class:`SessionError` when one cannot start now."""
        if self.running:
            raise SessionError("a search is already running: stop it first")
        if self._mapping.running:
            raise SessionError("a capture is being mapped: wait for it")
        if self._session.run.active:
            raise SessionError("a mission is under way (running or paused): abort it before searching")
        st = self._link.latest_state() if self._link is not None else None
        if st is None or not getattr(st, "link_ok", False):
            raise SessionError("no state from the robot: is the link connected?")
        with self._lock:
            self.config, self.chosen, self.result, self.steps = config, None, None, []
            self._pause.clear()
            self._stop.clear()
            self._approve.clear()
            self._path, self._last_pos = 0.0, tuple(float(v) for v in st.position)
            self._looked = None
            self._thread = threading.Thread(target=self._run, name="search", daemon=True)
            self._thread.start()

    def pause(self) -> None:
        if not self.running:
            raise SessionError("no search is running")
        self._pause.set()
        if self._session.run.active and self._runner is not None:  # the move ends where the robot is: it holds,
            try:  # and Hold / Land here / Return are free to act; Resume plans again from there
                self._runner.abort()
            except Exception as exc:
                log.info("search pause: %s", exc)

    def resume(self) -> None:
        if not self.paused:
            raise SessionError("no search is paused")
        self._pause.clear()

    def approve(self) -> None:
        if not self.waiting_approval:
            raise SessionError("no move is waiting for approval")
        self._approve.set()

    def stop(self) -> None:
        if not self.running:
            return
        self._stop.set()
        if self._session.run.active and self._runner is not None:
            try:
                self._runner.abort()
            except Exception as exc:
                log.info("search stop: %s", exc)

    # --- the loop -----------------------------------------------------------------------------------
    def _name(self) -> str:
        return f"Find: {self.config.target}" if self.config else "Find"

    def _say(self, text: str, fraction: float = 0.5, level: str = "") -> None:
        line = f"{len(self.steps) + 1}. {text}"
        self.steps.append(line)
        log.info("search: %s", line)
        self._session.set_job(JobStatus(self._name(), True, fraction, text))
        if level:
            self._session.notify(self._name(), text, level)

    def _pos(self) -> tuple[float, float, float]:
        p = tuple(float(v) for v in self._link.latest_state().position)
        if self._last_pos is not None:
            self._path += math.dist(p, self._last_pos)
        self._last_pos = p  # type: ignore[assignment]
        return p  # type: ignore[return-value]

    def _hold_while_paused(self) -> bool:
        """Wait while paused; ``False`` when stopped."""
        if self._pause.is_set() and not self._stop.is_set():
            self._say("paused (Resume plans again from where the robot is, Stop ends)")
            while self._pause.is_set() and not self._stop.is_set():
                self._pos()  # the travel adds to the path length
                time.sleep(0.05)
        return not self._stop.is_set()

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
        self._say(f"capture {self.result.captures} ({what}): " + (self._session.job.message if ok else
                  f"failed: {self._session.job.error or self._session.job.message}"))
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

    def _turn(self, yaw: float) -> bool:
        st = self._link.latest_state()
        run = self._link.run_segment(turn_segment(st.position, yaw))
        deadline = time.monotonic() + 60.0
        while not run.done and time.monotonic() < deadline:
            if self._pause.is_set() or self._stop.is_set():
                self._link.hold()
                return False
            run.wait(0.05)
        return getattr(run.status, "value", "") == "done"

    def _go(self, goal: tuple[float, float, float], what: str) -> str | None:
        """Plan from the robot to ``goal`` and run it; ``None`` when there, else why not."""
        s = self._session
        try:
            if s.route_snapshot().registered or s.route_snapshot().candidate is not None:
                s.clear_route()
        except SessionError as exc:
            return str(exc)
        res = s.add_goal(goal)
        if not res.ok:
            return f"no route to {what}: {res.message}"
        s.register()
        mission = s.build_mission()
        kinds = "-".join(dict.fromkeys(mission.kinds()))
        self._say(f"going to {what}: {kinds} ({res.message})")
        self._runner.execute(mission)
        deadline = time.monotonic() + MISSION_TIMEOUT
        while time.monotonic() < deadline:
            self._pos()  # the travel adds to the path length
            state = s.run.state
            if self._stop.is_set():
                return "stopped by the operator"
            if state == "paused" and not self._pause.is_set():  # the manager paused it (a step failed or refused)
                why = s.run.message
                self._abort_move()
                return f"the move stopped: {why}"
            if self._pause.is_set():
                if not self._hold_while_paused():
                    return "stopped by the operator"
                self._abort_move()
                return "paused"
            if state in ("done", "aborted", "failed") or (state == "idle" and not s.run.active):
                break
            time.sleep(0.05)
        self._pos()  # the travel adds to the path length
        return None if s.run.state == "done" else f"the move ended {s.run.state}: {s.run.message}"

    def _abort_move(self) -> None:
        """End the mission under way, if any (the robot holds), and wait for it to end."""
        s = self._session
        if s.run.active:
            try:
                self._runner.abort()
            except Exception as exc:
                log.info("search: abort: %s", exc)
            end = time.monotonic() + 60
            while s.run.active and time.monotonic() < end:
                time.sleep(0.05)

    def _choose(self) -> tuple[Viewpoint | None, str]:
        s, cfg = self._session, self.config
        assert cfg is not None
        known = s.known_space
        if known is None:
            return None, "no known space yet"
        state = known.state()
        here = self._pos()
        for allow in (False, True):
            if allow != (s.plan_unknown == "allow"):
                s.set_plan_unknown(allow)
            grid = s.grid
            start = (here[0], here[1], max(here[2], grid.workspace.floor))
            cell = grid.workspace.cell_of(start)
            if cell is None:
                return None, f"the robot at {start} is outside the workspace"
            cost = Route(grid, start, s.weights).cost_array
            vps = score_viewpoints(state, grid, cost, cell, cfg.target_height, seen_only=not allow, limit=3,
                                   looked=self._looked)
            if vps and vps[0].gain >= GAIN_MIN:
                return vps[0], ("over unknown space (nothing seen shows more)" if allow else "over seen space")
        return None, "no reachable viewpoint shows unknown space where the target can be"

    def _run(self) -> None:
        cfg = self.config
        assert cfg is not None
        t0 = time.monotonic()
        self.result = r = SearchResult(target=cfg.target)
        try:
            r.reason = self._loop(cfg, t0)
        except Exception as exc:  # a bug or a link error: report it, keep the console alive
            log.exception("search failed")
            r.reason = f"failed: {exc}"
        finally:
            if self._session.plan_unknown == "allow":
                try:
                    self._session.set_plan_unknown(False)
                except Exception:
                    pass
            pos = self._pos()
            r.final_position = [round(v, 3) for v in pos]
            r.path_length = round(self._path, 3)
            r.time = round(time.monotonic() - t0, 2)
            if r.target_position is not None:
                r.distance_to_target = round(math.dist(pos[:2], r.target_position[:2]), 3)
            summ = self._session.known_summary() if self._session.known_space is not None else None
            r.seen_share = round(summ.seen_share, 3) if summ is not None else None
            r.steps = list(self.steps)
            text = (f"found {r.target_id} at {r.distance_to_target:.2f} m" if r.found and r.distance_to_target is not None
                    else r.reason)
            self._session.set_job(JobStatus(self._name(), False, 1.0, f"{text}: {r.captures} captures, "
                                            f"{r.path_length:.1f} m, {r.time:.0f} s"))
            self._session.notify(self._name(), f"{text} ({r.captures} captures, {r.path_length:.1f} m travelled)",
                                 "success" if r.found else "warning")

    def _loop(self, cfg: SearchConfig, t0: float) -> str:
        r = self.result
        assert r is not None
        self._say(f"searching for {cfg.target} ({cfg.mode} mode; budget {cfg.max_captures} captures, "
                  f"{cfg.max_time:.0f} s)", 0.02)
        if not self._capture("where the robot stands"):
            return "a capture failed"
        while True:
            if not self._hold_while_paused():
                return "stopped by the operator"
            obj, n = self._target()
            if obj is not None:
                r.target_id, r.target_position = obj.id, [round(v, 3) for v in obj.position]
                r.seen_by = sorted({s.capture for s in obj.history if s.capture})
                if self._sure(obj, n):
                    self._say(f"{obj.label} {obj.id} mapped at ({obj.position[0]:.2f}, {obj.position[1]:.2f}) m, seen in "
                              f"{n} capture{'s' if n > 1 else ''}: going beside it", 0.9)
                    return self._finish(obj)
                if r.captures >= cfg.max_captures:
                    return f"budget: {cfg.max_captures} captures used ({obj.id} seen once, not confirmed)"
                here = self._pos()
                self._say(f"{obj.label} {obj.id} seen once: facing it to confirm", 0.7)
                if math.dist(here[:2], obj.position[:2]) > 0.3:
                    self._turn(heading_to(here, obj.position))
                self._capture(f"confirming {obj.id}")
                continue
            if r.captures >= cfg.max_captures:
                return f"not found: budget of {cfg.max_captures} captures used"
            if time.monotonic() - t0 > cfg.max_time:
                return f"not found: time budget of {cfg.max_time:.0f} s used"
            vp, why = self._choose()
            self.chosen = vp
            if vp is None:
                return f"not found: {why}"
            self._say(f"next viewpoint {why}: {vp.why}", min(0.85, r.captures / cfg.max_captures))
            if cfg.mode == "step":
                self.waiting_approval = True
                self._say("waiting for Approve step")
                while not self._approve.is_set() and not self._stop.is_set():
                    time.sleep(0.05)
                self.waiting_approval = False
                self._approve.clear()
                if self._stop.is_set():
                    return "stopped by the operator"
            here = self._pos()
            if math.dist(here, vp.goal) > 0.2 and not (vp.mode == "walk" and math.dist(here[:2], vp.goal[:2]) < 0.2
                                                        and here[2] < 0.1):
                why_not = self._go(vp.goal, "the viewpoint")
                if why_not == "paused":
                    continue
                if why_not is not None:
                    if self._stop.is_set():
                        return "stopped by the operator"
                    self._say(f"move not done: {why_not}; capturing where the robot is", level="warning")
            if not self._hold_while_paused():
                return "stopped by the operator"
            self._turn(vp.yaw)
            self._capture(f"from the viewpoint, facing {math.degrees(vp.yaw) % 360:.0f}°")

    def _finish(self, obj: Any) -> str:
        r = self.result
        assert r is not None
        s = self._session
        for _ in range(3):
            here = self._pos()
            grid = s.grid
            try:
                _, app = goal_beside(s.scene, grid, obj.id, here, Route(grid, here, s.weights))
            except ObjectGoalError as exc:
                if s.plan_unknown != "allow":
                    s.set_plan_unknown(True)
                    continue
                return f"found but cannot reach it: {exc}"
            if math.dist(here[:2], app.goal[:2]) < 0.2 and here[2] < 0.1:
                r.found = True
                return "found"
            why = self._go(tuple(float(v) for v in app.goal), f"beside {obj.id}")
            if why is None:
                r.found = True
                return "found"
            if why == "paused":
                if not self._hold_while_paused():
                    return "stopped by the operator"
                continue
            if self._stop.is_set():
                return "stopped by the operator"
            self._say(f"the move beside {obj.id} did not end there: {why}; planning again", level="warning")
        return "found but the move beside it failed"


__all__ = ["SearchConfig", "SearchJob", "SearchResult", "target_height", "target_matches", "MODES"]
