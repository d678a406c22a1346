"""The mission panel: build the mission, its segment list, Execute / Pause / Resume / Abort, progress.

Execution goes through a :class:`MissionRunner` (the robot link's mission manager), which runs in
its own thread and reports back through ``Session.set_run``; this view only turns button presses
into calls and draws the reported status.
"""

from __future__ import annotations

import html
import math
import threading
from typing import Any, Protocol

import viser

from planner.mission import Mission, SegmentKind

from console.session import mission_rules
from console.session import operator_state as rules
from console.session.button_rules import return_hint
from console.views.client_notice import tell
from console.views.page_a11y import hint_spans
from console.views.paths_view import KIND_RGB
from console.wording import kind_text, plural
from console.session.session import MISSION, ROBOT, ROUTE, RUN, RunStatus, Session, SessionError


class MissionRunner(Protocol):
    """Drives the robot through a mission without blocking the caller."""

    def execute(self, mission: Mission) -> None: ...

    def pause(self) -> None: ...

    def resume(self) -> None: ...

    def abort(self) -> None: ...


def max_height(segment: Any, floor: float = 0.0) -> float:
    """Highest waypoint of a segment above the floor at world z = ``floor`` [m]."""
    return max(float(w[2]) for w in segment.waypoints) - floor


def no_mission_text(registered: int, refused: str | None = None, run_state: str = "idle") -> str:
    """The mission panel without a mission: what to do next, given the count of registered segments, or
    why Build mission is refused for the registered path (``refused``: shown until the route changes);
    after a mission ended (``run_state`` ``done`` / ``aborted``) it says so instead of "No mission yet"."""
    if registered and refused:
        return (f"<small style='color:#b35c00'>No mission: <b>Build mission</b> is refused for this path: "
                f"{html.escape(refused)}. Plan the goal again (Clear, then click it).</small>")
    if registered:
        return "<small>No mission yet: <b>Build mission</b> turns the registered path into one.</small>"
    first = {"done": "Mission done", "aborted": "Mission aborted"}.get(run_state, "No mission yet")
    return f"<small>{first}: register a path, then <b>Build mission</b>.</small>"


def built_text(mission: Mission) -> str:
    """What a built mission is, in words: ``3 segments: walk → take-off → fly``."""
    return f"{plural(len(mission.segments), 'segment')}: " + " → ".join(kind_text(s.kind) for s in mission.segments)


def segment_table(mission: Mission, current: int | None = None) -> str:
    """The mission as a Markdown table (HTML colour chips), the running segment in bold.

    A fly segment also says how high it climbs (``max 1.9 m`` above the floor): its two ends
    alone can hide a climb over a tall obstacle. The *from → to* cell holds its start, its end and that
    climb (or a turn's heading) one a line, so every column fits the control panel (370 px) unscrolled.
    """
    floor = float(mission.bounds_min[2])
    rows = ["| # | type | from → to [m] | length |", "|---|---|---|---|"]
    for i, s in enumerate(mission.segments):
        a, b = s.start, s.end
        chip = (f"<span style='display:inline-block;width:0.7em;height:0.7em;border-radius:2px;"
                f"background:rgb{KIND_RGB[s.kind]};margin-right:0.3em'></span>")
        kind = kind_text(s.kind)
        peak = f"<br>**max {max_height(s, floor):.1f} m**" if s.kind is SegmentKind.FLY else ""
        if s.kind is SegmentKind.TURN and s.yaw is not None:
            peak = f"<br>to heading **{math.degrees(s.yaw):.0f}°**"
        row = (f"| {i + 1} | {chip}{kind} | ({a[0]:.1f}, {a[1]:.1f}, {a[2]:.1f}) →<br>"
               f"({b[0]:.1f}, {b[1]:.1f}, {b[2]:.1f}){peak} | {s.length:.2f} m |")
        if current == i:
            row = row.replace(f"| {i + 1} |", f"| ▶ **{i + 1}** |", 1)
        rows.append(row)
    rows.append(f"\n<small>mission <code>{html.escape(mission.id)}</code>: {plural(len(mission.segments), 'segment')}, "
                f"{mission.length:.2f} m</small>")
    return "\n".join(rows)


