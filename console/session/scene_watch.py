"""The watched scene folder: scene JSON files dropped in are spawned without a restart.

This is the paper's Unity *StreamingAssets* behaviour. The folder is polled (no inotify needed);
each ``*.json`` file is read once per modification (its ``mtime`` and size), after it has been
still for ``settle`` seconds so a file being written is not read half-way. A malformed file is
reported once (naming the bad field) and ignored until it changes again.

Limits: a file larger than ``max_bytes`` is refused from its size alone (it is never read), and
one with more than ``max_objects`` objects is refused before its objects are checked; both are
reported like a malformed file. Reading and checking run on the watcher's thread, before
``on_scene`` is called, so they never hold the session's lock; the session then refuses
implausible objects (:meth:`console.session.session.Session.spawn`).

Every file is treated by its kind (:mod:`pipeline.file_kind`): a console session, a mission, a
scene graph, a camera file, a recording or a photo dropped in is reported once as what it is and
which command reads it, never read as a scene. A symbolic link that leads nowhere, or a loop of
links, is reported once too. A file is known by its name and its identity (inode, modification
time, size), so a file rewritten in place or replaced by a rename is read again;
``on_scene``'s receiver decides what a re-read replaces (the console drops the objects the file's
previous version added, :meth:`console.app.ConsoleApp._spawn_file`). Positions and poses are
range-checked like a command-line pose (:func:`pipeline.file_kind.check_scene_ranges`), and a
zero camera quaternion is named by its field.

:meth:`SceneWatcher.stop` ends the polling between files; at interpreter exit (SIGTERM, Ctrl-C) the
pass under way is waited for (up to :data:`EXIT_WAIT_S`) instead of the thread being killed inside a
library call.

Objects may be given in the ``world``, ``robot`` or ``camera`` frame (see :mod:`pipeline.scene`);
robot- and camera-frame objects are moved into the world frame with the pose of the capture they
name (``source.capture``), else with the robot's current pose.
"""

from __future__ import annotations

import atexit
import logging
import math
import os
import threading
import time
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Callable

import numpy as np

from pipeline.camera.geometry import CameraMount, Pose, camera_pose_in_world
from pipeline.file_kind import KINDS, check_scene_ranges, kind_of_json, sniff, wrong_kind
from pipeline.scene import Capture, Scene, SceneError, SceneObject, scene_from_dict
from pipeline.scene_json import parse_json_text

MAX_FILE_BYTES = 5_000_000
"""Largest scene file read from the watched folder [bytes] (a room's scene is a few kB)."""

MAX_FILE_OBJECTS = 2_000
"""Most objects one watched scene file may hold."""

EXIT_WAIT_S = 60.0
"""Longest wait at interpreter exit for the file being handled [s]."""

log = logging.getLogger(__name__)


class FrameError(ValueError):
    """An object cannot be moved into the world frame (no pose to do it with)."""


class NotReady(Exception):
    """Raised by ``on_scene`` when a file cannot be handled yet (e.g. no robot pose so far):
    the file is read again on the next pass instead of being reported."""


def _heading_vector(frame: str, yaw: float) -> np.ndarray:
    """Unit vector of an object's length axis in its own frame, for a heading ``yaw`` [rad]."""
    c, s = math.cos(yaw), math.sin(yaw)
    if frame == "camera":  # vertical axis is -y; yaw turns x towards z (forward)
        return np.array([c, 0.0, s])
    return np.array([c, s, 0.0])  # robot and world: z up


def _capture_poses(cap: Capture, mount: CameraMount) -> tuple[Pose | None, Pose | None]:
    """``world <- robot`` and ``world <- camera`` recorded in a capture, where present."""
    robot = None
    rp = cap.robot_pose
    if "x" in rp and "y" in rp:
        robot = Pose.from_xyz_yaw(rp["x"], rp["y"], rp.get("z", 0.0), rp.get("yaw", 0.0))
    camera = None
    if cap.camera_position is not None and cap.camera_quaternion is not None:
        camera = Pose(cap.camera_position, cap.camera_quaternion)
    elif robot is not None:
        camera = camera_pose_in_world(robot, mount)
    return robot, camera


