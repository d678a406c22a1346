"""Go look: the suggested look towards a goal not seen yet, as one operator action, off the UI thread.

When a goal is refused as not seen yet, **Go look** (next to Look around) takes the next look of
:func:`planner.goal_look.next_look` from where the robot is (hover spots included; never a spot
next to where a capture was already taken from the same heading) and:

1. goes there as a normal mission the operator sees in the Mission panel (walk, take-off, fly:
   the route is planned, registered and executed as any other);
2. turns to face the goal (a ``TURN`` segment) and captures & maps;
3. tries the goal again: either the route to it is planned (the candidate, left for the operator
   to Register and Execute), or the next look is offered with why ("the floor at (2.50, 5.00) is
   still below the camera's view from there; next look from (3.88, 7.38, 0.97) m: Go look").

One look per click: the operator decides on each. **Pause** pauses the mission under way (or holds
a turn) and the job waits; **Resume** carries on; **Stop** aborts the mission and ends it. The
Mission panel's own Pause / Abort act on the move too (an aborted move ends the look). World frame
[m], headings counter-clockwise from +x [rad].
"""

from __future__ import annotations

import logging
import math
import time
from dataclasses import dataclass, field
from typing import Any, Sequence

from planner.goal_look import hidden_by, known_state
from planner.mission import MissionError, heading_to, turn_segment
from planner.route import Route

from console.session.job_thread import JobThread
from console.session.mapping_job import MappingJob
from console.session.session import RUN, JobStatus, Session, SessionError
from console.wording import plural

log = logging.getLogger(__name__)

GO_LOOK = "Go look"
MOVE_TIMEOUT = 900.0
"""Longest wait for the move to the look [s]."""
TURN_TIMEOUT = 60.0
"""Longest wait for the turn [s]."""


def _fmt(p: Sequence[float]) -> str:
    return "(" + ", ".join(f"{v:.2f}" for v in p) + ")"


@dataclass
class GoLookOutcome:
    """What the last Go look did.

    Attributes:
        target: The goal (world [m]).
        looks: Looks taken towards it since it was first asked for.
        planned: Whether the goal's route is planned now (the candidate).
        message: The last line for the operator.
        next_look: The camera position of the next look offered [m], if any.
        kinds: Segment kinds of each move to a look (``walk-takeoff-fly`` ...).
    """

    target: tuple[float, float, float] = (0.0, 0.0, 0.0)
    looks: int = 0
    planned: bool = False
    message: str = ""
    next_look: tuple[float, float, float] | None = None
    kinds: list[str] = field(default_factory=list)


def looked_from(session: Session) -> list[tuple[tuple[float, float, float], float]]:
    """``(camera position [m], heading [rad])`` of the session's captures (to suggest none of them again)."""
    out = []
    for c in session.scene.captures:
        pose = dict(c.robot_pose or {})
        if "yaw" not in pose:
            continue
        if c.camera_position is not None:
            eye = tuple(float(v) for v in c.camera_position)
        elif all(k in pose for k in ("x", "y", "z")):
            eye = (float(pose["x"]), float(pose["y"]), float(pose["z"]) + session.grid.robot.camera_height)
        else:
            continue
        out.append((eye, float(pose["yaw"])))  # type: ignore[arg-type]
    return out


