"""The session's operator rules (mixed into :class:`console.session.session.Session`): the route follows the
robot, one run state for every tab, missions that end in the air, vehicle-command missions.

The rules themselves are the pure functions of :mod:`console.session.operator_state`; this mixin applies
them to the session's state under its lock. It uses the session's ``_lock``, ``_route``, ``_grid``,
``_scene``, ``_workspace``, ``_margin``, ``_weights``, ``_mission``, ``_robot``, ``_run``,
``_emit`` and ``_save_locked``.

Frames and units: world frame (z up) [m].
"""

from __future__ import annotations

import logging
import threading
import uuid
from dataclasses import dataclass, field
from typing import Callable, Mapping

import numpy as np

from planner.landing_spot import return_spots
from planner.mission import Mission, MissionError
from planner.route import path_points

from console.session import button_rules, edit_rules, mission_rules
from console.session import operator_state as rules
from console.session import search_landing
from console.session.battery_estimate import DrainRate, hover_text
from console.session.session_types import Notice, RunStatus, SessionError, Vec3
from console.session.topics import MISSION, ROUTE, RUN

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class OperatorView:
    """What every tab shows about who drives the robot and what may run (see :mod:`console.session.operator_state`).

    Attributes:
        route_note: Why the registered route does not start at the robot (one action: re-plan), or ``None``.
        execute_blocker: Why Execute is disabled, or ``None``.
        resume_blocker: Why Resume is disabled although the run is paused (the mission was retired), or ``None``.
        commands: Vehicle commands (``hold``, ``land``, ``return``, ``disarm``) and their state.
        air_end: Height above the floor [m] at which the mission ends in the air, or ``None``.
        running: Name of the vehicle command being flown (``Land here``, ``Return``), or ``""``.
        launch: Where Return goes (the floor spot the robot last stood on disarmed), or ``None``.
        battery_note: While the robot hovers with no mission running (none, ended, or paused), the battery time left to land
            (:func:`console.session.battery_estimate.hover_text`), else ``""``.
        return_hint: Where Return lands and, when not on the take-off spot, how far from it and why
            (:func:`console.session.button_rules.return_hint`; a Return under way: where its mission ends).
    """

    route_note: str | None = None
    execute_blocker: str | None = None
    resume_blocker: str | None = None
    commands: Mapping[str, rules.CommandState] = field(default_factory=dict)
    air_end: float | None = None
    running: str = ""
    launch: Vec3 | None = None
    battery_note: str = ""
    return_hint: str = ""


@dataclass(frozen=True)
class _Run:
    """The mission the manager was given: an operator mission or a vehicle command."""

    mission: Mission
    command: str  # "" for the operator's mission
    goals: tuple[Vec3, ...] = ()
    path: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    ends: tuple[int, ...] = ()