def _route_key(session: Session) -> tuple[Any, ...]:
    """What identifies the registered route (its start and cells): a Build refusal is shown until it changes."""
    snap = session.route_snapshot()
    return (tuple(snap.start), tuple(p.tobytes() for p in snap.registered))


class MissionView:
    """Mission building, listing and execution controls.

    Args:
        server: The viser server.
        session: The state it shows and edits.
        runner: The mission manager driving the robot (``None``: execution unavailable).
    """

    def __init__(self, server: viser.ViserServer, session: Session, runner: MissionRunner | None, *,
                 read_only: bool = False) -> None:
        self._server = server
        self.read_only = bool(read_only)  # replay: nothing is built or changed
        self._run_mission: tuple[str | None] | None = None  # the mission a finished run's line belongs to
        self._refused: tuple[Any, str] | None = None  # (route key, why) of the last Build refused
        self._session = session
        self._runner = runner
        self._lock = threading.Lock()
        gui = server.gui
        self._build = build = gui.add_button("Build mission", icon=viser.Icon.ROUTE, disabled=True,
                                             hint="Split the green path into walk / take-off / fly / land segments")
        self._table = gui.add_markdown("<small>No mission yet: register a path, then Build mission.</small>")
        self._replan = gui.add_button("Re-plan from the robot", color="orange", icon=viser.Icon.ROUTE, visible=False,
                                      hint="Plan every registered goal again from where the robot is now")
        self._landing = gui.add_button("Add landing", color="orange", icon=viser.Icon.ARROW_BAR_TO_DOWN, visible=False,
                                       hint="The mission ends in the air: land straight below its last goal")
        self._execute = gui.add_button("Execute", color="green", icon=viser.Icon.PLAYER_PLAY, disabled=True)
        self._why = gui.add_markdown("")
        self._pause = gui.add_button("Pause", color="yellow", icon=viser.Icon.PLAYER_PAUSE, disabled=True, visible=False)
        self._resume = gui.add_button("Resume", color="teal", icon=viser.Icon.PLAYER_PLAY, disabled=True, visible=False)
        self._abort = gui.add_button("Abort", color="red", icon=viser.Icon.PLAYER_STOP, disabled=True, visible=False)
        self._progress = gui.add_progress_bar(0.0, visible=False, color="green")
        self._status = gui.add_markdown("")
        self._hints = gui.add_html("")  # Build / Execute hover text, shown by the page script (page_a11y)
        build.on_click(self._on_build)
        self._execute.on_click(self._on_execute)
        self._replan.on_click(lambda e: self._act(e, "Re-planned", self._session.replan_from_robot))
        self._landing.on_click(lambda e: self._act(e, "Landing added", self._session.add_landing))
        self._shown: tuple[Any, ...] | None = None
        self._pause.on_click(lambda e: self._call(e, "pause"))
        self._resume.on_click(lambda e: self._call(e, "resume"))
        self._abort.on_click(lambda e: self._call(e, "abort"))
        session.subscribe(self._on_event)
        self.refresh()

    def _on_event(self, topic: str, _payload: Any) -> None:
        if topic in (MISSION, RUN, ROUTE):
            self.refresh()
        elif topic == ROBOT and self._rules_changed():
            self.refresh()

    def _rules_changed(self) -> bool:
        """Whether what the operator rules say changed (robot states arrive at tens of Hz)."""
        view = self._session.operator_state(self._runner is not None)
        key = (view.execute_blocker, view.route_note, view.resume_blocker, view.air_end, view.launch)
        return key != self._shown

    def _act(self, event: Any, title: str, action: Any) -> None:
        try:
            out = action()
        except SessionError as exc:
            tell(event.client, f"{title.split()[0]}: not done", str(exc), "yellow")
            return
        tell(event.client, title, out if isinstance(out, str) else f"mission {out.id}: {', '.join(out.kinds())}",
             "green")

    def _on_build(self, event: Any) -> None:
        try:
            mission = self._session.build_mission()
        except SessionError as exc:
            self._refused = (_route_key(self._session), str(exc))  # in the panel until the route changes
            self.refresh()
            tell(event.client, "No mission", str(exc), "yellow")
            return
        tell(event.client, "Mission built", built_text(mission), "green")

    def _on_execute(self, event: Any) -> None:
        mission = self._session.mission
        if mission is None:
            tell(event.client, "No mission", "build the mission first", "yellow")
            return
        if self._runner is None:
            tell(event.client, "Cannot execute", "this robot link has no mission manager", "red")
            return
        why = self._session.operator_state().execute_blocker
        if why is not None:
            tell(event.client, "Cannot execute", why, "yellow")
            return
        try:
            self._runner.execute(mission)
        except Exception as exc:  # the link refuses (not armed, link down, geofence ...)
            tell(event.client, "Cannot execute", str(exc), "red")

    def _call(self, event: Any, what: str) -> None:
        if self._runner is None:
            return
        try:
            getattr(self._runner, what)()
        except Exception as exc:
            tell(event.client, f"Cannot {what}", str(exc), "red")

    def refresh(self) -> None:
        """Redraw the segment list, buttons and progress from the session."""
        with self._lock:
            mission = self._session.mission
            run: RunStatus = self._session.run
            registered = len(self._session.route_snapshot().registered)
            build_off = mission_rules.blocker("build", run.state) if registered and not self.read_only else None
            if registered and not self.read_only and build_off is None:  # what the click would be refused with
                build_off = self._session.build_refusal()
            self._build.disabled = (not rules.route_edits(False, registered, self.read_only, run.state)["build"]
                                    or build_off is not None)
            key = _route_key(self._session)
            if self._refused is not None and self._refused[0] != key:
                self._refused = None  # the route changed: the refusal no longer applies
            refused = build_off if build_off is not None and build_off.startswith("cannot build") else None
            if refused is None and self._refused is not None:
                refused = self._refused[1]
            if mission is None:
                self._table.content = no_mission_text(registered, refused, run.state)
            else:
                self._table.content = segment_table(mission, run.segment if run.active else None)
            view = self._session.operator_state(self._runner is not None)
            self._shown = (view.execute_blocker, view.route_note, view.resume_blocker, view.air_end, view.launch)
            self._execute.visible = not run.active
            self._execute.disabled = view.execute_blocker is not None
            # one rule per button, the same the click is refused with (execute_blocker, mission_rules)
            self._execute.hint = ("Run the mission on the robot" if view.execute_blocker is None
                                  else f"Execute is off: {view.execute_blocker}")
            build_hint = "Split the green path into walk / take-off / fly / land segments"
            if self._build.disabled:
                why = build_off or ("a replay changes nothing" if self.read_only else "register a path first")
                build_hint += f" · Build mission is off: {why}"
            self._build.hint = build_hint
            self._hints.content = hint_spans([(self._build, build_hint), (self._execute, self._execute.hint)])
            notes = []
            if build_off is not None and build_off != refused:  # one rule per button and mission state
                notes.append(f"Build mission is off: {build_off}")  # (mission_rules; a refusal: in the table)
            if view.execute_blocker is not None and not run.active and mission is not None:
                notes.append(f"Execute is off: {view.execute_blocker}")
            if view.route_note is not None and view.route_note != view.execute_blocker:
                notes.append(view.route_note)
            if view.air_end is not None:
                notes.append(f"⚠ the mission ends hovering {view.air_end:.1f} m above the floor: add a landing")
            if view.resume_blocker is not None:
                notes.append(view.resume_blocker)
            self._why.content = "".join(f"<small style='color:#b35c00'>{html.escape(n)}</small><br>" for n in notes)
            self._replan.visible = view.route_note is not None and not self.read_only
            self._landing.visible = view.air_end is not None and not run.active and not self.read_only
            self._pause.visible = mission_rules.allowed("pause", run.state)
            self._pause.disabled = not mission_rules.allowed("pause", run.state)
            self._resume.visible = mission_rules.allowed("resume", run.state) and view.resume_blocker is None
            self._resume.disabled = not mission_rules.allowed("resume", run.state) or view.resume_blocker is not None
            self._abort.visible = mission_rules.allowed("abort", run.state)
            self._abort.disabled = not mission_rules.allowed("abort", run.state)
            # a finished run's line belongs to the mission shown when it ended: a new Build hides it
            here = (mission.id if mission is not None else None,)
            if run.active or run.state == "idle":
                self._run_mission = None
            elif self._run_mission is None:
                self._run_mission = here
            shown = run.state != "idle" and (run.active or self._run_mission == here)
            self._progress.visible = shown
            self._progress.value = round(100.0 * max(0.0, min(1.0, run.fraction)), 1)
            self._progress.animated = run.state == "running"
            colors = {"done": "green", "aborted": "gray", "failed": "red", "paused": "yellow", "failsafe": "red"}
            self._progress.color = colors.get(run.state, "blue")
            doing = f"{view.running}: " if view.running else ""
            if view.running == "Return":  # where it lands: the take-off spot, not where the operator started
                doing = f"{view.return_hint or return_hint(view.launch)} · "
            self._status.content = (f"<small>{html.escape(doing)}<b>{html.escape(run.state)}</b>"
                                    f"{' · ' + html.escape(run.message) if run.message else ''}</small>"
                                    if shown else "")