class GoLookJob(JobThread):
    """Runs Go look in a worker thread (one at a time).

    Args:
        session: State, progress and notices; a mission under way refuses a look.
        link: The robot link (``latest_state``, ``run_segment``, ``hold``).
        mapping: Capture & map, run in this job's thread.
        runner: The mission runner (``execute``, ``pause``, ``resume``, ``abort``).
    """

    def __init__(self, session: Session, link: Any, mapping: MappingJob, runner: Any) -> None:
        super().__init__(session)
        self._link, self._mapping, self._runner = link, mapping, runner
        self.outcome = GoLookOutcome()

    # --- control --------------------------------------------------------------------------------------
    def start(self, target: Sequence[float]) -> None:
        """Go look towards ``target`` (world ``(x, y)`` on the floor or ``(x, y, z)`` [m]); returns at once.

        Raises:
            SessionError: Not finite, outside the workspace, right at the robot (no heading to face, as
                Look at goal says), another look / capture / mission under way, no robot state.
        """
        t = [float(v) for v in target]
        ws = self._session.workspace
        if len(t) == 2:
            t.append(ws.floor)
        if len(t) != 3 or not all(math.isfinite(v) for v in t):
            raise SessionError(f"go look: the goal must be finite numbers (x, y[, z]) [m], got {target!r}")
        if not ws.contains(t):
            raise SessionError(f"go look: the goal {_fmt(t)} is outside the workspace {_fmt(ws.min)}..{_fmt(ws.max)}")
        st = self._robot_ready(self._link, self._mapping, "a look is already running: pause or stop it first", "Go look")
        try:  # Look at goal's rule: a goal right at the robot has no heading to face
            heading_to(st.position, (t[0], t[1], 0.0))
        except MissionError as exc:
            raise SessionError(f"go look: {exc}") from None
        goal = (t[0], t[1], t[2])
        with self._lock:
            if self.outcome.target != goal:
                self.outcome = GoLookOutcome(target=goal)
            self._launch(self._run, "go-look", (goal,),
                         announce=lambda: self._report(0.0, f"towards {_fmt(goal[:2])}: choosing where to look from"))

    def pause(self) -> None:
        """Pause the move under way (the robot holds) and wait."""
        if not self.running:
            raise SessionError("no Go look is running")
        self._request_pause()
        if self._session.run.state == "running" and self._runner is not None:
            try:
                self._runner.pause()
            except Exception as exc:  # the runner's errors: the job still waits
                log.info("go look pause: %s", exc)
        else:
            self._hold()

    def resume(self) -> None:
        if not self.paused:
            raise SessionError("no Go look is paused")
        self._request_resume()
        if self._session.run.state == "paused" and self._runner is not None:
            self._runner.resume()

    def stop(self) -> None:
        """End the look; a move under way is aborted (the robot holds)."""
        if not self.running:
            return
        self._request_stop()
        if self._session.run.active and self._runner is not None:
            try:
                self._runner.abort()
            except Exception as exc:
                log.info("go look stop: %s", exc)
        else:
            self._hold()

    # --- worker --------------------------------------------------------------------------------------
    def _report(self, fraction: float, message: str, running: bool = True, error: str | None = None) -> None:
        self.outcome.message = error or message
        self._set_job(JobStatus(GO_LOOK, running, max(0.0, min(1.0, fraction)), message, error))

    def _hold(self) -> None:
        try:
            self._link.hold()
        except Exception as exc:
            log.info("go look: hold failed: %s", exc)

    def _here(self) -> tuple[float, float, float]:
        p = self._link.latest_state().position
        return (float(p[0]), float(p[1]), max(float(p[2]), self._session.workspace.floor))

    def _look(self, goal: tuple[float, float, float]) -> Any:
        s = self._session
        grid = s.grid
        return Route(grid, self._here(), s.weights).look_for(goal, avoid=looked_from(s))

    def _clear_route(self) -> None:
        snap = self._session.route_snapshot()
        if snap.registered or snap.candidate is not None:
            self._session.clear_route()

    def _go(self, where: tuple[float, float, float]) -> str | None:
        """Plan from the robot to ``where`` and run it as a mission; ``None`` when there, else why not."""
        s = self._session
        self._clear_route()
        res = s.add_goal(where)
        if not res.ok:
            return f"no route to the look at {_fmt(where)}: {res.message}"
        s.register()
        mission = s.build_mission()
        kinds = "-".join(dict.fromkeys(mission.kinds()))
        self.outcome.kinds.append(kinds)
        self._report(0.2, f"going to {_fmt(where)}: {kinds} (the Mission panel's Pause / Abort act on it)")
        states: list[str] = []  # this mission's run states (the last move's "done" is not this one's)
        unsubscribe = s.subscribe(lambda topic, st: states.append(st.state) if topic == RUN else None)
        try:
            self._runner.execute(mission)
            deadline = time.monotonic() + MOVE_TIMEOUT
            while time.monotonic() < deadline:
                if self._stop.is_set():
                    self._abort_move(states)
                    return "stopped by the operator"
                if states and states[-1] in ("done", "aborted", "failed"):
                    break
                time.sleep(0.05)
            else:
                return f"the move did not end within {MOVE_TIMEOUT:.0f} s"
        finally:
            unsubscribe()
        if states[-1] != "done":
            return f"the move ended {states[-1]}: {s.run.message}"
        self._clear_route()
        return None

    def _abort_move(self, states: list[str], timeout: float = 60.0) -> None:
        """Abort the move under way (again every 2 s: an abort may reach the runner before the move
        starts) until this mission's state says it ended, at most ``timeout`` [s]."""
        end = time.monotonic() + timeout
        while time.monotonic() < end:
            if states and states[-1] in ("done", "aborted", "failed"):
                return
            try:
                self._runner.abort()
            except Exception as exc:  # nothing to abort yet, or the runner's errors: try again
                log.info("go look: abort: %s", exc)
            again = time.monotonic() + 2.0
            while time.monotonic() < again and not (states and states[-1] in ("done", "aborted", "failed")):
                time.sleep(0.05)

    def _turn(self, yaw: float) -> str | None:
        while True:
            st = self._link.latest_state()
            run = self._link.run_segment(turn_segment(st.position, yaw))
            deadline = time.monotonic() + TURN_TIMEOUT
            while not run.done and time.monotonic() < deadline:
                if self._pause.is_set() or self._stop.is_set():
                    self._hold()
                    break
                run.wait(0.05)
            if self._stop.is_set():
                return "stopped by the operator"
            if self._pause.is_set():
                if not self._wait_paused("turning"):
                    return "stopped by the operator"
                continue  # turn again
            if getattr(run.status, "value", "") != "done":
                return f"the turn to {math.degrees(yaw) % 360:.0f}° failed: {getattr(run, 'error', '') or 'not done'}"
            return None

    def _wait_paused(self, where: str) -> bool:
        return self._wait_resumed(lambda: self._report(0.5, f"paused while {where} (Resume carries on, Stop ends)"))

    def _run(self, goal: tuple[float, float, float]) -> None:
        out = self.outcome
        try:
            look = self._look(goal)
            if look is None:
                self._end(f"no reachable spot sees {_fmt(goal[:2])} or the space around it: Look around", "warning")
                return
            self._report(0.1, f"look {out.looks + 1}: {look.why}")
            here = self._here()
            if math.dist(here, look.goal) > 0.2:
                why = self._go(look.goal)
                if why is not None:
                    self._end(f"stopped: {why}", "warning")
                    return
            if not self._wait_paused("at the look"):
                self._end("stopped by the operator", "info")
                return
            self._report(0.6, f"turning to face the goal ({math.degrees(look.yaw) % 360:.0f}°)")
            why = self._turn(look.yaw)
            if why is not None:
                self._end(f"stopped: {why}", "warning")
                return
            self._report(0.7, "capturing and mapping")
            if not self._mapping.run_as(f"{GO_LOOK} · look {out.looks + 1} from {_fmt(look.eye)}"):
                job = self._session.job
                self._end(f"the capture failed: {job.error or job.message}", "error")
                return
            out.looks += 1
            if self._stop.is_set():
                self._end("stopped by the operator after the capture", "info")
                return
            self._retry(goal, look)
        except Exception as exc:  # a bug or a link error: report it, keep the console alive
            log.exception("go look failed")
            self._end(f"failed: {exc}", "error")

    def _retry(self, goal: tuple[float, float, float], look: Any) -> None:
        """Plan the goal again; else offer the next look with why."""
        s, out = self._session, self.outcome
        self._clear_route()
        res = s.add_goal(goal)
        if res.ok:
            out.planned, out.next_look = True, None
            self._end(f"after {plural(out.looks, 'look')} the goal {_fmt(goal[:2])} is seen: "
                      f"route planned ({res.message}); Register and Execute it", "success")
            return
        grid = s.grid
        cell = grid.workspace.cell_of(goal)
        owner = grid.owner_of(cell) if cell is not None and grid.reason is not None else None
        if owner is not None and "not seen yet" not in res.message:  # an object's clearance closes it: no look opens it
            out.next_look = None
            self._end(f"after {plural(out.looks, 'look')} the goal {_fmt(goal[:2])} is refused "
                      f"for a reason a look does not change: {res.message}", "warning")
            return
        why = hidden_by(grid, known_state(grid), look.eye, look.yaw, goal)
        nxt = self._look(goal)
        where = "floor" if goal[2] - grid.workspace.floor < grid.workspace.resolution else "space"
        hidden = f"the {where} at {_fmt(goal[:2])} is still {why or 'not seen'}"
        if nxt is None:
            out.next_look = None
            self._end(f"{hidden}; no reachable spot shows more of it: Look around", "warning")
            return
        out.next_look = nxt.eye
        self._end(f"{hidden}; next look from {_fmt(nxt.eye)} m {'hovering' if nxt.mode == 'fly' else 'on the floor'}"
                  f" (Go look)", "info")

    def _end(self, text: str, level: str) -> None:
        error = text if level == "error" else None
        self._report(1.0, text, running=False, error=error)
        self._session.notify(GO_LOOK, text, level)


__all__ = ["GO_LOOK", "GoLookJob", "GoLookOutcome", "looked_from"]
