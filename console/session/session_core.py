"""The state the session's mixins share: declared once, so :mod:`console.session.history` (undo) and
:mod:`console.session.session_store` (persistence) type ``self`` without importing
:class:`console.session.session.Session` (which mixes them in and sets every attribute in its ``__init__``).

Annotations only (no values, no behaviour). Frames and units as in :mod:`console.session.session_types`:
world frame (z up) [m], yaw about +z [rad].
"""

from __future__ import annotations

import threading
from pathlib import Path
from typing import Any, Callable, Sequence

from pipeline.scene import Scene
from planner.grid import CostWeights, PlanningGrid, Workspace
from planner.mission import Mission
from planner.route import Route

from console.session.session_types import CaptureRecord, Notice, RunStatus, Settings, Vec3


class SessionCore:
    """Attributes and hooks of :class:`~console.session.session.Session` that its mixins use."""

    folder: Path
    _lock: threading.RLock
    _autosave: bool
    _workspace: Workspace
    _margin: float
    _weights: CostWeights
    _scene: Scene
    _grid: PlanningGrid
    _route: Route
    _mission: Mission | None
    _capture: CaptureRecord | None
    _capture_meta: dict[str, Any] | None
    _run: RunStatus
    _selected: str | None
    _settings: Settings
    _last_save_error: str | None
    _restore_problems: list[str]
    _outbox: list[Notice]
    _history: Any  # console.session.history.History (that module imports this one)
    capture: CaptureRecord | None  # property of Session
    run: RunStatus  # property of Session
    # hooks defined by Session or the other mixin
    _emit: Callable[[Sequence[tuple[str, Any]]], None]
    _sync_start_locked: Callable[[], bool]
    _floor_point: Callable[[Sequence[float]], Vec3]
    _remember_locked: Callable[..., None]
    _save_locked: Callable[[], None]
