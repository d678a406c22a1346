"""Session files: the ``session.json`` format, writing it (reading and checking it:
:mod:`console.session.session_parse`), safe file names, and :class:`Persistence`, the save / load / restore
half of :class:`~console.session.session.Session`.

A session file holds the scene, route, mission, settings and the last capture's metadata, all in the
world frame [m]. Names typed by the operator are resolved with :func:`resolve_name`, which refuses
anything that would land outside the session folder.

Restore rules: a file that is not a session, or whose scene is malformed or implausible, is refused
as a whole (naming the field). Otherwise each other part (route, mission, settings, last capture)
is checked like the scene (every number finite, the field named) and a bad part is dropped while
the valid parts are restored; the reasons are kept in :attr:`Persistence.restore_problems` for the
page, and ``session.json`` itself is first copied aside as ``session.json.unreadable-<time>``. A
file that cannot be restored at all is moved aside the same way; if it cannot be (a read-only
folder) :class:`SessionError` says what to do (``--fresh`` or another ``--session``).
"""

from __future__ import annotations

import json
import logging
import re
import time
from dataclasses import replace
from pathlib import Path
from typing import Any

from pipeline.scene import Scene, check_plausible, scene_to_dict, write_text_atomic
from planner.grid import Workspace
from planner.mission import Mission
from planner.route import Route

from console.session.capture_files import (
    CAPTURE_DIR, highest_capture_number, numbered_capture_id, read_capture_files, write_capture_files,
)
from console.session.file_aside import put_aside
from console.session.history_file import HISTORY_FILE, HistoryWriter, read_history_file
from console.session.session_core import SessionCore
from console.session.session_parse import SESSION_VERSION, SavedSession, parse_saved
from console.session.session_types import CaptureRecord, Notice, SessionError, Settings
from console.session.topics import CAPTURE, GRID, MISSION, ROUTE, SCENE, SELECTION, SETTINGS


log = logging.getLogger(__name__)

SESSION_FILE = "session.json"

_NAME_OK = re.compile(r"^[A-Za-z0-9_.\-/ ]+$")


