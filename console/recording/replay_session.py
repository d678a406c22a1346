"""A read-only session fed from a recording: the console's views draw it as they draw a live one.

:class:`ReplaySession` is a :class:`~console.session.session.Session` whose state is set by
:meth:`ReplaySession.show` from a :class:`~console.recording.replay.ReplayState`; every edit and command
(goals, register, mission, spawn, move, delete, undo, save, load, robot commands) is refused with
:class:`~console.session.session.SessionError` ("replay is read-only"), a click's goal with a failed
:class:`~planner.route.PlanResult`. Selecting an object (a view choice) still works.

Frames and units as in :mod:`console.session.session` (world frame [m]).
"""

from __future__ import annotations

import shutil
import tempfile
import time
from dataclasses import replace
from typing import Any, NoReturn

from planner.grid import build_grid
from planner.route import PlanResult

from console.recording.replay import ReplayInfo, ReplayState
from console.session.session import CAPTURE, GRID, MISSION, ROBOT, ROUTE, RUN, SCENE, SELECTION, RouteSnapshot, Session, SessionError

READ_ONLY = "replay is read-only: this console shows a recording; start `morphonavi console` to plan and drive"

_REFUSED = (
    "register", "discard", "undo", "clear_route", "build_mission", "spawn", "delete_object", "move_object",
    "set_capture", "set_robot", "set_job", "set_run", "complete_mission", "mission_started", "mission_not_started",
    "mission_finished", "replan_from_robot", "add_landing", "land_mission", "return_mission", "save", "load",
    "restore_last", "undo_edit", "redo_edit", "delete_save", "next_capture_id", "attach_runner",
)


def _refuse(*_args: Any, **_kwargs: Any) -> NoReturn:
    raise SessionError(READ_ONLY)


class ReplaySession(Session):
    """A session showing a recording (see the module docstring).

    Args:
        info: The recorded console's workspace, margin and start.
    """

    def __init__(self, info: ReplayInfo) -> None:
        self._tmp = tempfile.mkdtemp(prefix="morphonavi-replay-")  # nothing is saved: autosave off
        super().__init__(self._tmp, start=info.start, workspace=info.workspace, margin=info.margin, autosave=False)
        self._replay_route: RouteSnapshot | None = None
        self._versions: dict[str, int] = {}
        self._grid_for: Any = None
        self.state: ReplayState | None = None

    def close(self) -> None:
        shutil.rmtree(self._tmp, ignore_errors=True)

    # --- what the views read -----------------------------------------------------------------------
    def route_snapshot(self) -> RouteSnapshot:
        with self._lock:
            if self._replay_route is not None:
                return self._replay_route
        return super().route_snapshot()

    # --- the recording drives the state ---------------------------------------------------------
    def show(self, state: ReplayState) -> None:
        """Show ``state``: set what changed since the last call and announce it to the views."""
        from console.recording import recording_schemas as rs

        old, new = self._versions, state.versions
        changed = {t for t in set(old) | set(new) if old.get(t) != new.get(t)}
        events: list[tuple[str, Any]] = []
        with self._lock:
            self.state = state
            if rs.SCENE_JSON in changed or self._grid_for is None:
                if state.scene is not self._grid_for:
                    self._scene = state.scene
                    self._grid = build_grid(state.scene, self._workspace, self._margin)
                    self._grid_for = state.scene
                    if self._selected is not None and self._selected not in {o.id for o in state.scene.objects}:
                        self._selected = None
                    events += [(SCENE, None), (GRID, None), (SELECTION, self._selected)]
            if rs.ROUTE_JSON in changed:
                self._replay_route = state.route
                events.append((ROUTE, None))
            if rs.MISSION_JSON in changed:
                self._mission = state.mission
                events.append((MISSION, None))
            if rs.CAPTURE_META in changed:
                self._capture = state.capture  # None before the first capture (the camera panel keeps its last photo)
                if state.capture is not None:
                    events.append((CAPTURE, state.capture))
            if rs.ROBOT_STATE in changed or rs.POSE in changed:
                self._robot = None if state.robot is None else replace(  # its age as it was at the shown time
                    state.robot, stamp=time.time() - (state.time / 1e9 - state.robot.stamp))
                if self._robot is not None:
                    events.append((ROBOT, self._robot))
            if rs.PROGRESS in changed:
                self._run = state.run
                events.append((RUN, state.run))
            self._versions = dict(new)
        self._emit(events)

    # --- everything that edits or commands is refused ------------------------------------------------
    def add_goal(self, goal: Any) -> PlanResult:
        return PlanResult(False, READ_ONLY)


for _name in _REFUSED:
    if hasattr(Session, _name):
        setattr(ReplaySession, _name, _refuse)
