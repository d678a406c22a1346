"""Undo for map edits: a bounded history of scene states.

Before each spawn, move, delete, capture or load the session pushes a :class:`SceneState` (the
scene, its planning grid, the route as saved, the mission, the last capture); :meth:`History.pop`
hands back the newest one, and :class:`Undo` (mixed into the session) puts it back. Everything held is immutable or a copy, so
a state stays valid however the session changes afterwards. All positions are world frame [m].
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass
from typing import Any

from pipeline.scene import Scene
from planner.grid import PlanningGrid
from planner.mission import Mission
from planner.route import Route

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
    """

    label: str
    scene: Scene
    grid: PlanningGrid
    route: dict[str, Any]
    mission: Mission | None
    capture: CaptureRecord | None
    capture_meta: dict[str, Any] | None
    key: str = ""
    known: Any = None


class History:
    """The newest ``depth`` states before edits; not thread-safe (the session's lock guards it)."""

    def __init__(self, depth: int = HISTORY_DEPTH) -> None:
        if depth < 1:
            raise ValueError(f"history depth must be >= 1, got {depth}")
        self._states: deque[SceneState] = deque(maxlen=depth)

    def push(self, state: SceneState) -> bool:
        """Remember ``state``; False (nothing pushed) when it continues the newest step's ``key``."""
        if state.key and self._states and self._states[-1].key == state.key:
            return False
        self._states.append(state)
        return True

    def pop(self) -> SceneState | None:
        """The newest state, removed; ``None`` when there is nothing to undo."""
        return self._states.pop() if self._states else None

    def peek(self) -> SceneState | None:
        return self._states[-1] if self._states else None

    def __len__(self) -> int:
        return len(self._states)

    def clear(self) -> None:
        self._states.clear()


class Undo(SessionCore):
    """The undo half of :class:`~console.session.session.Session` (mixed into it; uses its lock and state)."""

    def _remember_locked(self, label: str, key: str = "") -> None:
        """Push the state before an edit."""
        self._history.push(SceneState(label, self._scene, self._grid, self._route.to_dict(), self._mission,
                                      self._capture, self._capture_meta, key, getattr(self, "_known", None)))

    @property
    def undo_label(self) -> str | None:
        """What :meth:`undo_edit` would undo (``move box-3``), or ``None`` when there is nothing."""
        with self._lock:
            top = self._history.peek()
            return None if top is None else top.label

    def undo_edit(self) -> str:
        """Put the map back as it was before the last spawn, move, delete, capture or load.

        Scene, grid, registered route, mission and last capture come back together; the route start
        then follows the robot as after any change. Returns what was undone.
        """
        with self._lock:
            if self._run.active:
                raise SessionError("a mission is under way (running or paused): abort it before undoing map edits")
            state = self._history.pop()
            if state is None:
                raise SessionError("nothing to undo: no map edit since the console started")
            route = Route(state.grid, self._route.start, self._weights)
            route.restore(state.route)
            self._scene, self._grid, self._route, self._mission = state.scene, state.grid, route, state.mission
            self._capture, self._capture_meta = state.capture, state.capture_meta
            self._known = state.known  # the known space as it was before the capture
            if self._selected is not None and self._selected not in {o.id for o in state.scene.objects}:
                self._selected = None
            self._sync_start_locked()
            self._save_locked()
            cap, selected = self._capture, self._selected
        self._emit([(SCENE, None), (GRID, None), (ROUTE, None), (MISSION, None), (SELECTION, selected)]
                   + ([(CAPTURE, cap)] if cap is not None else []))
        return f"undone: {state.label}"
