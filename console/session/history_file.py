"""The undo and redo history on disk: ``history.json`` beside ``session.json``, so Undo and Redo
survive a console restart.

The file holds both stacks of :class:`~console.session.history.History`, oldest first. Each state is
written in the session file's own format (scene, route, mission, last capture's metadata, known
space; world frame [m]) and read back through the same checks
(:func:`console.session.session_parse.parse_saved`), so a state that would not restore as a session
is not put back either. Known spaces shared by several states are written once (``known_spaces``,
referred to by key). The grid is not stored (it is rebuilt when a state is put back) and the
capture's photo stays in ``captures/`` (its metadata names it).

Bounded: at most :data:`~console.session.history.HISTORY_DEPTH` states a stack, and the oldest undo
states are left out of the file once it would pass :data:`MAX_HISTORY_BYTES`.
"""

from __future__ import annotations

import json
import logging
from pathlib import Path
from typing import Any, Sequence

from pipeline.scene import scene_to_dict, write_text_atomic
from planner.grid import Workspace

from console.session.file_aside import put_aside
from console.session.history import SceneState
from console.session.history_schema import HISTORY_KIND, HISTORY_VERSION, outline_errors, step_errors
from console.session.session_parse import SESSION_VERSION, parse_saved
from console.session.session_types import SessionError

log = logging.getLogger(__name__)

HISTORY_FILE = "history.json"
MAX_HISTORY_BYTES = 40 * 1024 * 1024
"""The history file stays under this size [bytes]: older undo states are left out of it (a map of
10 000 objects is about 10 MB a state; the paper's room with its known space about 0.1 MB)."""


def _state_dict(state: SceneState, workspace: Workspace, margin: float, known_ref: str | None) -> dict[str, Any]:
    return {
        "label": state.label,
        "key": state.key,
        "known_ref": known_ref,
        "state": {
            "version": SESSION_VERSION,
            "kind": "morphonavi-session",
            "frame": "world",
            "workspace": {"min": list(workspace.min), "max": list(workspace.max), "resolution": workspace.resolution},
            "margin": margin,
            "scene": scene_to_dict(state.scene),
            "route": state.route,
            "mission": None if state.mission is None else state.mission.to_dict(),
            "last_capture": state.capture_meta,
        },
    }


class HistoryWriter:
    """Writes ``history.json``; keeps each state's and each known space's JSON text between writes
    (states are immutable), so a write after one edit serialises only the new state."""

    def __init__(self) -> None:
        self._entries: dict[int, tuple[SceneState, str, str | None]] = {}  # id -> (state, JSON text, known key)
        self._known: dict[int, tuple[Any, str, str]] = {}  # id -> (known space, key, its JSON text)
        self._serial = 0

    def text(self, undo: Sequence[SceneState], redo: Sequence[SceneState], workspace: Workspace, margin: float,
             max_bytes: int = MAX_HISTORY_BYTES) -> str:
        """Both stacks (oldest first) as ``history.json`` text within ``max_bytes`` (oldest undo states
        left out first; the newest undo state and the redo stack always kept)."""
        entries: dict[int, tuple[SceneState, str, str | None]] = {}
        used: set[str] = set()
        known: dict[int, tuple[Any, str, str]] = {}

        def entry(state: SceneState) -> tuple[str, str | None]:
            ref = None
            if state.known is not None:
                k = id(state.known)
                got = self._known.get(k)
                if got is None or got[0] is not state.known:
                    self._serial += 1
                    got = (state.known, f"k{self._serial}", json.dumps(state.known.to_dict(), separators=(",", ":")))
                    self._known[k] = got
                known[k] = got
                ref = got[1]
            cached = self._entries.get(id(state))
            if cached is None or cached[0] is not state:
                cached = (state, json.dumps(_state_dict(state, workspace, margin, ref), allow_nan=False,
                                            separators=(",", ":")), ref)
            entries[id(state)] = cached
            return cached[1], cached[2]

        redo_out: list[str] = []
        for s in redo:
            text, ref = entry(s)
            redo_out.append(text)
            used.add(ref or "")
        size = sum(len(t) for t in redo_out)
        undo_out: list[str] = []
        for s in reversed(undo):  # newest first: the size bound leaves out the oldest
            text, ref = entry(s)
            size += len(text)
            if size > max_bytes and undo_out:
                break
            undo_out.append(text)
            used.add(ref or "")
        undo_out.reverse()
        self._entries, self._known = entries, known
        spaces = ",".join(f"{json.dumps(key)}:{text}" for _, key, text in known.values() if key in used)
        return ('{"kind":%s,"version":%d,"known_spaces":{%s},"undo":[%s],"redo":[%s]}\n'
                % (json.dumps(HISTORY_KIND), HISTORY_VERSION, spaces, ",".join(undo_out), ",".join(redo_out)))

    def write(self, path: Path, undo: Sequence[SceneState], redo: Sequence[SceneState], workspace: Workspace,
              margin: float) -> None:
        """Write the history atomically; raises ``OSError``, ``TypeError`` or ``ValueError``."""
        write_text_atomic(path, self.text(undo, redo, workspace, margin))