class OperatorRules:
    """Mixin: the operator rules over the session's state (see the module docstring)."""

    _running: _Run | None = None
    _replan_goals: list[Vec3] | None = None  # goals to re-plan from the robot when it next rests
    _rebuild_after_replan = False
    _launch: Vec3 | None = None
    _retired_run: str | None = None  # id of an active run an edit retired (its abort is under way)
    _abort_run: Callable[[], None] | None = None
    _battery_land: Callable[[], None] | None = None  # ends the run and lands here (VehicleCommands)
    _battery_warned = 0  # the battery level last warned about: 0 ok, 1 low, 2 critical
    _battery_acting = ""  # the critical-battery action started ("land", "end"; each once per flight)
    _land_nearest = False  # a search runs: Land here lands on the nearest seen-free floor (search_landing)

    # --- wiring --------------------------------------------------------------------------------
    def set_land_nearest(self, on: bool) -> None:
        """While a search runs (``on``), Land here over floor not seen free or over an obstacle lands on the
        nearest seen-free floor instead of being refused (:mod:`console.session.search_landing`)."""
        with self._lock:  # type: ignore[attr-defined]
            self._land_nearest = bool(on)

    def _land_choice_locked(self, commands: Mapping[str, rules.CommandState]) -> Mapping[str, rules.CommandState]:
        """The vehicle commands, with Land here as a search lands (see :meth:`set_land_nearest`)."""
        if not self._land_nearest or self._robot is None:  # type: ignore[attr-defined]
            return commands
        return search_landing.land_elsewhere_state(commands, self._robot, self._run, self._workspace,  # type: ignore[attr-defined]
                                                   self._launch, self._grid)  # type: ignore[attr-defined]

    def attach_runner(self, abort: Callable[[], None]) -> None:
        """Give the session the way to end the run an edit retires (the mission manager's abort)."""
        self._abort_run = abort

    def attach_battery_land(self, land: Callable[[], None]) -> None:
        """Give the session the way to end a run and land here at critical charge (blocking call,
        run on its own thread)."""
        self._battery_land = land

    # --- what the views show ---------------------------------------------------------------------
    def operator_state(self, has_runner: bool = True) -> OperatorView:
        """The operator rules applied to the current state (an immutable snapshot)."""
        with self._lock:  # type: ignore[attr-defined]
            ws, robot, run = self._workspace, self._robot, self._run  # type: ignore[attr-defined]
            origin = rules.robot_origin(robot, ws) if robot is not None else None
            note = rules.route_note(self._route.start, origin, len(self._route.registered)) \
                if not run.active else None  # type: ignore[attr-defined]
            blocker = rules.execute_blocker(self._mission, robot, run, has_runner, ws)  # type: ignore[attr-defined]
            if blocker is None and self._mission is not None:  # type: ignore[attr-defined]
                blocker = edit_rules.robot_overlap_blocker(self._scene.objects, robot)  # type: ignore[attr-defined]
            if blocker is None and note is not None:
                blocker = note
            retired = ("an edit retired this mission: it is being ended" if self._retired_run is not None
                       and run.active else None)
            if retired is None and run.active and self._running is not None and not self._running.command:
                retired = rules.battery_blocker(robot)  # low battery: the operator's mission does not resume
            if retired is None and run.state == "paused" and "landing stopped: contact" in (run.message or ""):
                retired = ("the landing stopped on contact: Resume would repeat the same descent; abort, "
                           "then land elsewhere")  # a vertical descent meets the same surface again
            hovering = (robot is not None and run.state != "running" and rules.airborne(robot, ws)
                        and robot.mode in button_rules.HELD_MODES)
            returning = self._running is not None and self._running.command == "Return" and run.active
            end = self._running.mission.segments[-1].end if returning and self._running.mission.segments else None  # type: ignore[union-attr]
            return OperatorView(note, blocker, retired,
                                self._land_choice_locked(button_rules.vehicle_commands(robot, run, ws, self._launch,
                                                                                self._grid)),  # type: ignore[attr-defined]
                                rules.ends_in_air(self._mission, ws),  # type: ignore[attr-defined]
                                self._running.command if self._running is not None and run.active else "",
                                self._launch,
                                hover_text(robot.battery, self._drain_rate().rate()) if hovering else "",  # type: ignore[union-attr]
                                button_rules.return_hint(self._launch, self._grid, end))  # type: ignore[attr-defined]

    # --- hooks called by the session -------------------------------------------------------------
    def _goal_problem_locked(self, goal: Vec3) -> str | None:
        """Why a goal is refused before planning (inside the robot's margin), or ``None``. Measured at
        the goal's cell centre, where the planner checks and plans it (one rule for both)."""
        cell, _ = self._route.check_point(goal, "goal")  # type: ignore[attr-defined]
        if cell is None:
            return None  # outside, or closed for the robot's size: the planner says so
        spot = self._route.snapped(goal) or goal  # type: ignore[attr-defined]
        return rules.goal_clearance(spot, self._scene, self._margin, self._workspace)  # type: ignore[attr-defined]

    def _build_locked(self) -> Mission:
        """The registered route as a mission (it may start in the air); raises :class:`SessionError`."""
        try:
            return rules.mission_from_path(self._route.registered_cells(), self._grid)  # type: ignore[attr-defined]
        except MissionError as exc:
            raise SessionError(f"cannot build the mission: {exc}") from None

    def _follow_robot_locked(self) -> bool:
        """Apply "the route starts at the robot"; True if the route changed."""
        r, ws, route = self._robot, self._workspace, self._route  # type: ignore[attr-defined]
        if r is None:
            return False
        self._battery_rules_locked(r)
        origin = rules.robot_origin(r, ws)
        if origin is not None and not r.armed and not rules.airborne(r, ws):
            self._launch = origin  # ArduPilot-like home: where it last stood disarmed
        if self._run.active or origin is None or not rules.at_rest(r):  # type: ignore[attr-defined]
            return False
        pending, self._replan_goals = self._replan_goals, None
        if pending is not None and (pending or route.registered):
            rebuild, self._rebuild_after_replan = self._rebuild_after_replan, False
            self._replan_locked(origin, pending, rebuild=rebuild)
            return True
        if rules.gap(route.start, origin) < ws.resolution / 2 or route.registered:
            return False  # at the robot already, or a stale route the operator re-plans (one action)
        goal = route.candidate_goal
        route.set_start(origin)
        if goal is not None:
            route.propose(goal)
        return True

    def _mission_after_edit_locked(self) -> Mission | None:
        """The mission once the map changed: an idle mission is retired (Build again); a run keeps
        its mission unless its remaining segments now cross an obstacle, which ends it visibly."""
        run, mission = self._run, self._mission  # type: ignore[attr-defined]
        running = self._running
        if not run.active or running is None:
            return None
        why = rules.remaining_blocked(running.mission, run.segment or 0, self._grid, self._weights)  # type: ignore[attr-defined]
        if why is None:
            return mission
        self._retired_run = running.mission.id
        self._outbox_notice(Notice("Mission ended", f"{why}: the robot holds and the route is re-planned "
                                   "from where it stands", "warning"))
        abort = self._abort_run
        if abort is not None:
            threading.Thread(target=self._safe_abort, args=(abort,), name="retire-run", daemon=True).start()
        return None

    def _drain_rate(self) -> DrainRate:
        """The battery's drain in the air, measured from this session's robot reports (made on first use)."""
        drain = self.__dict__.get("_drain")
        if drain is None:
            drain = self.__dict__.setdefault("_drain", DrainRate())
        return drain

    def _battery_rules_locked(self, r: rules.RobotSnapshot) -> None:
        """Warn every tab once per crossing of a battery threshold; at critical charge in the air,
        end the run and land here (unless the vehicle's own failsafe acts)."""
        self._drain_rate().add(r.stamp, r.battery, rules.airborne(r, self._workspace))  # type: ignore[attr-defined]
        level = {"ok": 0, "low": 1, "critical": 2}[rules.battery_level(r)]
        if level > self._battery_warned:
            why = rules.battery_blocker(r) or ""
            title = "Battery critical" if level == 2 else "Battery low"
            body = (f"{why}: the mission is ended and the robot lands where it is" if level == 2
                    and rules.airborne(r, self._workspace) else why)  # type: ignore[attr-defined]
            self._outbox_notice(Notice(title, body, "error" if level == 2 else "warning"))
        if level >= self._battery_warned:
            self._battery_warned = level
        else:  # a recharge re-arms the warning, past a margin so a noisy reading warns once
            b = getattr(r, "battery", None)
            edge = rules.BATTERY_CRITICAL if self._battery_warned == 2 else rules.BATTERY_LOW
            if b is None or b >= edge + rules.BATTERY_HYSTERESIS:
                self._battery_warned = level
        action = rules.battery_action(r, self._run, self._workspace)  # type: ignore[attr-defined]
        if not rules.airborne(r, self._workspace) and not self._run.active:  # type: ignore[attr-defined]
            self._battery_acting = ""  # re-armed on the ground with nothing running (once per flight)
        if action is None or self._battery_acting == action:  # a landing stopped, then down: "end" still ends it
            return
        if action == "end" and self._battery_acting == "land" and self._run.state == "running":  # type: ignore[attr-defined]
            return  # the console's own landing settles after touchdown: not ended under it
        act = self._battery_land if action == "land" else self._abort_run
        if act is None:
            return
        self._battery_acting = action
        threading.Thread(target=self._safe_battery_land, args=(act,), name=f"battery-{action}", daemon=True).start()

    @staticmethod
    def _safe_battery_land(land: Callable[[], None]) -> None:
        try:
            land()
        except Exception:
            log.exception("battery critical: landing failed")

    @staticmethod
    def _safe_abort(abort: Callable[[], None]) -> None:
        try:
            abort()
        except Exception:  # already ended meanwhile
            log.info("retiring the run: it had already ended", exc_info=True)

    def _outbox_notice(self, notice: Notice) -> None:
        box = getattr(self, "_outbox", None)
        if isinstance(box, list):
            box.append(notice)
        else:
            log.warning("%s: %s", notice.title, notice.body)

    # --- runs ----------------------------------------------------------------------------------------
    def mission_started(self, mission: Mission, command: str = "") -> None:
        """The mission manager was given ``mission`` (``command``: name of a vehicle command, or "")."""
        with self._lock:  # type: ignore[attr-defined]
            route = self._route  # type: ignore[attr-defined]
            goals, ends, n = [], [], 0
            for i, seg in enumerate(route.registered):
                n += len(seg) - (1 if i else 0)
                ends.append(n - 1)
                goals.append(tuple(float(v) for v in path_points(seg[-1:], self._grid)[0]))  # type: ignore[attr-defined]
            self._running = _Run(mission, command, tuple(goals), route.registered_points(), tuple(ends))
            self._retired_run = None

    def mission_not_started(self, mission_id: str) -> None:
        """The manager refused the mission: forget it."""
        with self._lock:  # type: ignore[attr-defined]
            if self._running is not None and self._running.mission.id == mission_id:
                self._running = None

    def mission_finished(self, state: str, mission_id: str | None, status: RunStatus | None = None) -> None:
        """The manager ended a mission (``done`` or ``aborted``; its final ``status``): apply the rules
        for what is next in one step with the status change (no tab sees one without the other).

        The operator's mission done: its route is retired and the start follows the robot. Aborted:
        the mission is retired and the goals not reached yet are re-planned from the robot once it
        rests. A vehicle command (Land here, Return) ended: the registered goals are re-planned from
        where the robot now is (and the mission rebuilt if there was one).
        """
        with self._lock:  # type: ignore[attr-defined]
            if status is not None:
                self._run = status  # type: ignore[attr-defined]
            running = self._running
            if running is not None and mission_id is not None and running.mission.id != mission_id:
                running = None
            self._running, self._retired_run = None, None
            command = running.command if running is not None else ""
            route, ws = self._route, self._workspace  # type: ignore[attr-defined]
            if not command and state == "done":
                route.clear()
                self._mission = None  # type: ignore[attr-defined]
                self._replan_goals = None
            else:
                goals = list(self.route_snapshot().goals)  # type: ignore[attr-defined]
                if not command:  # aborted: retire the mission, keep the goals not reached yet
                    self._mission = None  # type: ignore[attr-defined]
                    origin = rules.robot_origin(self._robot, ws) if self._robot is not None else None  # type: ignore[attr-defined]
                    if running is not None and origin is not None:
                        goals = rules.goals_left(running.goals, running.path, running.ends, origin)
                self._replan_goals = goals if (goals or route.registered) else None
                self._rebuild_after_replan = bool(command) and self._mission is not None  # type: ignore[attr-defined]
            self._follow_robot_locked()
            self._save_locked()  # type: ignore[attr-defined]
        self._emit(([(RUN, status)] if status is not None else []) + [(ROUTE, None), (MISSION, None)])  # type: ignore[attr-defined]
        if not command and state == "done":
            self.notify("Mission done", "the route now starts where the robot stands", "success")  # type: ignore[attr-defined]

    # --- operator actions --------------------------------------------------------------------------
    def replan_from_robot(self) -> str:
        """The one action for a route that does not start at the robot: plan every registered goal
        again from the robot's pose (and rebuild the mission if there was one); returns a message."""
        with self._lock:  # type: ignore[attr-defined]
            why = mission_rules.blocker("replan", self._run.state)  # type: ignore[attr-defined]
            if why is not None:
                raise SessionError(why)
            r = self._robot  # type: ignore[attr-defined]
            if r is None:
                raise SessionError("no state from the robot yet: cannot plan from it")
            origin = rules.robot_origin(r, self._workspace)  # type: ignore[attr-defined]
            if origin is None:
                where = rules.position_blocker(r) or "the robot is outside the workspace"  # type: ignore[attr-defined]
                raise SessionError(f"{where}: cannot plan from it")
            goals = [g for g in self.route_snapshot().goals if rules.gap(g, origin) > rules.START_TOLERANCE]  # type: ignore[attr-defined]
            notes = self._replan_locked(origin, goals, rebuild=self._mission is not None)  # type: ignore[attr-defined]
            self._save_locked()  # type: ignore[attr-defined]
        self._emit([(ROUTE, None), (MISSION, None)])  # type: ignore[attr-defined]
        return "; ".join(notes)

    def _replan_locked(self, origin: Vec3, goals: list[Vec3], rebuild: bool) -> list[str]:
        route = self._route  # type: ignore[attr-defined]
        cand = route.candidate_goal
        route.set_start(origin)
        notes = [f"route re-planned from the robot at {rules.fmt_point(origin)}"]
        for g in goals:
            res = route.propose(g)
            if not res.ok:
                notes.append(f"goal {rules.fmt_point(g)} dropped: {res.message}")
                continue
            route.register()
        if cand is not None:
            route.propose(cand)
        self._mission = None  # type: ignore[attr-defined]
        if rebuild and route.registered:
            try:
                self._mission = self._build_locked()  # type: ignore[attr-defined]
                notes.append("mission rebuilt")
            except SessionError as exc:
                notes.append(str(exc))
        return notes

    def add_landing(self) -> Mission:
        """Add a landing straight below the end of a mission that ends in the air, and rebuild it."""
        with self._lock:  # type: ignore[attr-defined]
            ws, route = self._workspace, self._route  # type: ignore[attr-defined]
            why = mission_rules.blocker("add_landing", self._run.state)  # type: ignore[attr-defined]
            if why is not None:
                raise SessionError(why)
            if rules.ends_in_air(self._mission, ws) is None:  # type: ignore[attr-defined]
                raise SessionError("the mission does not end in the air: no landing to add")
            x, y, _ = route.last_node()
            spot = (float(x), float(y), ws.floor)
            why = rules.unseen_floor_blocker(spot, self._grid)  # type: ignore[attr-defined]
            if why is not None:
                raise SessionError(f"cannot land below the last goal: the floor below {rules.fmt_point(spot[:2])} "
                                   "has not been seen: look down there first")
            why = self._goal_problem_locked(spot)
            if why is not None:
                raise SessionError(f"cannot land below the last goal: {why}")
            res = route.propose(spot)
            if not res.ok:
                raise SessionError(f"cannot land below the last goal: {res.message}")
            route.register()
            self._mission = self._build_locked()  # type: ignore[attr-defined]
            mission = self._mission  # type: ignore[attr-defined]
            self._save_locked()  # type: ignore[attr-defined]
        self._emit([(ROUTE, None), (MISSION, None)])  # type: ignore[attr-defined]
        return mission

    def land_mission(self, forced: bool = False) -> Mission:
        """Land here as a one-segment mission (refused, with the reason, above a mapped obstacle, and
        over floor the known space has not seen free). ``forced`` (the critical-battery landing
        only): land even on floor not seen (a forced landing beats a crash)."""
        with self._lock:  # type: ignore[attr-defined]
            r, ws = self._robot, self._workspace  # type: ignore[attr-defined]
            if self._land_nearest and not forced and r is not None and \
                    rules.vehicle_commands(r, self._run, ws, self._launch, None)["land"].enabled:  # type: ignore[attr-defined]
                m = search_landing.land_elsewhere_mission(r, self._grid, self._route, ws,  # type: ignore[attr-defined]
                                                          f"land-{uuid.uuid4().hex[:6]}")
                if m is not None:  # a search: over unseen floor or an obstacle, land on the nearest seen-free spot
                    return m
            # one rule for the button and this refusal (console.session.button_rules): obstacle or unseen space below,
            # not flying, link or position lost, a mission under way
            state = button_rules.land_here(r, self._run, ws, self._launch, self._grid, forced)  # type: ignore[attr-defined]
            if not state.enabled and forced and r is not None and \
                    rules.vehicle_commands(r, self._run, ws, self._launch, None)["land"].enabled:  # type: ignore[attr-defined]
                # critical battery over an object: the nearest spot the landing rule fits, before the vehicle's own
                # failsafe lands it where it hovers (on the object)
                m = search_landing.land_elsewhere_mission(r, self._grid, self._route, ws,  # type: ignore[attr-defined]
                                                          f"land-{uuid.uuid4().hex[:6]}")
                if m is not None:
                    return m
            if not state.enabled or r is None:
                raise SessionError(state.reason or "Land here applies when the robot is in the air")
            return rules.land_here_mission(r, ws, f"land-{uuid.uuid4().hex[:6]}")

    def return_mission(self) -> Mission:
        """Return as a mission: the Aerial-Ground A* from the robot's pose to the launch spot, or, when the
        landing rule no longer fits it (e.g. within the robot's radius of a wall), to the nearest spot it
        fits (:func:`planner.landing_spot.return_spots`), which the operator is told."""
        with self._lock:  # type: ignore[attr-defined]
            r, ws, home = self._robot, self._workspace, self._launch  # type: ignore[attr-defined]
            state = button_rules.return_home(r, self._run, ws, home, self._grid)  # type: ignore[attr-defined]
            origin = rules.robot_origin(r, ws) if r is not None else None
            if not state.enabled or origin is None or home is None:
                raise SessionError(state.reason or "Return applies when the robot is armed or in the air")
            spots, why = return_spots(self._grid, home)  # type: ignore[attr-defined]
            if not spots:
                raise SessionError(button_rules.no_return_spot(home, why))
            for spot in spots:
                res = self._route.plan(origin, spot)  # type: ignore[attr-defined]
                if res.ok:
                    break
            if not res.ok:
                raise SessionError(f"cannot plan the return: {res.message}")
            try:
                mission = rules.mission_from_path(res.cells, self._grid, f"return-{uuid.uuid4().hex[:6]}")  # type: ignore[attr-defined]
            except MissionError as exc:
                raise SessionError(f"cannot fly the return: {exc}") from None
            said = button_rules.return_hint(home, self._grid, mission.segments[-1].end) if why else ""  # type: ignore[attr-defined]
        if said:  # the words of Return's hover text, with where this mission really ends
            self.notify("Return", said)  # type: ignore[attr-defined]
        return mission