def objects_to_world(
    scene: Scene,
    robot_pose: Pose | None = None,
    mount: CameraMount = CameraMount(),
) -> Scene:
    """The scene with every object in the world frame.

    Args:
        scene: Objects in any frame.
        robot_pose: ``world <- robot`` to use for objects whose capture records no pose.
        mount: Camera on the robot, for camera-frame objects without a recorded camera pose.

    Raises:
        FrameError: An object needs a pose that neither its capture nor ``robot_pose`` gives.
    """
    captures = {c.id: c for c in scene.captures}
    out: list[SceneObject] = []
    for obj in scene.objects:
        if obj.frame == "world":
            out.append(obj)
            continue
        robot, camera = (None, None)
        cap = captures.get(obj.source.capture or "")
        if cap is not None:
            robot, camera = _capture_poses(cap, mount)
        if robot is None and robot_pose is not None:
            robot = robot_pose
        if camera is None and robot is not None:
            camera = camera_pose_in_world(robot, mount)
        pose = robot if obj.frame == "robot" else camera
        if pose is None:
            raise FrameError(
                f"object {obj.id!r} is in the {obj.frame} frame but its capture records no pose "
                "and the robot's pose is unknown"
            )
        centre = pose.apply(obj.position)
        heading = pose.rotation.apply(_heading_vector(obj.frame, obj.yaw))
        yaw = math.atan2(heading[1], heading[0]) if math.hypot(heading[0], heading[1]) > 1e-9 else 0.0
        positions = dict(obj.source.positions)
        positions[obj.frame] = obj.position
        positions["world"] = (float(centre[0]), float(centre[1]), float(centre[2]))
        out.append(replace(
            obj,
            position=(float(centre[0]), float(centre[1]), float(centre[2])),
            yaw=yaw,
            frame="world",
            source=replace(obj.source, positions=positions),
        ))
    return scene.with_objects(out)


@dataclass(frozen=True)
class _Seen:
    mtime_ns: int
    size: int
    inode: int = 0


OTHER_KINDS = ("recording", "camera_toml", "catalog", "photo")
"""Kinds of non-JSON files the watched folder names when dropped in (anything else is left alone)."""