class ManagerRunner:
    """:class:`MissionRunner` over the link's :class:`~console.link.manager.MissionManager`.

    Forwards the manager's events to the session (``set_run``; warnings and errors as notices to
    every operator). When a mission completes, the executed route is retired so the next goals
    are planned from where the robot now stands.
    """

    def __init__(self, manager: Any, session: Session) -> None:
        self.manager = manager
        self._session = session
        self._last_state = ""
        self.unsubscribe = manager.subscribe(self._on_event)
        session.attach_runner(self.abort)

    def execute(self, mission: Mission, command: str = "") -> None:
        """Run ``mission`` (``command``: the vehicle command it carries out, or "" for the operator's)."""
        self._session.mission_started(mission, command)
        try:
            self.manager.start(mission)
        except Exception:
            self._session.mission_not_started(mission.id)
            raise

    def pause(self) -> None:
        self.manager.pause()

    def resume(self) -> None:
        self.manager.resume()

    def abort(self) -> None:
        self.manager.abort()

    def take_control(self, confirm: bool = False) -> str:
        """The manager's :meth:`~console.link.manager.MissionManager.take_control` (the question, or done)."""
        return self.manager.take_control(confirm)

    def close(self) -> None:
        self.unsubscribe()
        self.manager.close()

    def _on_event(self, event: Any) -> None:
        p = event.progress
        state = getattr(p.status, "value", str(p.status))
        status = RunStatus(state, p.segment, float(p.fraction), event.message or p.message)
        if state != self._last_state and state in ("done", "aborted"):
            self._session.mission_finished(state, p.mission_id, status)  # the status and what follows, at once
        else:
            self._session.set_run(status)
        self._last_state = state
        if event.level in ("warning", "error"):
            self._session.notify("Mission", event.message, event.level)


def make_runner(link: Any, session: Session, *, failsafe_after: float = 3.0,
                failsafe_hold: float = 5.0) -> MissionRunner | None:
    """The mission manager for ``link``, reporting to ``session``; ``None`` if unavailable.

    ``failsafe_after`` [s] without hearing the robot enters the failsafe (hold); ``failsafe_hold`` [s]
    later, with the link still lost, the robot is landed.
    """
    try:
        from console.link.manager import MissionManager
    except ImportError:
        return None
    return ManagerRunner(MissionManager(link, failsafe_after=failsafe_after, failsafe_hold=failsafe_hold), session)
