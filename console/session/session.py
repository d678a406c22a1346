"""The console's state: scene, grid, route, mission, last capture, robot, jobs; save and restore.

Everything the operator sees lives here, behind one lock, and every change is announced to the
subscribed listeners (the views of every browser tab) as ``(topic, payload)``. Listeners run on
the thread that made the change, after the lock is released; they read what they need back
through the properties, which return immutable snapshots.

Frames and units: positions are in the world frame (the console's frame, z up) [m], yaw about
+z [rad]; the camera pose of a capture is ``world <- camera`` with the camera in the OpenCV
optical frame (x right, y down, z forward).

Persistence: the session folder holds ``session.json`` (scene, route, mission, settings, the
last capture's metadata, written after every change) and ``captures/`` (photo and depth of the
last capture); the code is :class:`console.session.session_store.Persistence`, mixed in here. Map edits
(spawn, move, delete, capture, load) can be undone with :meth:`Session.undo_edit`; scenes with
implausible objects are refused naming the field (:func:`pipeline.scene.check_plausible`). Names
typed by the operator are resolved with :meth:`Session.resolve_name`, which
refuses anything that would land outside the session folder.

Operator rules (the route starts at the robot, what Execute and the vehicle commands allow, runs
retired by edits, goals inside the robot's margin): :mod:`console.session.operator_state`, applied here by
:class:`console.session.operator_session.OperatorRules`, mixed in.

The pieces live next door and are re-exported here: topics in :mod:`console.session.topics`, value types
in :mod:`console.session.session_types`, the scene merge in :mod:`console.session.merge`, click picking in
:mod:`console.views.picking`, the session file format in :mod:`console.session.session_store` and the capture
files in :mod:`console.session.capture_files`.
"""

from __future__ import annotations

import logging
import math
import threading
from dataclasses import replace
from pathlib import Path
from typing import Any, Callable, Sequence

from pipeline.scene import Scene
from planner.grid import CostWeights, GridError, Workspace
from planner.mission import Mission
from planner.route import PlanResult, Route, path_points

from pipeline.scene import SceneError, check_plausible

from console.session.capture_files import CAPTURE_DIR
from console.session.history import History, Undo
from console.session.known_space_state import KnownSpaceSession
from console.session import edit_rules, goal_rules, mission_rules
from console.wording import plural
from console.session.merge import merge_observations, merge_report
from console.session.object_follow import ObjectFollow
from console.session.operator_session import OperatorRules
from console.session.pin_edit import PinEdits
from console.views.picking import click_goal, ray_plane
from console.session.session_reads import SessionReads
from console.session.session_store import SESSION_FILE, SESSION_VERSION, Persistence
from console.session.session_types import (
    CaptureRecord, Detection, JobStatus, Notice, RobotSnapshot, RouteSnapshot, RunStatus, SessionError, Settings,
    SpawnReport, Vec3, fmt_point,
)
from console.session.topics import (
    AGENT, CAPTURE, GRID, JOB, MISSION, NOTICE, ROBOT, ROUTE, RUN, SCENE, SEARCH, SELECTION, SETTINGS, Listener,
)

__all__ = [
    "CAPTURE", "CAPTURE_DIR", "GRID", "JOB", "MISSION", "NOTICE", "ROBOT", "ROUTE", "RUN", "SCENE", "SEARCH", "SELECTION",
    "SESSION_FILE", "SESSION_VERSION", "SETTINGS", "CaptureRecord", "Detection", "JobStatus", "Listener",
    "Notice", "RobotSnapshot", "RouteSnapshot", "RunStatus", "Session", "SessionError", "Settings",
    "SpawnReport", "Vec3", "merge_observations", "ray_plane",
]

log = logging.getLogger(__name__)


