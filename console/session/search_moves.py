"""The search's moves (mixed into :class:`console.session.search.SearchJob`): go to a point with an
Aerial-Ground A* mission through the mission runner, turn in place, and notice the operator acting
on the robot in between, as in missions.

During a move (a mission) the mission panel's buttons act as on any mission: **Pause** pauses the
move and the search with it (Resume, on either panel, continues the same move), **Abort** ends the
move (the robot holds) and pauses the search. A step the manager stops on its own (a refusal, a
failed segment) ends the move and the search captures where the robot is. Between moves (turning,
capturing) **Hold**, **Land here** and **Return** pause the search: the robot does what the operator
asked and the search waits for Resume. World frame (z up) [m], headings [rad].
"""

from __future__ import annotations

import logging
import math
import re
import time
from typing import Any

from planner.mission import turn_segment

from console.session.search_report import mission_json
from console.session.search_types import MISSION_TIMEOUT
from console.session.session import SessionError

log = logging.getLogger(__name__)

PAUSED = "paused"
STOPPED = "stopped by the operator"
BATTERY = "battery"
OPERATOR_PAUSE = re.compile(r"^mission paused (before|during) ")
"""How the mission manager words a pause the operator asked for (a failed or refused step is worded otherwise)."""
ZERO_LENGTH = re.compile(r"^goal is where the robot already is ")
"""How the session refuses a goal where the robot already is (:func:`console.session.goal_rules.zero_length`)."""