def resolve_name(folder: Path, name: str) -> Path:
    """The file in the session ``folder`` a typed name refers to (``.json`` added if missing).

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
    target = (folder / text).resolve()
    if not target.is_relative_to(folder) or target == folder:
        raise SessionError(f"{name!r} resolves outside the session folder {folder}")
    return target


class ConfirmNeeded(SessionError):
    """An action that asks first: call again with the confirming flag once the operator agreed.

    Attributes:
        question: What to ask (``Overwrite 'before-flight'?``).
        detail: What confirming does, in a sentence.
        confirm: The label of the confirming button (``Save over it``).
    """

    def __init__(self, question: str, detail: str, confirm: str) -> None:
        super().__init__(f"{question} {detail}")
        self.question, self.detail, self.confirm = question, detail, confirm


def list_saves(folder: Path) -> list[str]:
    """Names of the session files in ``folder`` (newest first; not the undo history)."""
    files = [p for p in folder.glob("*.json") if not p.name.startswith(".") and p.name != HISTORY_FILE]
    files.sort(key=lambda p: p.stat().st_mtime, reverse=True)
    return [p.name for p in files]


def session_to_dict(
    workspace: Workspace,
    margin: float,
    scene: Scene,
    route: Route,
    mission: Mission | None,
    settings: Settings,
    last_capture: dict[str, Any] | None,
) -> dict[str, Any]:
    """The persistent session state as a JSON-ready dict (the ``session.json`` format)."""
    ws = workspace
    return {
        "version": SESSION_VERSION,
        "kind": "morphonavi-session",
        "saved": time.time(),
        "frame": "world",
        "workspace": {"min": list(ws.min), "max": list(ws.max), "resolution": ws.resolution},
        "margin": margin,
        "scene": scene_to_dict(scene),
        "route": route.to_dict(),
        "mission": None if mission is None else mission.to_dict(),
        "settings": {"goal_mode": settings.goal_mode, "altitude": settings.altitude},
        "last_capture": last_capture,
    }


def _when(path: Path) -> str:
    """When ``path`` was last written, local time (``2026-12-02 03:40``), or ``earlier`` if unknown."""
    try:
        return time.strftime("%Y-%m-%d %H:%M", time.localtime(path.stat().st_mtime))
    except OSError:
        return "earlier"


def write_session_file(path: Path, data: dict[str, Any]) -> None:
    """Write a session dict to ``path`` atomically; raises ``OSError``, ``TypeError`` or ``ValueError``."""
    write_text_atomic(path, json.dumps(data, indent=1, allow_nan=False) + "\n")  # never write a NaN


def read_session_file(path: Path, folder: Path) -> Any:
    """The parsed JSON of the session file ``path`` in ``folder``; :class:`SessionError` if unreadable.

    Its size is checked before it is read (:data:`pipeline.file_kind.MAX_BYTES` ``["session"]``, 50 MB:
    a session holding a 10 000-object map is about 10 MB), so a huge file is refused at once, with the number.
    """
    from pipeline.file_kind import MAX_BYTES, MB, kind_of_json, wrong_kind

    limit = MAX_BYTES["session"]
    try:
        size = path.stat().st_size
        if size > limit:
            raise SessionError(f"{path.name} is {size / MB:.1f} MB, over the {limit / MB:g} MB limit for a session "
                               "file: not read (a session with a 10 000-object map is about 10 MB)")
        with open(path, "rb") as f:
            raw = f.read(limit + 1)
        if len(raw) > limit:
            raise SessionError(f"{path.name} grew over the {limit / MB:g} MB limit for a session file: not read")
        data = json.loads(raw.decode("utf-8"))
        kind = kind_of_json(data)
        if kind not in ("session", "json"):  # a scene or mission saved under the session's name
            raise SessionError(wrong_kind("", path.name, kind, "session"))
        return data
    except FileNotFoundError:
        raise SessionError(f"no saved session {path.name!r} in {folder}") from None
    except IsADirectoryError:
        raise SessionError(f"{path.name} in {folder} is a folder, not a session file") from None
    except UnicodeDecodeError:
        raise SessionError(f"{path.name} is not a session file: not UTF-8 text") from None
    except OSError as exc:
        raise SessionError(f"cannot read {path.name}: {(exc.strerror or type(exc).__name__).lower()}") from None
    except json.JSONDecodeError as exc:
        raise SessionError(f"{path.name} is not valid JSON (line {exc.lineno}): {exc.msg}") from None


def keep_aside(path: Path, reason: str, move: bool) -> Path:
    """Move (or copy) a bad session file to ``<name>.unreadable-<time>`` beside it
    (:func:`console.session.file_aside.put_aside`); returns the new path.

    Raises :class:`SessionError` saying what to do when the folder does not allow it.
    """
    try:
        return put_aside(path, move)
    except OSError as exc:
        raise SessionError(
            f"the session in {path.parent} is corrupt ({reason}) and cannot be kept aside "
            f"({exc.strerror or exc}): start with --fresh to begin with an empty map (the file is left "
            f"as it is and nothing is saved over it while the folder stays read-only), or with "
            f"--session DIR to use another folder") from None


class Persistence(SessionCore):
    """The save / load / restore half of :class:`~console.session.session.Session` (mixed into it).

    Uses the session's lock and state; every restored value is checked by :func:`parse_saved` and
    the scene by :func:`pipeline.scene.check_plausible` for the session's workspace.
    """

    # --- names, listing, writing ---------------------------------------------------------------
    def resolve_name(self, name: str) -> Path:
        """The session-folder file a typed name refers to (``.json`` added if missing).

        Raises :class:`SessionError` for empty names, absolute paths, odd characters, and any name
        that resolves (through ``..`` or symbolic links) outside the session folder.
        """
        return resolve_name(self.folder, name)

    def list_saves(self) -> list[str]:
        """Names of the session files in the session folder (newest first)."""
        return list_saves(self.folder)

    def to_dict(self) -> dict[str, Any]:
        """The whole persistent state as a JSON-ready dict."""
        with self._lock:
            data = session_to_dict(self._workspace, self._margin, self._scene, self._route,
                                   self._mission, self._settings, self._capture_meta)
            data.update(self._known_json_locked())  # type: ignore[attr-defined]  # KnownSpaceSession
            return data

    def save(self, name: str | None = None, overwrite: bool = False) -> Path:
        """Write the session to ``session.json`` or to the typed ``name`` in the session folder.

        A named snapshot that exists already is kept unless ``overwrite``: :class:`ConfirmNeeded`
        asks first (``Overwrite 'before-flight'?``)."""
        path = self.folder / SESSION_FILE if name is None else self._snapshot_path(name)
        if name is not None and path.exists() and not overwrite:
            raise ConfirmNeeded(f"Overwrite '{path.stem}'?",
                                f"A snapshot of that name was saved {_when(path)}; saving over it replaces it.",
                                "Save over it")
        with self._lock:
            data = self.to_dict()
        try:
            write_session_file(path, data)
        except (OSError, ValueError) as exc:
            from pipeline.file_kind import os_error_words

            raise SessionError(f"cannot write {path.name}: "
                               f"{os_error_words(exc, path) if isinstance(exc, OSError) else exc}") from None
        return path

    def delete_save(self, name: str, confirmed: bool = False) -> str:
        """Delete the named snapshot ``name`` from the session folder; returns its file name.

        Asks first: without ``confirmed`` it raises :class:`ConfirmNeeded` (``Delete 'before-flight'?``).
        Refuses the session's own ``session.json``, the undo history and files that are not sessions."""
        path = self._snapshot_path(name)
        if path.name == SESSION_FILE and path.parent == self.folder:
            raise SessionError(f"{SESSION_FILE} is the session itself (saved after every change): it is not deleted here")
        read_session_file(path, self.folder)  # missing, a folder, not JSON or not a session: refused, named
        if not confirmed:
            raise ConfirmNeeded(f"Delete '{path.stem}'?",
                                f"The snapshot saved {_when(path)} is removed from the session folder; "
                                "this cannot be undone.", "Delete")
        try:
            path.unlink()
        except FileNotFoundError:
            raise SessionError(f"no saved session {path.name!r} in {self.folder} (deleted in another tab?)") from None
        except OSError as exc:
            from pipeline.file_kind import os_error_words

            raise SessionError(f"cannot delete {path.name}: {os_error_words(exc, path)}") from None
        return path.name

    def _snapshot_path(self, name: str) -> Path:
        """The snapshot file ``name`` names; the files the session folder holds for itself are refused,
        whatever their case (``Session`` is ``session.json`` on a case-blind disk): the live session,
        the undo history and anything in the captures folder."""
        path = self.resolve_name(name)
        rel = path.relative_to(self.folder)  # resolve_name keeps names inside the (resolved) folder
        first = rel.parts[0].lower() if rel.parts else ""
        if len(rel.parts) == 1 and first == SESSION_FILE:
            raise SessionError(f"{name.strip()!r} is the session itself ({SESSION_FILE}, saved after every change): "
                               "choose another name for a snapshot")
        if len(rel.parts) == 1 and first == HISTORY_FILE:
            raise SessionError(f"{HISTORY_FILE} holds the undo history: choose another name")
        if len(rel.parts) > 1 and first == CAPTURE_DIR:
            raise SessionError(f"{name.strip()!r} is inside {CAPTURE_DIR}/, where the session keeps its photos: "
                               "choose another name")
        return path

    @property
    def save_error(self) -> str | None:
        """Why the last autosave failed (changes are not being saved), or ``None`` when saving works."""
        with self._lock:
            return self._last_save_error

    @property
    def restore_problems(self) -> tuple[str, ...]:
        """What the last restore at start-up could not bring back, and why (for the page)."""
        with self._lock:
            return tuple(self._restore_problems)

    def _save_locked(self) -> None:
        """Autosave; a failure (or a recovery) is announced to every tab once, not once per save."""
        if not self._autosave:
            return
        path = self.folder / SESSION_FILE
        try:
            write_session_file(path, self.to_dict())
        except (OSError, TypeError, ValueError) as exc:  # keep working; tell the operators once
            if self._last_save_error is None:
                log.error("autosave to %s failed: %s", path, exc)
                from pipeline.file_kind import os_error_words  # in words, not "[Errno 30] Read-only file system"

                why = os_error_words(exc, path) if isinstance(exc, OSError) else str(exc)
                self._outbox.append(Notice(
                    "Changes are not being saved",
                    f"writing {path} failed: {why}. The console keeps working, but a restart will lose the "
                    "changes: make the folder writable (the next change then saves everything) or free some disk space.",
                    "error"))
            self._last_save_error = str(exc)
            return
        if self._last_save_error is not None:
            self._outbox.append(Notice("Saving again", f"{path.name} is written after every change again", "success"))
        self._last_save_error = None
        self._save_history_locked()

    _history_written = -1  # the history's version last written to history.json
    _history_writer: HistoryWriter | None = None

    def _save_history_locked(self) -> None:
        """Write the undo / redo history (``history.json``) when it changed since it was last written."""
        if self._history.version == self._history_written:
            return
        if self._history_writer is None:
            self._history_writer = HistoryWriter()
        undo, redo = self._history.states()
        try:
            self._history_writer.write(self.folder / HISTORY_FILE, undo, redo, self._workspace, self._margin)
        except (OSError, TypeError, ValueError) as exc:  # the map is saved; only the history is not
            log.error("cannot write the undo history %s: %s", HISTORY_FILE, exc)
            return
        self._history_written = self._history.version

    def _restore_history_locked(self) -> list[str]:
        """Read ``history.json`` back into the history; returns what could not be restored."""
        undo, redo, problems = read_history_file(self.folder / HISTORY_FILE, self._workspace)
        self._history.replace(undo, redo)
        self._history_written = self._history.version
        return problems

    _capture_number: int | None = None  # the last capture number given (None: not looked up yet)

    def next_capture_id(self, name: str = "", source: str = "") -> str:
        """A new capture id, unique in this session folder across restarts (``cap-0013``: one past the
        highest found in ``captures/`` and in ids already given; see :func:`numbered_capture_id`)."""
        with self._lock:
            if self._capture_number is None:
                ids = [str(self._capture_meta.get("id", ""))] if isinstance(self._capture_meta, dict) else []
                self._capture_number = highest_capture_number(self.folder, ids)
            self._capture_number += 1
            return numbered_capture_id(self._capture_number, name, source)

    def _store_capture_locked(self, rec: CaptureRecord) -> dict[str, Any] | None:
        """Write the capture's files; their metadata, or ``None`` (logged) if they cannot be stored."""
        try:
            return write_capture_files(self.folder, rec)
        except OSError as exc:
            log.error("cannot store capture %s: %s", rec.id, exc)
            return None

    # --- loading -------------------------------------------------------------------------------
    def load(self, name: str | None = None) -> list[str]:
        """Replace the state with a saved session; returns notes about what could not be kept.

        Raises :class:`SessionError` naming the bad field when the file cannot be used at all; the
        current state is then left untouched. Bad parts of a usable file are dropped and named in
        the notes. A load can be undone (:meth:`~console.session.session.Session.undo_edit`).
        """
        path = self.folder / SESSION_FILE if name is None else self.resolve_name(name)
        if self.run.active:
            raise SessionError("a mission is under way: abort it before loading another session")
        saved = parse_saved(read_session_file(path, self.folder), path.name, self._workspace)
        notes = self._apply_saved(saved, path.name, remember=f"load {path.name}")
        self._emit_all()
        return notes + self.warn_objects_over_robot(f"session {path.name}")  # type: ignore[attr-defined]

    def restore_last(self) -> list[str] | None:
        """Restore ``session.json`` at start-up; ``None`` if nothing was restored.

        A file that cannot be used is moved aside (``session.json.unreadable-<time>``) and the
        session starts empty; a partly bad one is copied aside and its valid parts restored. Either
        way the reasons are in :attr:`restore_problems`. Raises :class:`SessionError` (saying what
        to do) only when a bad file cannot be kept aside, e.g. in a read-only folder.
        """
        path = self.folder / SESSION_FILE
        if not path.exists():
            return None
        try:
            saved = parse_saved(read_session_file(path, self.folder), path.name, self._workspace)
        except SessionError as exc:
            kept = keep_aside(path, str(exc), move=True)
            log.error("the last session could not be restored (%s); it was kept as %s and the console "
                      "starts empty", exc, kept.name)
            with self._lock:
                self._restore_problems = [str(exc), f"the file was kept as {kept.name}; the console started empty"]
            return None
        problems = list(saved.problems)
        if problems:
            try:
                kept = keep_aside(path, "; ".join(problems), move=False)
                problems.append(f"the file as it was is kept as {kept.name}")
            except SessionError:
                problems.append("the file as it was could not be copied aside (read-only folder?)")
            log.error("the last session was restored in part: %s", "; ".join(problems))
        with self._lock:  # Undo and Redo as they were before the restart (read before the first save)
            history_problems = self._restore_history_locked()
        notes = self._apply_saved(saved, path.name, remember=None)
        with self._lock:
            self._restore_problems = problems + history_problems
        self._emit_all()
        return notes

    def _emit_all(self) -> None:
        cap = self.capture
        self._emit([(SCENE, None), (GRID, None), (ROUTE, None), (MISSION, None), (SETTINGS, None),
                    (SELECTION, None)] + ([(CAPTURE, cap)] if cap is not None else []))

    def _apply_saved(self, saved: SavedSession, where: str, remember: str | None) -> list[str]:
        """Swap the checked parts in; returns the problems and notes for the operator."""
        notes = list(saved.problems) + list(saved.notes)
        mission = saved.mission
        with self._lock:
            if remember is not None:  # the known space before the load comes back with an undo
                self._remember_locked(remember)
                remember = None
            self._known, self._plan_unknown = saved.known, saved.plan_unknown  # type: ignore[attr-defined]
            grid = self._grid_for_locked(saved.scene)  # type: ignore[attr-defined]  # KnownSpaceSession
            route = Route(grid, self._route.start, self._weights)
            if saved.route is not None:
                try:
                    notes += route.restore(saved.route)
                except (KeyError, TypeError, ValueError, IndexError) as exc:
                    notes.append(f"{where}: route could not be restored ({exc}); the route and mission were dropped")
                    route, mission = Route(grid, self._route.start, self._weights), None
            if remember is not None:
                self._remember_locked(remember)
            self._scene, self._grid, self._route, self._mission = saved.scene, grid, route, mission
            self._selected = None
            self._settings = replace(self._settings, goal_mode=saved.goal_mode, altitude=saved.altitude)
            self._capture, self._capture_meta = None, None
            if saved.last_capture is not None:
                try:
                    self._capture = read_capture_files(self.folder, saved.last_capture)
                    self._capture_meta = saved.last_capture
                except (KeyError, TypeError, ValueError, AttributeError, OSError) as exc:
                    notes.append(f"the last capture could not be restored: {exc}")
            self._save_locked()
        return notes

    def status_text(self) -> tuple[str, bool]:
        """What the page says about saving and the last restore, and whether it is a warning."""
        with self._lock:
            err, problems, auto = self._last_save_error, list(self._restore_problems), self._autosave
        if err is not None:
            parts = [f"Changes are NOT being saved: {err}. A restart will lose them."]
        elif auto:
            parts = ["The session is saved after every change and restored at start."]
        else:
            parts = ["Changes are not saved automatically (autosave off)."]
        if problems:
            parts.append("The last session was restored in part: " + "; ".join(problems) + ".")
        return " ".join(parts), bool(err is not None or problems)