class Session(SessionReads, Persistence, Undo, OperatorRules, KnownSpaceSession, ObjectFollow, PinEdits):
    """All console state, thread-safe, observable, persisted in one folder (see :class:`Persistence`).

    Args:
        folder: Session folder (created); saves and capture images go there.
        start: Where the robot stands initially (world frame [m]); the route starts there.
        workspace: Planning bounds and resolution.
        margin: Robot radius [m]: cells this close to an obstacle are dangerous.
        weights: Aerial-Ground A* layer costs.
        autosave: Write ``session.json`` after every change.
        empty_is_unseen: The console's rule for a robot in a room nobody has looked at: before the
            first capture, a map with no scene file spawned or loaded is space no capture has seen
            (planned as all unknown: :meth:`~console.session.known_space_state.KnownSpaceSession.nothing_seen_locked`).
            Without it (scripts, benches, hand-made maps) a map without known space is taken as fully known.
    """

    def __init__(
        self,
        folder: str | Path,
        start: Sequence[float] = (2.5, 0.7, 0.0),
        workspace: Workspace = Workspace(),
        margin: float = 0.35,
        weights: CostWeights = CostWeights(),
        autosave: bool = True,
        empty_is_unseen: bool = False,
    ) -> None:
        self.folder = Path(folder).expanduser().resolve()
        self.folder.mkdir(parents=True, exist_ok=True)
        self._lock = threading.RLock()
        self._listeners: list[Listener] = []
        self._autosave = autosave
        self._workspace = workspace
        self._margin = margin
        self._weights = weights
        self._scene = Scene()
        self._known = None  # known space (console.session.known_space_state): None until the first capture
        self._plan_unknown = "closed"
        self._empty_is_unseen = bool(empty_is_unseen)
        self._map_given = False  # a scene file was spawned or a map loaded (a hand-made map: fully known)
        self._grid = self._grid_for_locked(self._scene)
        self._route = Route(self._grid, self._floor_point(start), weights)
        self._mission: Mission | None = None
        self._capture: CaptureRecord | None = None
        self._capture_meta: dict[str, Any] | None = None
        self._robot: RobotSnapshot | None = None
        self._job = JobStatus()
        self._run = RunStatus()
        self._selected: str | None = None
        self._settings = Settings()
        self._last_save_error: str | None = None
        self._restore_problems: list[str] = []
        self._outbox: list[Notice] = []  # notices raised under the lock, sent by the next _emit
        self._history = History()
        self._run_start: Vec3 | None = None  # where the robot is during a run: the route start shown

    # --- observers -----------------------------------------------------------------------------
    def subscribe(self, listener: Listener) -> Callable[[], None]:
        """Call ``listener(topic, payload)`` on every change; returns the unsubscribe function."""
        with self._lock:
            self._listeners.append(listener)

        def unsubscribe() -> None:
            with self._lock:
                if listener in self._listeners:
                    self._listeners.remove(listener)

        return unsubscribe

    def _emit(self, events: Sequence[tuple[str, Any]]) -> None:
        with self._lock:
            listeners = list(self._listeners)
            queued, self._outbox = self._outbox, []
        for topic, payload in [(NOTICE, n) for n in queued] + list(events):
            for listener in listeners:
                try:
                    listener(topic, payload)
                except Exception:  # a broken view must not break the session
                    log.exception("listener failed on %s", topic)

    def notify(self, title: str, body: str, level: str = "info") -> None:
        """Show a message to every connected operator (and log it)."""
        getattr(log, "warning" if level in ("warning", "error") else "info")("%s: %s", title, body)
        self._emit([(NOTICE, Notice(title, body, level))])

    def announce_agent(self, event: dict[str, Any]) -> None:
        """Tell every listener (the recorder, the agent panel) what a language-model agent did: a tool
        call, a proposal or the operator's decision (:mod:`console.mcp`); ``event`` is JSON-ready."""
        self._emit([(AGENT, dict(event))])

    def announce_search(self, event: dict[str, Any]) -> None:
        """Tell every listener (the recorder, replay) a search step or its end
        (:mod:`console.session.search_report`); ``event`` is JSON-ready."""
        self._emit([(SEARCH, dict(event))])

    # --- settings --------------------------------------------------------------------------------
    def set_goal_mode(self, mode: str, altitude: float | None = None) -> None:
        """Choose where clicked goals go: ``ground`` or ``altitude`` (height [m] above the floor)."""
        if mode not in ("ground", "altitude"):
            raise SessionError(f"goal mode must be 'ground' or 'altitude', got {mode!r}")
        with self._lock:
            s = self._settings
            alt = s.altitude if altitude is None else float(altitude)
            top = self._workspace.max[2] - self._workspace.floor
            if not (math.isfinite(alt) and 0.0 < alt < top):
                raise SessionError(f"altitude must be between 0 and {top:.2f} m above the floor, got {alt}")
            self._settings = replace(s, goal_mode=mode, altitude=alt)
        self._emit([(SETTINGS, None)])

    def set_click_to_goal(self, enabled: bool) -> None:
        with self._lock:
            self._settings = replace(self._settings, click_to_goal=bool(enabled))
        self._emit([(SETTINGS, None)])

    def goal_height(self) -> float:
        """World z [m] of a clicked goal under the current goal mode."""
        with self._lock:
            s = self._settings
            return self._workspace.floor + (s.altitude if s.goal_mode == "altitude" else 0.0)

    # --- route -----------------------------------------------------------------------------------
    def goal_from_ray(self, origin: Sequence[float], direction: Sequence[float], top_down: bool = False) -> Vec3:
        """The goal a click ray picks: its hit with the floor or the chosen altitude (world [m]); in a
        top view (``top_down``) the floor point under the cursor at the chosen altitude
        (:func:`console.views.picking.click_goal`)."""
        return click_goal(origin, direction, self.goal_height(), self._workspace, top_down)

    def add_goal(self, goal: Sequence[float]) -> PlanResult:
        """Plan a candidate from the last registered node (or the start) to ``goal`` (world [m]).

        On failure the previous candidate stays and the result's message says why.
        """
        g = tuple(float(v) for v in goal)
        if len(g) != 3 or not all(math.isfinite(v) for v in g):
            return PlanResult(False, f"goal must be 3 finite numbers [m], got {goal!r}")
        with self._lock:
            why = mission_rules.blocker("plan", self._run.state)
            if why is not None:
                return PlanResult(False, why)
            why = self._goal_problem_locked(g)  # type: ignore[arg-type]
            if why is None:  # a goal where the route already is would make a 0 m mission
                why = goal_rules.zero_length(g, self._route, self._workspace)  # type: ignore[arg-type]
            if why is not None:
                return PlanResult(False, why)
            res = goal_rules.nothing_seen(self._route.propose(g), self.nothing_seen_locked())
            if res.ok:
                self._save_locked()
        if res.ok:
            self._emit([(ROUTE, None)])
        return res

    def register(self) -> str:
        """Append the candidate to the registered (green) path; returns a message."""
        with self._lock:
            self._mission_rule_locked("register")
            if self._route.candidate is None:
                raise SessionError("there is no candidate path to register: click a goal first")
            n = len(self._route.candidate.cells)
            self._route.register()
            self._mission = None
            self._save_locked()
            count = len(self._route.registered)
        self._emit([(ROUTE, None), (MISSION, None)])
        return f"segment {count} registered ({plural(n, 'cell')})"

    def discard(self) -> None:
        """Drop the candidate path."""
        with self._lock:
            self._route.discard()
            self._save_locked()
        self._emit([(ROUTE, None)])

    def undo(self) -> str:
        """Remove the last registered segment."""
        with self._lock:
            self._mission_rule_locked("undo")
            if not self._route.undo():
                raise SessionError("nothing to undo: no registered segment")
            self._mission = None
            self._save_locked()
            left = len(self._route.registered)
        self._emit([(ROUTE, None), (MISSION, None)])
        return f"last segment removed, {left} left"

    def clear_route(self) -> None:
        """Remove the candidate, every registered segment and the mission."""
        with self._lock:
            self._mission_rule_locked("clear")
            self._route.clear()
            self._mission = None
            self._sync_start_locked()
            self._save_locked()
        self._emit([(ROUTE, None), (MISSION, None)])

    def _mission_rule_locked(self, button: str) -> None:
        """Refuse ``button`` with the reason when the mission state forbids it (:mod:`console.session.mission_rules`)."""
        why = mission_rules.blocker(button, self._run.state)
        if why is not None:
            raise SessionError(why)

    def build_mission(self) -> Mission:
        """Turn the registered path into a mission (walk / take-off / fly / land segments)."""
        with self._lock:
            self._mission_rule_locked("build")  # never while a mission is under way (paused included)
            if not self._route.registered:
                raise SessionError("register at least one path segment before building the mission")
            mission = self._build_locked()  # may start in the air (console.session.operator_state)
            self._mission = mission
            self._save_locked()
        self._emit([(MISSION, None)])
        return mission

    # --- scene -----------------------------------------------------------------------------------
    def spawn(self, scene: Scene, origin: str = "", replaces: Sequence[str] = ()) -> SpawnReport:
        """Add world-frame objects (re-sightings update the known object), rebuild the grid, replan.

        ``replaces``: ids of objects this one replaces (a scene file rewritten: the objects its previous
        version added), dropped first unless the operator has pinned them since. The merge runs on a
        snapshot outside the lock (it grows with the objects: seconds for thousands) and is swapped in
        when the map has not changed meanwhile, else merged again (under the lock the third time).

        Raises :class:`SessionError` naming the field of an implausible object; nothing changes then. A
        capture's objects over the robot's body are dropped, with a notice (:func:`edit_rules.drop_over_robot`).
        """
        what = f" from {origin}" if origin else ""
        self.check_plausible(scene, f"refused{what}")
        dropped = None
        if origin.startswith("capture "):  # a camera never sees the robot it is on: a perception error
            scene, dropped = edit_rules.drop_over_robot(scene, self.robot, origin)
        if not origin.startswith("capture "):
            self._map_given = True  # a scene file or a script's scene: a hand-made map, taken as fully known
        key = origin.replace(" ", ":", 1) if origin.startswith("capture ") else ""  # one undo step with set_capture
        drop = set(replaces)

        def base_of(current: Scene) -> Scene:
            if not drop:
                return current
            return current.with_objects([o for o in current.objects if o.id not in drop or o.is_pinned])

        for attempt in range(3):
            with self._lock:
                snapshot = self._scene
            if attempt < 2:
                merged, rep = merge_report(base_of(snapshot), scene)  # not under the lock
            with self._lock:
                if attempt == 2:
                    merged, rep = merge_report(base_of(self._scene), scene)
                elif self._scene is not snapshot:
                    continue  # the map changed while merging: merge again
                selected, (added, updated) = self._selected, (rep.added, rep.updated)
                notes = self._set_scene_locked(merged, f"spawn{what}", key)
                reselected, follow = self._follow_fusion_locked(rep.merged, rep.removed, selected, self._run.active)
                break
        log.info("spawned %d new and %d updated objects%s", len(added), len(updated), what)
        self._emit([(SCENE, None), (GRID, None), (ROUTE, None), (MISSION, None)]
                   + ([(SELECTION, getattr(self.selected, "id", None))] if reselected else []))
        if follow is not None:  # a candidate chosen by object whose object was merged: beside the survivor
            self._replan_followed(follow)
        if dropped:
            self.notify("Mapped object dropped", dropped, "warning")
        return SpawnReport(tuple(added), tuple(updated), tuple(notes))

    def delete_object(self, object_id: str) -> list[str]:
        """Remove an object from the map; the grid is rebuilt and the route re-checked. Its id is then refused
        as deleted by the operator (:meth:`~console.session.object_follow.ObjectFollow.resolve_object`)."""
        with self._lock:
            try:
                self._scene.object(object_id)
            except KeyError:
                raise SessionError(f"no object {object_id!r} in the map (was it deleted in another tab?)") from None
            scene = self._scene.with_objects([o for o in self._scene.objects if o.id != object_id])
            notes = self._set_scene_locked(scene, f"delete {object_id}")
            self._record_deletion_locked(object_id)
        self._emit([(SCENE, None), (GRID, None), (ROUTE, None), (MISSION, None), (SELECTION, None)])
        return notes

    def move_object(self, object_id: str, position: Sequence[float], yaw: float | None = None) -> list[str]:
        """Put an object at ``position`` (box centre, world [m]) and heading ``yaw`` [rad].

        Refused (:class:`SessionError`, nothing changed) where its box would overlap the robot's body
        (:func:`console.session.edit_rules.check_clear_of_robot`)."""
        p = tuple(float(v) for v in position)
        if len(p) != 3 or not all(math.isfinite(v) for v in p):
            raise SessionError(f"position must be 3 finite numbers [m], got {position!r}")
        if yaw is not None and not math.isfinite(yaw):
            raise SessionError(f"yaw must be a finite number [rad], got {yaw!r}")
        ws = self._workspace
        if not all(ws.min[a] - 1.0 <= p[a] <= ws.max[a] + 1.0 for a in range(3)):
            raise SessionError(f"position {fmt_point(p)} is far outside the workspace {fmt_point(ws.min)}..{fmt_point(ws.max)}")
        with self._lock:
            try:
                obj = self._scene.object(object_id)
            except KeyError:
                raise SessionError(f"no object {object_id!r} in the map (was it deleted in another tab?)") from None
            moved = obj.moved(p, yaw)  # type: ignore[arg-type]
            edit_rules.check_clear_of_robot(moved, edit_rules.robot_position(self._robot, self._route.start))
            objs = [moved if o.id == object_id else o for o in self._scene.objects]
            notes = self._set_scene_locked(self._scene.with_objects(objs), f"move {object_id}")
        self._emit([(SCENE, None), (GRID, None), (ROUTE, None), (MISSION, None), (SELECTION, object_id)])
        return notes

    def select(self, object_id: str | None) -> None:
        """Select an object (``None`` clears the selection)."""
        with self._lock:
            if object_id is not None:
                try:
                    self._scene.object(object_id)
                except KeyError:
                    raise SessionError(f"no object {object_id!r} in the map") from None
            self._selected = object_id
        self._emit([(SELECTION, object_id)])

    def check_plausible(self, scene: Scene, what: str = "refused") -> None:
        """Raise :class:`SessionError` (``what: objects[0].size[0]: ...``) for objects no room holds."""
        ws = self._workspace
        try:
            check_plausible(scene, ws.min, ws.max)
        except SceneError as exc:
            raise SessionError(f"{what}: {exc}") from None

    def _set_scene_locked(self, scene: Scene, label: str, key: str = "") -> list[str]:
        """Swap in ``scene`` (undoably, as ``label``); warns every tab when registered segments are lost."""
        grid = self._grid_for_locked(scene)  # with the known space, if any
        self._remember_locked(label, key)
        old_grid, had_mission = self._grid, self._mission is not None
        goals = [tuple(path_points(seg, old_grid)[-1]) for seg in self._route.registered if len(seg)]
        self._scene = scene
        self._grid = grid
        notes = self._route.set_grid(grid)
        self._mission = self._mission_after_edit_locked()
        kept = len(self._route.registered)
        if kept < len(goals):
            one = kept + 1 == len(goals)
            segs = f"segment {kept + 1}" if one else f"segments {kept + 1}-{len(goals)}"
            to = ", ".join(fmt_point(g) for g in goals[kept:])
            self._outbox.append(Notice(
                "Route segments removed",
                f"{label}: registered {segs} (to {to}) now "
                + ("crosses obstacles and was removed" if one else "cross obstacles and were removed")
                + ("; the mission was retired" if had_mission and self._mission is None else "")
                + (". Undo brings it back." if one else ". Undo brings them back."), "warning"))
        if self._selected is not None and self._selected not in {o.id for o in scene.objects}:
            self._selected = None
        self._save_locked()
        return notes

    # --- capture, robot, jobs ------------------------------------------------------------------
    def set_capture(self, record: CaptureRecord) -> None:
        """Show a new capture (photo, detections, depth, camera pose); saved with the session."""
        with self._lock:
            self._remember_locked(f"capture {record.id}", f"capture:{record.id}")
            self._capture = record
            self._capture_meta = self._store_capture_locked(record)
            self._save_locked()
        self._emit([(CAPTURE, record)])

    def set_robot(self, state: RobotSnapshot) -> None:
        """Record the robot's live state; an idle route start follows the robot, and during a run
        (every kind, paused included) the start shown follows it too (:func:`goal_rules.run_start`)."""
        with self._lock:
            self._robot = state
            moved = self._sync_start_locked()
            if moved:
                self._save_locked()
            shown = goal_rules.run_start(state, self._run.active, self._workspace, self._run_start)
            followed, self._run_start = shown != self._run_start, shown
        events: list[tuple[str, Any]] = [(ROBOT, state)]
        if moved or followed:
            events.append((ROUTE, None))
        self._emit(events)

    def set_job(self, status: JobStatus, *, background: bool = False) -> bool:
        """Show a job's progress to every tab; ``True`` if shown.

        ``background=True`` (a job nobody asked for, e.g. the start-up model loading) never replaces
        another job's status: once a capture has reported, the bar is the capture's.
        """
        with self._lock:
            if background and self._job.name not in ("", status.name):
                return False
            self._job = status
        self._emit([(JOB, status)])
        return True

    def set_run(self, status: RunStatus) -> None:
        with self._lock:
            self._run = status
            if not status.active:
                self._run_start = None  # the route's own start is shown again
        self._emit([(RUN, status)])

    def complete_mission(self) -> None:
        """The mission was flown: retire its route and mission, start again under the robot."""
        with self._lock:
            self._route.clear()
            self._mission = None
            self._run = replace(self._run, state="done") if self._run.active else self._run
            self._sync_start_locked()
            self._save_locked()
        self._emit([(ROUTE, None), (MISSION, None)])

    def _sync_start_locked(self) -> bool:
        """The route starts at the robot (rules in :mod:`console.session.operator_state`); True if it changed."""
        return self._follow_robot_locked()

    def _apply_saved(self, saved: Any, where: str, remember: str | None) -> list[str]:
        """A restored or loaded map without known space holding an object no capture mapped (a scene
        file's) is a hand-made one, taken as fully known."""
        with self._lock:
            self._map_given = self._map_given or (saved.known is None and any(
                o.source.capture is None for o in saved.scene.objects))
        return super()._apply_saved(saved, where, remember)

    def _ready_locked(self, state: Any) -> Any:
        """An undo step read back from ``history.json`` gets its grid under this session's rules."""
        if state.grid is None:
            state = replace(state, grid=self._grid_for_locked(state.scene, state.known))
        return super()._ready_locked(state)

    def _floor_point(self, p: Sequence[float]) -> Vec3:
        return (float(p[0]), float(p[1]), self._workspace.floor)