class SearchMoves:
    """Mixin: moves and turns of a search (see the module docstring). Uses the job's ``_session``,
    ``_link``, ``_runner``, ``_pause``, ``_stop``, ``_pos``, ``_step``, ``_pause_for`` and ``_battery_end``."""

    _self_abort = False  # the search itself is ending the move (Pause, Stop)

    def _command_under_way(self) -> str:
        """The vehicle command (``Land here``, ``Return``) flying now, or ``""``."""
        s = self._session  # type: ignore[attr-defined]
        if not s.run.active:
            return ""
        try:
            return s.operator_state(True).running or ""
        except Exception:  # a session without operator rules
            return ""

    def _check_commands(self) -> None:
        """Between moves: a Land here or Return the operator started pauses the search."""
        cmd = self._command_under_way()
        if cmd and not self._pause.is_set():  # type: ignore[attr-defined]
            self._pause_for(f"{cmd} was started")  # type: ignore[attr-defined]

    def _set_unknown(self, allow: bool) -> None:
        """Switch the session's "plan into unknown space" rule (only while no mission is under way)."""
        s = self._session  # type: ignore[attr-defined]
        if (s.plan_unknown == "allow") == allow or s.run.active:
            return
        try:
            s.set_plan_unknown(allow)
        except SessionError as exc:
            log.info("search: plan into unknown space: %s", exc)

    def _go(self, goal: tuple[float, float, float], what: str) -> str | None:
        """Plan from the robot to ``goal`` over seen space only (the session's unknown-space rule closed:
        the search never plans through space no capture has seen) and run it; ``None`` when there (a goal
        where the robot already is counts as there), :data:`PAUSED`, :data:`STOPPED`, :data:`BATTERY`,
        or why the move did not get there."""
        s = self._session  # type: ignore[attr-defined]
        self._check_commands()
        if self._pause.is_set():  # type: ignore[attr-defined]
            return PAUSED
        self._set_unknown(False)
        try:
            if s.run.active:  # a Land here or Return the operator just started: never edit the route under it
                self._check_commands()
                return PAUSED if self._pause.is_set() else "a mission is under way"  # type: ignore[attr-defined]
            if s.route_snapshot().registered or s.route_snapshot().candidate is not None:
                s.clear_route()
            res = s.add_goal(goal)
            if res.ok:
                s.register()
                mission = s.build_mission()
        except SessionError as exc:
            self._check_commands()  # a Land here or Return started meanwhile
            return PAUSED if self._pause.is_set() else str(exc)  # type: ignore[attr-defined]
        if not res.ok and ZERO_LENGTH.match(res.message or ""):  # the planner's zero-length refusal: already there
            return None
        if not res.ok:
            self._check_commands()
            return PAUSED if self._pause.is_set() else f"no route to {what}: {res.message}"  # type: ignore[attr-defined]
        kinds = "-".join(dict.fromkeys(mission.kinds()))
        self._step("move", f"going to {what}: {kinds} ({res.message})", mission=mission_json(mission))  # type: ignore[attr-defined]
        self._self_abort = False
        try:
            self._runner.execute(mission)  # type: ignore[attr-defined]
        except Exception as exc:  # the manager refused: a Land here or Return started meanwhile, or the link
            self._check_commands()
            return PAUSED if self._pause.is_set() else f"the move could not start: {exc}"  # type: ignore[attr-defined]
        return self._follow()

    def _follow(self) -> str | None:
        """Wait for the move under way to end, acting on the operator's Pause / Resume / Abort."""
        s = self._session  # type: ignore[attr-defined]
        deadline = time.monotonic() + MISSION_TIMEOUT
        held = False  # the operator paused the move (mission Pause)
        while time.monotonic() < deadline:
            self._pos()  # type: ignore[attr-defined]  # the travel adds to the path length
            run = s.run
            if self._stop.is_set():  # type: ignore[attr-defined]
                self._abort_move()
                return STOPPED
            if run.state == "paused" and not held:
                if not OPERATOR_PAUSE.match(run.message or ""):  # a step failed or was refused
                    why = run.message
                    self._abort_move()
                    return f"the move stopped: {why}"
                held = True
                self._pause_for("the move was paused (mission Pause): Resume continues it")  # type: ignore[attr-defined]
                self._step("paused", "paused with the move (mission Pause): Resume continues the move, Abort ends it")  # type: ignore[attr-defined]
            elif run.state == "running" and held:  # resumed from the mission panel or the Find panel
                held = False
                self._pause.clear()  # type: ignore[attr-defined]
                self._step("resumed", "the move goes on")  # type: ignore[attr-defined]
            elif self._pause.is_set() and not held and run.state not in ("paused", "failsafe"):  # the search's Pause
                self._abort_move()
                return PAUSED
            if run.state in ("done", "aborted", "failed") or (run.state == "idle" and not run.active):
                break
            time.sleep(0.05)
        else:
            self._abort_move()
            return f"the move took longer than {MISSION_TIMEOUT:.0f} s"
        self._pos()  # type: ignore[attr-defined]
        state = s.run.state
        if state == "done":
            return None
        if self._stop.is_set():  # type: ignore[attr-defined]
            return STOPPED
        if state == "aborted" and not self._self_abort:
            if self._battery_end() is not None:  # type: ignore[attr-defined]  # the battery rule ended it
                return BATTERY
            self._pause_for("the move was aborted (Abort): the robot holds")  # type: ignore[attr-defined]
            return PAUSED
        if self._pause.is_set():  # type: ignore[attr-defined]
            return PAUSED
        return f"the move ended {state}: {s.run.message}"

    def _abort_move(self) -> None:
        """End the search's mission under way, if any (the robot holds), and wait for it to end."""
        s = self._session  # type: ignore[attr-defined]
        if s.run.active and not self._command_under_way():
            self._self_abort = True
            try:
                self._runner.abort()  # type: ignore[attr-defined]
            except Exception as exc:
                log.info("search: abort: %s", exc)
            end = time.monotonic() + 60
            while s.run.active and time.monotonic() < end:
                time.sleep(0.05)

    def _turn(self, yaw: float) -> bool:
        """Turn in place to ``yaw`` [rad]; ``False`` when it did not end there (paused, stopped, held)."""
        st = self._link.latest_state()  # type: ignore[attr-defined]
        if abs(math.remainder(float(st.yaw) - yaw, math.tau)) < math.radians(2):
            return True
        run = self._link.run_segment(turn_segment(st.position, yaw))  # type: ignore[attr-defined]
        deadline = time.monotonic() + 60.0
        while not run.done and time.monotonic() < deadline:
            if self._pause.is_set() or self._stop.is_set():  # type: ignore[attr-defined]
                self._link.hold()  # type: ignore[attr-defined]
                return False
            self._check_commands()
            run.wait(0.05)
        status = str(getattr(run.status, "value", run.status))
        if status == "held" and not self._stop.is_set():  # type: ignore[attr-defined]
            self._pause_for("the robot was held (Hold)")  # type: ignore[attr-defined]
        return status == "done"


__all__ = ["BATTERY", "OPERATOR_PAUSE", "PAUSED", "STOPPED", "ZERO_LENGTH", "SearchMoves"]
