"""The session's read access: thread-safe snapshots of its state (mixed into :class:`console.session.session.Session`).

Every property takes the session's lock and returns an immutable value (or the current object of an
immutable type); world frame (z up) [m], yaw [rad].
"""

from __future__ import annotations

from pipeline.scene import Scene, SceneObject
from planner.grid import CostWeights, PlanningGrid, Workspace
from planner.mission import Mission
from planner.route import path_points

from console.session.session_core import SessionCore
from console.session.session_types import (CaptureRecord, JobStatus, RobotSnapshot, RouteSnapshot, RunStatus, SessionError,
                                          Settings)


class SessionReads(SessionCore):
    """Read-only properties of the session's state."""

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
        """The route as world points, for drawing; during a run its start is where the robot is."""
        with self._lock:
            r, g = self._route, self._grid
            segs = tuple(path_points(seg, g) for seg in r.registered)
            cand = r.candidate.points(g) if r.candidate is not None else None
            goals = tuple(tuple(float(v) for v in s[-1]) for s in segs if len(s))
            running = getattr(self, "_run_start", None) if self._run.active else None
            return RouteSnapshot(r.start if running is None else running, segs, cand, r.candidate_goal, goals)  # type: ignore[arg-type]

    def build_refusal(self) -> str | None:
        """What Build mission would be refused with now for the registered path (the very words of
        :meth:`build_mission`: the same split and landing checks), or ``None`` (builds, or nothing registered;
        the mission state's rule is :mod:`console.session.mission_rules`'). Kept until the route or the grid changes."""
        with self._lock:
            segs, grid = tuple(self._route.registered), self._grid
            last = getattr(self, "_build_check", None)
            if last is not None and last[0] is grid and len(last[1]) == len(segs) and all(
                    a is b for a, b in zip(last[1], segs)):
                return last[2]
            why = None
            if segs:
                try:
                    self._build_locked()  # type: ignore[attr-defined]
                except SessionError as exc:
                    why = str(exc)
            self._build_check = (grid, segs, why)
            return why