def set_aside(path: Path, move: bool) -> str:
    """Move (or copy) a bad history file to ``history.json.unreadable-<time>`` beside it
    (:func:`console.session.file_aside.put_aside`); returns what the operator is told (``kept aside as
    history.json.unreadable-...``, ``a copy kept as ...``, or why not). Never raises for the folder."""
    try:
        kept = put_aside(path, move)
    except OSError as exc:
        return f"not kept aside: {(exc.strerror or str(exc)).lower()}"
    return f"{'kept aside' if move else 'a copy kept'} as {kept.name}"


def read_history_file(path: Path, workspace: Workspace) -> tuple[list[SceneState], list[SceneState], list[str]]:
    """The undo and redo states saved in ``path`` (oldest first) and what could not be read back.

    A missing file gives empty stacks and no problem. The file is checked against its schema
    (:data:`console.session.history_schema.HISTORY_SCHEMA`), then every state through the session file's
    checks. A file that is unreadable, not a history, or wrong in its outline is moved aside
    (``history.json.unreadable-<time>``): empty stacks and the reason naming the field. A step that fails
    is dropped with the ones before it (an undo goes back one step at a time, so the older ones stay
    reachable only through it; a bad redo step drops the redo stack), and the file is first copied aside.
    Never raises for a bad file.
    """
    if not path.exists():
        return [], [], []
    from pipeline.file_kind import MAX_BYTES

    def unusable(why: str) -> tuple[list[SceneState], list[SceneState], list[str]]:
        return [], [], [f"{path.name} {why}: the undo history starts empty ({set_aside(path, move=True)})"]

    try:
        if path.stat().st_size > MAX_BYTES["session"] + MAX_HISTORY_BYTES:
            return unusable("is too large to read")
        data = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, ValueError, RecursionError) as exc:
        return unusable(f"could not be read ({exc})")
    if not isinstance(data, dict) or data.get("kind") != HISTORY_KIND or data.get("version") != HISTORY_VERSION:
        return unusable(f"is not a MorphoNavi undo history (version {HISTORY_VERSION})")
    outline = outline_errors(data)
    if outline:
        return unusable(f"is not a valid undo history: {outline[0]}")
    spaces = data.get("known_spaces") or {}
    problems: list[str] = []
    known_cache: dict[str, Any] = {}

    def states(name: str) -> list[SceneState]:
        out: list[SceneState] = []
        for i, entry in enumerate(data[name]):
            try:
                errors = step_errors(entry, f"{path.name}: {name}[{i}]", limit=1)
                if errors:
                    raise SessionError(errors[0])
                out.append(_state_from(entry, spaces, workspace, known_cache, f"{path.name}: {name}[{i}]"))
            except SessionError as exc:
                problems.append(f"{exc}: the undo history before it was dropped" if name == "undo"
                                else f"{exc}: the redo history was dropped")
                out = [] if name == "undo" else out
                if name == "redo":
                    return []
        return out

    undo, redo = states("undo"), states("redo")
    if problems:
        problems[-1] += f" ({set_aside(path, move=False)})"
    return undo, redo, problems


def _state_from(entry: Any, spaces: dict[str, Any], workspace: Workspace, known_cache: dict[str, Any],
                where: str) -> SceneState:
    if not isinstance(entry, dict):
        raise SessionError(f"{where}: must be an object")
    label, key = entry.get("label"), entry.get("key", "")
    if not isinstance(label, str) or not label or not isinstance(key, str):
        raise SessionError(f"{where}.label: must be a non-empty text")
    state = entry.get("state")
    if not isinstance(state, dict):
        raise SessionError(f"{where}.state: must be an object")
    ref = entry.get("known_ref")
    if ref is not None:
        if not isinstance(ref, str) or ref not in spaces:
            raise SessionError(f"{where}.known_ref: must name one of known_spaces, got {ref!r}")
        state = dict(state, known_space=spaces[ref])
    saved = parse_saved(state, where, workspace)
    if saved.problems or saved.notes:
        raise SessionError(f"{where}: " + "; ".join(saved.problems + saved.notes))
    if saved.route is None:
        raise SessionError(f"{where}.state.route: missing")
    known = saved.known
    if ref is not None:  # one known space object per saved one, shared as when it was written
        known = known_cache.setdefault(ref, known)
    return SceneState(label, saved.scene, None, saved.route, saved.mission, None, saved.last_capture, key, known)
