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
last capture). Names typed by the operator are resolved with :meth:`Session.resolve_name`, which
refuses anything that would land outside the session folder.
"""

from __future__ import annotations

import json
import logging
import math
import re
import threading
import time
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any, Callable, Mapping, Sequence

import numpy as np

from pipeline.geometry import Intrinsics, Pose
from pipeline.scene import Scene, SceneError, SceneObject, scene_from_dict, scene_to_dict, write_text_atomic
from planner.grid import CostWeights, GridError, PlanningGrid, Workspace, build_grid
from planner.mission import Mission, MissionError
from planner.route import PlanResult, Route, path_points

log = logging.getLogger(__name__)

Vec3 = tuple[float, float, float]

SESSION_VERSION = 1
SESSION_FILE = "session.json"
CAPTURE_DIR = "captures"

# Topics announced to listeners (payload in brackets).
SCENE = "scene"  # scene objects changed [None]
GRID = "grid"  # planning grid rebuilt [None]
ROUTE = "route"  # candidate / registered path changed [None]
MISSION = "mission"  # mission built or cleared [None]
RUN = "run"  # mission execution status [RunStatus]
CAPTURE = "capture"  # new last capture [CaptureRecord]
ROBOT = "robot"  # live robot state [RobotSnapshot]
JOB = "job"  # background job progress [JobStatus]
SELECTION = "selection"  # selected object changed [str | None]
SETTINGS = "settings"  # goal mode / altitude / layers changed [None]
NOTICE = "notice"  # message for every operator [Notice]

Listener = Callable[[str, Any], None]


class SessionError(ValueError):
    """An operator request that cannot be carried out; the message says why."""


# --- value types -------------------------------------------------------------------------------


@dataclass(frozen=True)
class Notice:
    """A message shown to every connected operator."""

    title: str
    body: str
    level: str = "info"  # info | success | warning | error


@dataclass(frozen=True)
class Detection:
    """One detection of a capture, for drawing on the photo.

    Attributes:
        label: Class name.
        score: Confidence in [0, 1].
        bbox: ``(x1, y1, x2, y2)`` [px] in the capture's image.
        object_id: Id of the scene object it became, if any.
    """

    label: str
    score: float
    bbox: tuple[float, float, float, float]
    object_id: str | None = None


@dataclass(frozen=True)
class CaptureRecord:
    """The last photo the robot took and what the pipeline made of it.

    Attributes:
        id: Capture id (matches ``SceneObject.source.capture``).
        image: RGB photo, H x W x 3 uint8.
        intrinsics: Intrinsics of ``image`` [px].
        camera_pose: ``world <- camera`` (camera in the OpenCV optical frame).
        robot_pose: ``world <- robot`` at capture time.
        detections: Boxes found in the photo.
        depth: Depth along the optical axis [m], H x W float32, or ``None``.
        backend: What produced the detections, for the operator (e.g. ``ground truth (sim)``).
        timings: Wall time per stage [s].
        timestamp: Capture time [s since the epoch].
    """

    id: str
    image: np.ndarray
    intrinsics: Intrinsics
    camera_pose: Pose
    robot_pose: Pose
    detections: tuple[Detection, ...] = ()
    depth: np.ndarray | None = None
    backend: str = ""
    timings: Mapping[str, float] = field(default_factory=dict)
    timestamp: float = field(default_factory=time.time)


@dataclass(frozen=True)
class RobotSnapshot:
    """The robot as last reported by the link (world frame).

    Attributes:
        pose: ``world <- robot`` [m, rad].
        mode: Locomotion / autopilot mode as reported (``walk``, ``fly``, ``idle`` ...).
        armed: Whether the motors are armed.
        battery: Charge in [0, 1], or ``None`` if unknown.
        healthy: Whether the link is alive.
        detail: Free text from the link (e.g. the failing check).
        stamp: Time of the report [s since the epoch].
    """

    pose: Pose
    mode: str = "unknown"
    armed: bool = False
    battery: float | None = None
    healthy: bool = True
    detail: str = ""
    stamp: float = field(default_factory=time.time)


@dataclass(frozen=True)
class JobStatus:
    """Progress of a background job (mapping, scene import).

    Attributes:
        name: What runs (``Capture & map``).
        running: Whether it is still running.
        fraction: Progress in [0, 1].
        message: Current stage, or the outcome when finished.
        error: Error text when it failed.
    """

    name: str = ""
    running: bool = False
    fraction: float = 0.0
    message: str = ""
    error: str | None = None


@dataclass(frozen=True)
class RunStatus:
    """Mission execution as reported by the mission manager.

    Attributes:
        state: ``idle``, ``running``, ``paused``, ``failsafe`` (link lost: holding or landing),
            ``done``, ``aborted`` or ``failed``.
        segment: Index of the segment being executed, or ``None``.
        fraction: Overall progress in [0, 1].
        message: Human-readable status.
    """

    state: str = "idle"
    segment: int | None = None
    fraction: float = 0.0
    message: str = ""

    @property
    def active(self) -> bool:
        """Whether a mission is under way (the route must not change under it)."""
        return self.state in ("running", "paused", "failsafe")


@dataclass(frozen=True)
class RouteSnapshot:
    """What the paths view draws (world frame [m]).

    Attributes:
        start: Where the route starts.
        registered: One point array (K x 3) per registered segment.
        candidate: Candidate path points (K x 3), or ``None``.
        candidate_goal: Goal of the candidate, or ``None``.
        goals: End point of each registered segment.
    """

    start: Vec3
    registered: tuple[np.ndarray, ...]
    candidate: np.ndarray | None
    candidate_goal: Vec3 | None
    goals: tuple[Vec3, ...]


@dataclass(frozen=True)
class Settings:
    """Operator choices shared by every tab.

    Attributes:
        goal_mode: ``ground`` (goals on the floor) or ``altitude`` (goals at ``altitude``).
        altitude: Goal height above the floor [m] in ``altitude`` mode.
        click_to_goal: Whether a click in the 3D view adds a goal.
    """

    goal_mode: str = "ground"
    altitude: float = 1.5
    click_to_goal: bool = True


@dataclass(frozen=True)
class SpawnReport:
    """What :meth:`Session.spawn` did."""

    added: tuple[str, ...]
    updated: tuple[str, ...]
    notes: tuple[str, ...]


# --- helpers -----------------------------------------------------------------------------------


def ray_plane(origin: Sequence[float], direction: Sequence[float], z: float) -> Vec3 | None:
    """Where a ray meets the horizontal plane at height ``z`` [m] (world), or ``None``.

    ``None`` when the ray is parallel to the plane or the plane lies behind the origin.
    """
    o = np.asarray(origin, dtype=np.float64)
    d = np.asarray(direction, dtype=np.float64)
    if o.shape != (3,) or d.shape != (3,) or not (np.all(np.isfinite(o)) and np.all(np.isfinite(d))):
        return None
    if abs(d[2]) < 1e-9:
        return None
    t = (z - o[2]) / d[2]
    if t <= 0:
        return None
    p = o + t * d
    return (float(p[0]), float(p[1]), float(z))


def _fmt(p: Sequence[float]) -> str:
    return "(" + ", ".join(f"{v:.2f}" for v in p) + ")"


_NAME_OK = re.compile(r"^[A-Za-z0-9_.\-/ ]+$")


def merge_observations(scene: Scene, new: Scene, *, match_radius: float = 0.6) -> tuple[Scene, list[str], list[str]]:
    """Fold newly mapped world-frame objects into a scene.

    A new object replaces an existing one with the same id from the same capture (the same file
    loaded again; only an object the scene held before this merge and not yet replaced by it), or
    else the nearest existing object of the same label whose centre lies within
    ``match_radius`` [m] (or half the larger object's footprint diagonal, if bigger) — the same thing
    seen again. Ids from different captures say nothing (every capture numbers its objects from 1).
    A view cut by the image border never replaces an uncut view of the same object (a truncated box
    gives a biased position). Objects the operator placed or moved by hand
    (``source.method == "manual"``) are never replaced. Everything else is added; clashing ids get a
    suffix. Returns ``(scene, added_ids, updated_ids)``.
    """
    sizes = {c.id: (c.intrinsics.get("width"), c.intrinsics.get("height")) for c in scene.captures + new.captures}

    def cut(o: SceneObject) -> bool:
        w, h = sizes.get(o.source.capture or "", (None, None))
        b = o.source.bbox
        if b is None or not w or not h:
            return False
        return b[0] <= 2 or b[1] <= 2 or b[2] >= w - 2 or b[3] >= h - 2

    objects = list(scene.objects)
    index = {o.id: n for n, o in enumerate(objects)}
    added: list[str] = []
    updated: list[str] = []
    claimed: set[int] = set()
    for obj in new.objects:
        if obj.frame != "world":
            raise SceneError(f"objects[{obj.id}].frame", f"must be world to spawn, got {obj.frame}")
        target: int | None = index.get(obj.id)
        # the id rule holds only for an object of the scene as it was before this merge: once
        # replaced or added here it carries the new capture's id, and another new object sharing
        # that id is a different thing (ids of a capture are unique)
        if target is not None and (target in claimed or objects[target].source.capture != obj.source.capture):
            target = None
        if target is None:
            best = math.inf
            for n, old in enumerate(objects):
                if n in claimed or old.label != obj.label or old.source.method == "manual":
                    continue
                d = math.dist(old.position, obj.position)  # 3D: stacked boxes share x, y
                reach = max(match_radius, 0.5 * math.hypot(max(old.size[0], obj.size[0]), max(old.size[2], obj.size[2])))
                if d <= reach and d < best:
                    best, target = d, n
        elif objects[target].source.method == "manual":
            target = None
            obj = replace(obj, id=f"{obj.id}-seen")
        if target is not None:
            if not (cut(obj) and not cut(objects[target])):
                objects[target] = replace(obj, id=objects[target].id)
            claimed.add(target)
            updated.append(objects[target].id)
            continue
        new_id, k = obj.id, 1
        while new_id in index:
            k += 1
            new_id = f"{obj.id}-{k}"
        objects.append(replace(obj, id=new_id))
        index[new_id] = len(objects) - 1
        claimed.add(len(objects) - 1)
        added.append(new_id)
    known = {c.id for c in scene.captures}
    captures = scene.captures + tuple(c for c in new.captures if c.id not in known)
    return Scene(objects=tuple(objects), captures=captures), added, updated


# --- the session -------------------------------------------------------------------------------


class Session:
    """All console state, thread-safe, observable, persisted in one folder.

    Args:
        folder: Session folder (created); saves and capture images go there.
        start: Where the robot stands initially (world frame [m]); the route starts there.
        workspace: Planning bounds and resolution.
        margin: Robot radius [m]: cells this close to an obstacle are dangerous.
        weights: Aerial-Ground A* layer costs.
        autosave: Write ``session.json`` after every change.
    """

    def __init__(
        self,
        folder: str | Path,
        start: Sequence[float] = (2.5, 0.7, 0.0),
        workspace: Workspace = Workspace(),
        margin: float = 0.35,
        weights: CostWeights = CostWeights(),
        autosave: bool = True,
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
        self._grid = build_grid(self._scene, workspace, margin)
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
        for topic, payload in events:
            for listener in listeners:
                try:
                    listener(topic, payload)
                except Exception:  # a broken view must not break the session
                    log.exception("listener failed on %s", topic)

    def notify(self, title: str, body: str, level: str = "info") -> None:
        """Show a message to every connected operator (and log it)."""
        getattr(log, "warning" if level in ("warning", "error") else "info")("%s: %s", title, body)
        self._emit([(NOTICE, Notice(title, body, level))])

    # --- read access (snapshots) ---------------------------------------------------------------
    @property
    def workspace(self) -> Workspace:
        return self._workspace

    @property
    def margin(self) -> float:
        return self._margin

    @property
    def weights(self) -> CostWeights:
        return self._weights

    @property
    def scene(self) -> Scene:
        with self._lock:
            return self._scene

    @property
    def grid(self) -> PlanningGrid:
        with self._lock:
            return self._grid

    @property
    def mission(self) -> Mission | None:
        with self._lock:
            return self._mission

    @property
    def capture(self) -> CaptureRecord | None:
        with self._lock:
            return self._capture

    @property
    def robot(self) -> RobotSnapshot | None:
        with self._lock:
            return self._robot

    @property
    def job(self) -> JobStatus:
        with self._lock:
            return self._job

    @property
    def run(self) -> RunStatus:
        with self._lock:
            return self._run

    @property
    def selected(self) -> SceneObject | None:
        with self._lock:
            if self._selected is None:
                return None
            try:
                return self._scene.object(self._selected)
            except KeyError:
                return None

    @property
    def settings(self) -> Settings:
        with self._lock:
            return self._settings

    def route_snapshot(self) -> RouteSnapshot:
        """The route as world points, for drawing."""
        with self._lock:
            r, g = self._route, self._grid
            segs = tuple(path_points(seg, g) for seg in r.registered)
            cand = r.candidate.points(g) if r.candidate is not None else None
            goals = tuple(tuple(float(v) for v in s[-1]) for s in segs if len(s))
            return RouteSnapshot(r.start, segs, cand, r.candidate_goal, goals)  # type: ignore[arg-type]

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
    def goal_from_ray(self, origin: Sequence[float], direction: Sequence[float]) -> Vec3:
        """The goal a click ray picks: its hit with the floor or the chosen altitude (world [m])."""
        z = self.goal_height()
        p = ray_plane(origin, direction, z)
        if p is None:
            raise SessionError(f"the click does not hit the plane z = {z:.2f} m; click on the floor or a grid layer")
        ws = self._workspace
        if not (ws.min[0] <= p[0] <= ws.max[0] and ws.min[1] <= p[1] <= ws.max[1]):
            raise SessionError(f"goal {_fmt(p[:2])} is outside the workspace {_fmt(ws.min[:2])}..{_fmt(ws.max[:2])}")
        return p

    def add_goal(self, goal: Sequence[float]) -> PlanResult:
        """Plan a candidate from the last registered node (or the start) to ``goal`` (world [m]).

        On failure the previous candidate stays and the result's message says why.
        """
        g = tuple(float(v) for v in goal)
        if len(g) != 3 or not all(math.isfinite(v) for v in g):
            return PlanResult(False, f"goal must be 3 finite numbers [m], got {goal!r}")
        with self._lock:
            if self._run.active:
                return PlanResult(False, "a mission is under way (running or paused): abort it, or wait until it is done, before planning")
            res = self._route.propose(g)
            if res.ok:
                self._save_locked()
        if res.ok:
            self._emit([(ROUTE, None)])
        return res

    def register(self) -> str:
        """Append the candidate to the registered (green) path; returns a message."""
        with self._lock:
            if self._route.candidate is None:
                raise SessionError("there is no candidate path to register: click a goal first")
            n = len(self._route.candidate.cells)
            self._route.register()
            self._mission = None
            self._save_locked()
            count = len(self._route.registered)
        self._emit([(ROUTE, None), (MISSION, None)])
        return f"segment {count} registered ({n} cells)"

    def discard(self) -> None:
        """Drop the candidate path."""
        with self._lock:
            self._route.discard()
            self._save_locked()
        self._emit([(ROUTE, None)])

    def undo(self) -> str:
        """Remove the last registered segment."""
        with self._lock:
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
            if self._run.active:
                raise SessionError("a mission is running: abort it before clearing the route")
            self._route.clear()
            self._mission = None
            self._sync_start_locked()
            self._save_locked()
        self._emit([(ROUTE, None), (MISSION, None)])

    def build_mission(self) -> Mission:
        """Turn the registered path into a mission (walk / take-off / fly / land segments)."""
        with self._lock:
            if not self._route.registered:
                raise SessionError("register at least one path segment before building the mission")
            try:
                mission = self._route.mission()
            except MissionError as exc:
                raise SessionError(f"cannot build the mission: {exc}") from None
            self._mission = mission
            self._save_locked()
        self._emit([(MISSION, None)])
        return mission

    # --- scene -----------------------------------------------------------------------------------
    def spawn(self, scene: Scene, origin: str = "") -> SpawnReport:
        """Add world-frame objects (re-sightings update the known object), rebuild the grid, replan."""
        with self._lock:
            merged, added, updated = merge_observations(self._scene, scene)
            notes = self._set_scene_locked(merged)
        what = f" from {origin}" if origin else ""
        log.info("spawned %d new and %d updated objects%s", len(added), len(updated), what)
        self._emit([(SCENE, None), (GRID, None), (ROUTE, None), (MISSION, None)])
        return SpawnReport(tuple(added), tuple(updated), tuple(notes))

    def delete_object(self, object_id: str) -> list[str]:
        """Remove an object from the map; the grid is rebuilt and the route re-checked."""
        with self._lock:
            try:
                self._scene.object(object_id)
            except KeyError:
                raise SessionError(f"no object {object_id!r} in the map (was it deleted in another tab?)") from None
            scene = self._scene.with_objects([o for o in self._scene.objects if o.id != object_id])
            if self._selected == object_id:
                self._selected = None
            notes = self._set_scene_locked(scene)
        self._emit([(SCENE, None), (GRID, None), (ROUTE, None), (MISSION, None), (SELECTION, None)])
        return notes

    def move_object(self, object_id: str, position: Sequence[float], yaw: float | None = None) -> list[str]:
        """Put an object at ``position`` (box centre, world [m]) and heading ``yaw`` [rad]."""
        p = tuple(float(v) for v in position)
        if len(p) != 3 or not all(math.isfinite(v) for v in p):
            raise SessionError(f"position must be 3 finite numbers [m], got {position!r}")
        if yaw is not None and not math.isfinite(yaw):
            raise SessionError(f"yaw must be a finite number [rad], got {yaw!r}")
        ws = self._workspace
        if not all(ws.min[a] - 1.0 <= p[a] <= ws.max[a] + 1.0 for a in range(3)):
            raise SessionError(f"position {_fmt(p)} is far outside the workspace {_fmt(ws.min)}..{_fmt(ws.max)}")
        with self._lock:
            try:
                obj = self._scene.object(object_id)
            except KeyError:
                raise SessionError(f"no object {object_id!r} in the map (was it deleted in another tab?)") from None
            objs = [obj.moved(p, yaw) if o.id == object_id else o for o in self._scene.objects]  # type: ignore[arg-type]
            notes = self._set_scene_locked(self._scene.with_objects(objs))
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

    def _set_scene_locked(self, scene: Scene) -> list[str]:
        try:
            grid = build_grid(scene, self._workspace, self._margin)
        except GridError as exc:
            raise SessionError(f"cannot build the planning grid: {exc}") from None
        self._scene = scene
        self._grid = grid
        notes = self._route.set_grid(grid)
        self._mission = None
        if self._selected is not None and self._selected not in {o.id for o in scene.objects}:
            self._selected = None
        self._save_locked()
        return notes

    # --- capture, robot, jobs ------------------------------------------------------------------
    def set_capture(self, record: CaptureRecord) -> None:
        """Show a new capture (photo, detections, depth, camera pose); saved with the session."""
        with self._lock:
            self._capture = record
            self._capture_meta = self._write_capture_files(record)
            self._save_locked()
        self._emit([(CAPTURE, record)])

    def set_robot(self, state: RobotSnapshot) -> None:
        """Record the robot's live state; an idle route start follows the robot on the ground."""
        with self._lock:
            self._robot = state
            moved = self._sync_start_locked()
            if moved:
                self._save_locked()
        events: list[tuple[str, Any]] = [(ROBOT, state)]
        if moved:
            events.append((ROUTE, None))
        self._emit(events)

    def set_job(self, status: JobStatus) -> None:
        with self._lock:
            self._job = status
        self._emit([(JOB, status)])

    def set_run(self, status: RunStatus) -> None:
        with self._lock:
            self._run = status
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
        """Move the route start under the robot when nothing is registered; True if moved."""
        r = self._robot
        if r is None or self._route.registered or self._run.active:
            return False
        x, y, z = r.pose.translation
        ws = self._workspace
        if z - ws.floor > ws.resolution or not ws.contains((x, y, ws.floor)):
            return False  # in the air or outside: keep the last start
        s = self._route.start
        if math.dist((x, y), s[:2]) < ws.resolution / 2:
            return False
        goal = self._route.candidate_goal
        self._route.set_start((x, y, ws.floor))
        if goal is not None:
            self._route.propose(goal)
        return True

    def _floor_point(self, p: Sequence[float]) -> Vec3:
        return (float(p[0]), float(p[1]), self._workspace.floor)

    # --- persistence -----------------------------------------------------------------------------
    def resolve_name(self, name: str) -> Path:
        """The session-folder file a typed name refers to (``.json`` added if missing).

        Raises :class:`SessionError` for empty names, absolute paths, odd characters, and any name
        that resolves (through ``..`` or symbolic links) outside the session folder.
        """
        text = (name or "").strip()
        if not text:
            raise SessionError("type a file name (it is saved in the session folder)")
        if len(text) > 120:
            raise SessionError("file name too long (120 characters at most)")
        if text.startswith(("/", "~")) or re.match(r"^[A-Za-z]:", text) or "\\" in text:
            raise SessionError(f"{text!r}: give a name inside the session folder, not an absolute path")
        if not _NAME_OK.match(text):
            raise SessionError(f"{text!r}: use letters, digits, spaces, '_', '-', '.' and '/' only")
        if any(part in ("..", ".") for part in Path(text).parts) or text in (".", ".."):
            raise SessionError(f"{text!r}: '..' and '.' are not allowed; names stay inside the session folder")
        if any(part.startswith(".") for part in Path(text).parts):
            raise SessionError(f"{text!r}: names may not start with '.'")
        if not text.endswith(".json"):
            text += ".json"
        target = (self.folder / text).resolve()
        if not target.is_relative_to(self.folder) or target == self.folder:
            raise SessionError(f"{name!r} resolves outside the session folder {self.folder}")
        return target

    def list_saves(self) -> list[str]:
        """Names of the session files in the session folder (newest first)."""
        files = [p for p in self.folder.glob("*.json") if not p.name.startswith(".")]
        files.sort(key=lambda p: p.stat().st_mtime, reverse=True)
        return [p.name for p in files]

    def to_dict(self) -> dict[str, Any]:
        """The whole persistent state as a JSON-ready dict."""
        with self._lock:
            ws = self._workspace
            return {
                "version": SESSION_VERSION,
                "kind": "morphonavi-session",
                "saved": time.time(),
                "frame": "world",
                "workspace": {"min": list(ws.min), "max": list(ws.max), "resolution": ws.resolution},
                "margin": self._margin,
                "scene": scene_to_dict(self._scene),
                "route": self._route.to_dict(),
                "mission": None if self._mission is None else self._mission.to_dict(),
                "settings": {"goal_mode": self._settings.goal_mode, "altitude": self._settings.altitude},
                "last_capture": self._capture_meta,
            }

    def save(self, name: str | None = None) -> Path:
        """Write the session to ``session.json`` or to the typed ``name`` in the session folder."""
        path = self.folder / SESSION_FILE if name is None else self.resolve_name(name)
        with self._lock:
            data = self.to_dict()
        try:
            write_text_atomic(path, json.dumps(data, indent=1) + "\n")
        except OSError as exc:
            raise SessionError(f"cannot write {path.name}: {exc}") from None
        return path

    def _save_locked(self) -> None:
        if not self._autosave:
            return
        try:
            write_text_atomic(self.folder / SESSION_FILE, json.dumps(self.to_dict(), indent=1) + "\n")
            self._last_save_error = None
        except (OSError, TypeError, ValueError) as exc:  # keep working; tell the operator once
            if self._last_save_error != str(exc):
                self._last_save_error = str(exc)
                log.error("autosave to %s failed: %s", self.folder / SESSION_FILE, exc)

    def load(self, name: str | None = None) -> list[str]:
        """Replace the state with a saved session; returns notes about what could not be kept.

        Raises :class:`SessionError` naming the bad field of a malformed file; the current state
        is then left untouched.
        """
        path = self.folder / SESSION_FILE if name is None else self.resolve_name(name)
        if self.run.active:
            raise SessionError("a mission is under way: abort it before loading another session")
        try:
            data = json.loads(path.read_text(encoding="utf-8"))
        except FileNotFoundError:
            raise SessionError(f"no saved session {path.name!r} in {self.folder}") from None
        except (OSError, UnicodeDecodeError) as exc:
            raise SessionError(f"cannot read {path.name}: {exc}") from None
        except json.JSONDecodeError as exc:
            raise SessionError(f"{path.name} is not valid JSON (line {exc.lineno}): {exc.msg}") from None
        notes = self._apply_saved(data, path.name)
        self._emit([(SCENE, None), (GRID, None), (ROUTE, None), (MISSION, None), (SETTINGS, None),
                    (SELECTION, None)] + ([(CAPTURE, self.capture)] if self.capture is not None else []))
        return notes

    def restore_last(self) -> list[str] | None:
        """Restore ``session.json`` if there is one; ``None`` if there is nothing to restore."""
        if not (self.folder / SESSION_FILE).exists():
            return None
        return self.load(None)

    def _apply_saved(self, data: Any, where: str) -> list[str]:
        if not isinstance(data, dict) or data.get("kind") != "morphonavi-session":
            raise SessionError(f"{where} is not a MorphoNavi session file")
        if data.get("version") != SESSION_VERSION:
            raise SessionError(f"{where}: version {data.get('version')!r} is not supported (expected {SESSION_VERSION})")
        try:
            scene = scene_from_dict(data.get("scene") or {"version": 1})
        except SceneError as exc:
            raise SessionError(f"{where}: scene.{exc}") from None
        for o in scene.objects:
            if o.frame != "world":
                raise SessionError(f"{where}: scene object {o.id!r} is in the {o.frame} frame, expected world")
        mission: Mission | None = None
        if data.get("mission") is not None:
            try:
                mission = Mission.from_dict(data["mission"])
            except MissionError as exc:
                raise SessionError(f"{where}: mission.{exc}") from None
        settings = data.get("settings") or {}
        mode = settings.get("goal_mode", "ground")
        alt = settings.get("altitude", 1.5)
        if mode not in ("ground", "altitude") or isinstance(alt, bool) or not isinstance(alt, (int, float)):
            raise SessionError(f"{where}: settings must hold goal_mode 'ground'/'altitude' and a numeric altitude")
        route_data = data.get("route")
        notes: list[str] = []
        ws_saved = data.get("workspace") or {}
        ws = self._workspace
        same_ws = (ws_saved.get("min") == list(ws.min) and ws_saved.get("max") == list(ws.max)
                   and ws_saved.get("resolution") == ws.resolution)
        with self._lock:
            old = (self._scene, self._grid, self._route, self._mission)
            try:
                grid = build_grid(scene, ws, self._margin)
                route = Route(grid, self._route.start, self._weights)
                if isinstance(route_data, dict) and same_ws:
                    notes += route.restore(route_data)
                elif route_data:
                    notes.append("the saved route was planned on a different workspace grid and was dropped")
                    mission = None
            except (KeyError, TypeError, ValueError, IndexError) as exc:
                self._scene, self._grid, self._route, self._mission = old
                raise SessionError(f"{where}: route is malformed: {exc}") from None
            self._scene, self._grid, self._route, self._mission = scene, grid, route, mission
            self._selected = None
            self._settings = replace(self._settings, goal_mode=mode, altitude=float(alt))
            cap_meta = data.get("last_capture")
            self._capture, self._capture_meta = None, None
            if isinstance(cap_meta, dict):
                try:
                    self._capture = self._read_capture_files(cap_meta)
                    self._capture_meta = cap_meta
                except (KeyError, TypeError, ValueError, OSError) as exc:
                    notes.append(f"the last capture could not be restored: {exc}")
            self._save_locked()
        return notes

    # --- capture files ---------------------------------------------------------------------------
    def _write_capture_files(self, rec: CaptureRecord) -> dict[str, Any] | None:
        import cv2

        safe_id = re.sub(r"[^A-Za-z0-9_\-]", "_", rec.id)[:64] or "capture"
        folder = self.folder / CAPTURE_DIR
        try:
            folder.mkdir(parents=True, exist_ok=True)
            photo = f"{CAPTURE_DIR}/{safe_id}.jpg"
            cv2.imwrite(str(self.folder / photo), cv2.cvtColor(rec.image, cv2.COLOR_RGB2BGR))
            depth_name = None
            if rec.depth is not None:
                depth_name = f"{CAPTURE_DIR}/{safe_id}_depth_mm.png"
                mm = np.clip(np.nan_to_num(rec.depth, nan=0.0, posinf=0.0) * 1000.0, 0, 65535).astype(np.uint16)
                cv2.imwrite(str(self.folder / depth_name), mm)
        except OSError as exc:
            log.error("cannot store capture %s: %s", rec.id, exc)
            return None
        t, q = rec.camera_pose.translation, rec.camera_pose.quaternion
        rt, rq = rec.robot_pose.translation, rec.robot_pose.quaternion
        return {
            "id": rec.id,
            "photo": photo,
            "depth_mm": depth_name,
            "intrinsics": rec.intrinsics.to_dict(),
            "camera_pose": {"translation": list(t), "quaternion_xyzw": list(q)},
            "robot_pose": {"translation": list(rt), "quaternion_xyzw": list(rq)},
            "detections": [{"label": d.label, "score": d.score, "bbox": list(d.bbox), "object_id": d.object_id}
                           for d in rec.detections],
            "backend": rec.backend,
            "timings": dict(rec.timings),
            "timestamp": rec.timestamp,
        }

    def _read_capture_files(self, meta: Mapping[str, Any]) -> CaptureRecord:
        import cv2

        def inside(rel: Any) -> Path:
            p = (self.folder / str(rel)).resolve()
            if not p.is_relative_to(self.folder):
                raise ValueError(f"{rel!r} lies outside the session folder")
            return p

        img = cv2.imread(str(inside(meta["photo"])), cv2.IMREAD_COLOR)
        if img is None:
            raise ValueError(f"photo {meta['photo']} is missing or unreadable")
        depth = None
        if meta.get("depth_mm"):
            d = cv2.imread(str(inside(meta["depth_mm"])), cv2.IMREAD_UNCHANGED)
            if d is not None:
                depth = d.astype(np.float32) / 1000.0
                depth[d == 0] = np.nan
        i = meta["intrinsics"]
        intr = Intrinsics(float(i["fx"]), float(i["fy"]), float(i["cx"]), float(i["cy"]),
                          int(i["width"]), int(i["height"]))
        cp, rp = meta["camera_pose"], meta["robot_pose"]
        dets = tuple(Detection(str(d["label"]), float(d["score"]), tuple(float(v) for v in d["bbox"]),  # type: ignore[arg-type]
                               d.get("object_id")) for d in meta.get("detections", []))
        return CaptureRecord(
            id=str(meta["id"]),
            image=cv2.cvtColor(img, cv2.COLOR_BGR2RGB),
            intrinsics=intr,
            camera_pose=Pose(tuple(cp["translation"]), tuple(cp["quaternion_xyzw"])),  # type: ignore[arg-type]
            robot_pose=Pose(tuple(rp["translation"]), tuple(rp["quaternion_xyzw"])),  # type: ignore[arg-type]
            detections=dets,
            depth=depth,
            backend=str(meta.get("backend", "")),
            timings={str(k): float(v) for k, v in (meta.get("timings") or {}).items()},
            timestamp=float(meta.get("timestamp", 0.0)),
        )
