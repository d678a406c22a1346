"""Undo and redo for map edits: a bounded history of scene states.

Before each spawn, move, delete, capture or load the session pushes a :class:`SceneState` (the
scene, its planning grid, the route as saved, the mission, the last capture); :meth:`History.pop`
hands back the newest one, and :class:`Undo` (mixed into the session) puts it back, keeping the state
it replaces on the redo stack; :meth:`Undo.redo_edit` puts that back again. Any new edit clears the
redo stack (as in every editor). Everything held is immutable or a copy, so a state stays valid however
the session changes afterwards. Both stacks are saved beside the session (``history.json``,
:mod:`console.session.history_file`) and survive a restart. All positions are world frame [m].
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass, replace
from typing import Any, Sequence

from pipeline.mapping.map_extent import id_numbers
from pipeline.scene import Scene
from planner.grid import GridError, PlanningGrid
from planner.mission import Mission
from planner.route import Route

from console.session.capture_files import read_capture_files
from console.session.known_space_state import grid_for
from console.session.session_core import SessionCore
from console.session.session_types import CaptureRecord, SessionError
from console.session.topics import CAPTURE, GRID, MISSION, ROUTE, SCENE, SELECTION


HISTORY_DEPTH = 20
"""How many edits can be undone, newest first."""


@dataclass(frozen=True)
class SceneState:
    """What an edit may change, as it was before the edit.

    Attributes:
        label: What the edit was, for the operator (``move box-3``, ``capture cap-7``).
        scene: The scene (world frame).
        grid: Its planning grid.
        route: :meth:`planner.route.Route.to_dict` of the route (start, registered cells, candidate goal).
        mission: The mission, or ``None``.
        capture: The last capture shown, or ``None``.
        capture_meta: Its stored metadata (``session.json``'s ``last_capture``), or ``None``.
        key: Edits with the same non-empty key are one step (a capture and the spawn of its objects).
        known: The known space (:mod:`console.session.known_space_state`), or ``None``.

    A state read back from ``history.json`` has no ``grid`` (rebuilt when it is put back) and no
    ``capture`` (read from its files, named in ``capture_meta``, when it is put back).
    """

    label: str
    scene: Scene
    grid: PlanningGrid | None
    route: dict[str, Any]
    mission: Mission | None
    capture: CaptureRecord | None
    capture_meta: dict[str, Any] | None
    key: str = ""
    known: Any = None


class History:
    """The newest ``depth`` states before edits, and the states undone since the last edit (redo);
    not thread-safe (the session's lock guards it)."""

    def __init__(self, depth: int = HISTORY_DEPTH) -> None:
        if depth < 1:
            raise ValueError(f"history depth must be >= 1, got {depth}")
        self.depth = depth
        self._states: deque[SceneState] = deque(maxlen=depth)
        self._redo: deque[SceneState] = deque(maxlen=depth)
        self.version = 0  # bumped by every change: the session saves the history when it moved on

    def push(self, state: SceneState) -> bool:
        """Remember ``state`` (a new edit: the redo stack is cleared); False (nothing pushed) when it
        continues the newest step's ``key``."""
        self._redo.clear()
        self.version += 1
        if state.key and self._states and self._states[-1].key == state.key:
            return False
        self._states.append(state)
        return True

    def pop(self) -> SceneState | None:
        """The newest state, removed; ``None`` when there is nothing to undo."""
        if not self._states:
            return None
        self.version += 1
        return self._states.pop()

    def peek(self) -> SceneState | None:
        return self._states[-1] if self._states else None

    def push_redo(self, state: SceneState) -> None:
        """Keep the state an undo replaced, for :meth:`pop_redo`."""
        self.version += 1
        self._redo.append(state)

    def pop_redo(self) -> SceneState | None:
        """The newest undone state, removed; ``None`` when there is nothing to redo."""
        if not self._redo:
            return None
        self.version += 1
        return self._redo.pop()

    def peek_redo(self) -> SceneState | None:
        return self._redo[-1] if self._redo else None

    def keep_undone(self, state: SceneState) -> None:
        """Put a state back on the undo stack without clearing the redo stack (a redo)."""
        self.version += 1
        self._states.append(state)

    def states(self) -> tuple[tuple[SceneState, ...], tuple[SceneState, ...]]:
        """``(undo, redo)``, oldest first (what :mod:`console.session.history_file` saves)."""
        return tuple(self._states), tuple(self._redo)

    def replace(self, undo: Sequence[SceneState], redo: Sequence[SceneState]) -> None:
        """Take both stacks as read back from a file (oldest first); the newest ``depth`` are kept."""
        self._states = deque(undo, maxlen=self.depth)
        self._redo = deque(redo, maxlen=self.depth)
        self.version += 1

    def __len__(self) -> int:
        return len(self._states)

    def clear(self) -> None:
        self._states.clear()
        self._redo.clear()
        self.version += 1


class Undo(SessionCore):
    """The undo half of :class:`~console.session.session.Session` (mixed into it; uses its lock and state)."""

    def _remember_locked(self, label: str, key: str = "") -> None:
        """Push the state before an edit."""
        self._history.push(self._state_now_locked(label, key))

    @property
    def undo_label(self) -> str | None:
        """What :meth:`undo_edit` would undo (``move box-3``), or ``None`` when there is nothing."""
        with self._lock:
            top = self._history.peek()
            return None if top is None else top.label

    @property
    def redo_label(self) -> str | None:
        """What :meth:`redo_edit` would put back (``move box-3``), or ``None`` when there is nothing."""
        with self._lock:
            top = self._history.peek_redo()
            return None if top is None else top.label

    def _state_now_locked(self, label: str, key: str = "") -> SceneState:
        return SceneState(label, self._scene, self._grid, self._route.to_dict(), self._mission,
                          self._capture, self._capture_meta, key, getattr(self, "_known", None))

    def undo_edit(self) -> str:
        """Put the map back as it was before the last spawn, move, delete, capture or load.

        Scene, grid, registered route, mission and last capture come back together; the route start
        then follows the robot as after any change. The state it replaces can be put back with
        :meth:`redo_edit` until the next edit. Returns what was undone.
        """
        with self._lock:
            if self._run.active:
                raise SessionError("a mission is under way (running or paused): abort it before undoing map edits")
            state = self._history.peek()
            if state is None:
                raise SessionError(f"nothing to undo: no map edit left in the history (the last {self._history.depth} "
                                   "are kept)")
            ready = self._ready_locked(state)  # may refuse: nothing has changed yet
            self._history.pop()
            self._history.push_redo(self._state_now_locked(state.label, state.key))
            self._put_back_locked(state, *ready)
        self._emit_put_back()
        return f"undone: {state.label}" + "".join(f"; {n}" for n in ready[3])

    def redo_edit(self) -> str:
        """Put back the edit the last :meth:`undo_edit` took away (until a new edit clears it).

        Returns what was redone.
        """
        with self._lock:
            if self._run.active:
                raise SessionError("a mission is under way (running or paused): abort it before redoing map edits")
            state = self._history.peek_redo()
            if state is None:
                raise SessionError("nothing to redo: no edit was undone since the last change")
            ready = self._ready_locked(state)
            self._history.pop_redo()
            self._history.keep_undone(self._state_now_locked(state.label, state.key))
            self._put_back_locked(state, *ready)
        self._emit_put_back()
        return f"redone: {state.label}" + "".join(f"; {n}" for n in ready[3])

    def _ready_locked(self, state: SceneState) -> tuple[PlanningGrid, CaptureRecord | None, dict[str, Any] | None, list[str]]:
        """What putting ``state`` back needs: its grid (rebuilt when it came from ``history.json``), its
        capture (read back from its files) and notes for the operator. Raises :class:`SessionError`."""
        notes: list[str] = []
        grid = state.grid
        if grid is None:
            try:
                grid = grid_for(state.scene, self._workspace, self._margin, state.known,
                                getattr(self, "_plan_unknown", "closed"))
            except GridError as exc:
                raise SessionError(f"cannot build the planning grid: {exc}") from None
        capture, meta = state.capture, state.capture_meta
        if capture is None and meta is not None:
            try:
                capture = read_capture_files(self.folder, meta)
            except (KeyError, TypeError, ValueError, AttributeError, OSError) as exc:
                notes.append(f"its capture could not be shown again: {exc}")
                meta = None
        return grid, capture, meta, notes

    def _put_back_locked(self, state: SceneState, grid: PlanningGrid, capture: CaptureRecord | None,
                         meta: dict[str, Any] | None, _notes: list[str]) -> None:
        """Make ``state`` the session's state; the route start then follows the robot."""
        self._known = state.known  # the known space as it was then (before a capture, after a redo)
        route = Route(grid, self._route.start, self._weights)
        route.restore(state.route)
        # ids are never given twice: the numbers the current map gave out stay taken in the one put back
        taken = id_numbers(self._scene.objects, self._scene.last_ids)
        last = {k: max(v, taken.get(k, 0)) for k, v in id_numbers(state.scene.objects, state.scene.last_ids).items()}
        scene = replace(state.scene, last_ids={**taken, **last})
        self._scene, self._grid, self._route, self._mission = scene, grid, route, state.mission
        self._capture, self._capture_meta = capture, meta
        if self._selected is not None and self._selected not in {o.id for o in state.scene.objects}:
            self._selected = None
        self._sync_start_locked()
        self._save_locked()

    def _emit_put_back(self) -> None:
        with self._lock:
            cap, selected = self._capture, self._selected
        self._emit([(SCENE, None), (GRID, None), (ROUTE, None), (MISSION, None), (SELECTION, selected)]
                   + ([(CAPTURE, cap)] if cap is not None else []))