class SceneWatcher:
    """Polls ``folder`` and hands each new or changed scene file to ``on_scene`` once.

    Args:
        folder: The watched folder (created if missing).
        on_scene: Called with ``(scene, file name)`` for each good file, objects in any frame;
            it may raise :class:`NotReady` to have the file read again on the next pass.
        on_error: Called with ``(file name, message)`` for each malformed file.
        interval: Seconds between polls.
        settle: A file must be unmodified this long [s] before it is read.
        spawn_existing: Whether files already there when watching starts are spawned too.
        max_bytes: Larger files are refused unread [bytes].
        max_objects: Files with more objects are refused.
    """

    def __init__(
        self,
        folder: str | Path,
        on_scene: Callable[[Scene, str], None],
        on_error: Callable[[str, str], None],
        interval: float = 1.0,
        settle: float = 0.3,
        spawn_existing: bool = True,
        max_bytes: int = MAX_FILE_BYTES,
        max_objects: int = MAX_FILE_OBJECTS,
    ) -> None:
        self.folder = Path(folder).expanduser().resolve()
        self.folder.mkdir(parents=True, exist_ok=True)
        self._on_scene = on_scene
        self._on_error = on_error
        self._interval = interval
        self._settle = settle
        self._max_bytes = max_bytes
        self._max_objects = max_objects
        self._seen: dict[str, _Seen] = {}
        self._told: dict[str, str] = {}  # name -> the notice already given for it (links, other kinds)
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        if not spawn_existing:
            for path, sig in self._listing().items():
                self._seen[path.name] = sig

    def _listing(self) -> dict[Path, _Seen]:
        out: dict[Path, _Seen] = {}
        try:
            entries = list(self.folder.iterdir())
        except OSError as exc:
            log.error("cannot list the watched scene folder %s: %s", self.folder, exc)
            return out
        for p in entries:
            if p.name.startswith("."):
                continue
            try:
                st = p.stat()
            except OSError as exc:
                self._tell(p.name, self._broken_link(p, exc))
                continue
            if not p.is_file():
                continue
            if p.suffix.lower() != ".json":
                self._other_file(p, st)
                continue
            self._told.pop(p.name, None)
            out[p] = _Seen(st.st_mtime_ns, st.st_size, st.st_ino)
        return out

    def _tell(self, name: str, message: str) -> None:
        """Report ``message`` about ``name`` once (again only when it changes)."""
        if message and self._told.get(name) != message:
            self._told[name] = message
            self._on_error(name, message)

    @staticmethod
    def _broken_link(p: Path, exc: OSError) -> str:
        import errno

        if not p.is_symlink():
            return ""
        try:
            target = str(p.readlink())
        except OSError:
            target = "?"
        if exc.errno == errno.ELOOP:
            return f"a loop of symbolic links (it points at {target}, which leads back to it): not read"
        return f"a symbolic link to {target}, which does not exist: not read"

    def _other_file(self, p: Path, st: os.stat_result) -> None:
        """A non-JSON file: named once when it is a kind MorphoNavi knows (a camera file, a recording ...)."""
        key = f"{p.name}:{st.st_mtime_ns}:{st.st_size}"
        if self._told.get(f"\0{p.name}") == key:
            return
        self._told[f"\0{p.name}"] = key
        kind = sniff(p)
        if kind in OTHER_KINDS:
            self._tell(p.name, f"{wrong_kind('', p.name, kind, 'scene')}; the watched folder reads scene "
                               "JSON files only: not read")

    def poll(self) -> list[str]:
        """One pass over the folder; returns the names read in this pass (good or bad)."""
        done: list[str] = []
        now = time.time_ns()
        for path, sig in sorted(self._listing().items()):
            if self._stop.is_set():
                break
            if self._seen.get(path.name) == sig:
                continue
            if (now - sig.mtime_ns) / 1e9 < self._settle:
                continue  # still being written; next pass
            self._seen[path.name] = sig
            done.append(path.name)
            try:
                scene = self._read(path, sig.size)
            except SceneError as exc:
                self._on_error(path.name, str(exc))
                continue
            try:
                self._on_scene(scene, path.name)
            except NotReady:
                del self._seen[path.name]
                done.pop()
            except (SceneError, FrameError, ValueError) as exc:
                self._on_error(path.name, str(exc))
        return done

    def _read(self, path: Path, size: int) -> Scene:
        """Read and check one file within the limits; raises :class:`SceneError` saying why not."""
        if size > self._max_bytes:
            raise SceneError("", f"{size / 1e6:.1f} MB is over the {self._max_bytes / 1e6:g} MB limit for a "
                                 "scene file: not read")
        try:
            text = path.read_text(encoding="utf-8")
        except (OSError, UnicodeDecodeError) as exc:
            raise SceneError("", f"cannot read the file: {exc}") from None
        if len(text.encode("utf-8")) > self._max_bytes:  # grew since it was listed
            raise SceneError("", f"over the {self._max_bytes / 1e6:g} MB limit for a scene file: not read")
        data = parse_json_text(text)
        kind = kind_of_json(data)
        if kind not in ("scene", "json"):
            raise SceneError("", f"{wrong_kind('', path.name, kind, 'scene')}; nothing was added")
        if kind == "json":
            keys = ", ".join(list(data)[:6]) if isinstance(data, dict) else type(data).__name__
            raise SceneError("", f"not {KINDS['scene'].what}: JSON of no MorphoNavi kind ({keys}); a scene file "
                                 "has \"version\" and \"objects\": nothing was added")
        objs = data.get("objects") if isinstance(data, dict) else None
        if isinstance(objs, list) and len(objs) > self._max_objects:
            raise SceneError("objects", f"{len(objs)} objects is over the limit of {self._max_objects} "
                                        "for one scene file: nothing was added")
        scene = scene_from_dict(data)
        check_scene_ranges(scene)
        return scene

    def start(self) -> None:
        """Poll in a daemon thread until :meth:`stop`."""
        if self._thread is not None:
            return

        def loop() -> None:
            while not self._stop.is_set():
                try:
                    self.poll()
                except Exception:  # never let the watcher die silently
                    log.exception("scene folder poll failed")
                self._stop.wait(self._interval)

        self._thread = threading.Thread(target=loop, name="scene-watch", daemon=True)
        self._thread.start()
        # at exit, end the pass under way before the interpreter stops daemon threads: stopped inside a
        # library call, the thread aborted the process ("FATAL: exception not rethrown", SIGTERM during a drop)
        atexit.register(self._stop_at_exit)

    def _stop_at_exit(self) -> None:
        self._stop.set()
        thread = self._thread
        if thread is not None:
            thread.join(timeout=EXIT_WAIT_S)

    def stop(self) -> None:
        """Stop polling (between files) and wait up to 2 s for the thread."""
        atexit.unregister(self._stop_at_exit)
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=2.0)
            self._thread = None
