"""The Look around / Look at / Go look buttons (and Pause / Resume / Stop while a look runs).

The buttons turn clicks into :class:`~console.session.look.LookJob` and
:class:`~console.session.go_look.GoLookJob` calls; the progress shows in the Map folder's job line,
as for Capture & map ("Look around: heading 3/6 (210°): turning"). "Look at goal" faces the point in
the Plan folder's Goal x / y fields (a floor click fills them); "Go look" takes the suggested look
towards that goal when it was refused as not seen yet (go there, face it, capture, plan it again);
the line under the buttons says what the last Go look found and where the next look is.

Each button (and **Capture & map**, made by the app above them) is off when the session would refuse it,
with what it does and why it is off on hover (:mod:`console.session.look_rules`; drawn by the page script,
:func:`console.views.page_a11y.hint_spans`).
"""

from __future__ import annotations

import html
from typing import Any, Callable

import viser

from console.session import look_rules
from console.session.go_look import GoLookJob
from console.session.look import DEFAULT_HEADINGS, LookJob
from console.session.session import JOB, ROBOT, ROUTE, RUN, Session, SessionError
from console.views.client_notice import tell
from console.views.page_a11y import hint_spans
from console.views.refresher import Refresher


class LookView:
    """Look buttons in the current GUI container.

    Args:
        server: The viser server.
        session: Its job and run status enable the buttons.
        job: The look job.
        goal_point: Returns the Goal fields' ``(x, y)`` [m] as typed text, for Look at and Go look.
        go_look: The Go look job (``None``: no Go look button, e.g. without a mission runner).
        capture: The Capture & map button, to disable and give its hover text (``None``: none).
        mapping: The capture & map job (its ``running``), for Capture & map's rule (``None``: never busy).
    """

    def __init__(self, server: viser.ViserServer, session: Session, job: LookJob,
                 goal_point: Callable[[], tuple[str, str]], go_look: GoLookJob | None = None,
                 capture: Any = None, mapping: Any = None) -> None:
        self._session = session
        self._job = job
        self._go = go_look
        self._goal_point = goal_point
        self._capture, self._mapping = capture, mapping
        self._states: dict[str, Any] = {}
        gui = server.gui
        self.around = gui.add_button(
            "Look around", icon=viser.Icon.ROTATE_360,
            hint=look_rules.DOES["around"].format(n=DEFAULT_HEADINGS))
        self.look_at = gui.add_button("Look at goal", icon=viser.Icon.EYE, hint=look_rules.DOES["look_at"])
        self.go_look = gui.add_button("Go look", icon=viser.Icon.TELESCOPE, visible=go_look is not None,
                                      hint=look_rules.DOES["go_look"])
        self._hints = gui.add_html("")  # the buttons' hover text, shown by the page script (page_a11y)
        self.go_note = gui.add_markdown("", visible=False)
        self.pause = gui.add_button("Pause look", icon=viser.Icon.PLAYER_PAUSE, visible=False,
                                    hint="Hold the robot; Resume turns on to the next heading")
        self.resume = gui.add_button("Resume look", icon=viser.Icon.PLAYER_PLAY, visible=False)
        self.stop = gui.add_button("Stop look", icon=viser.Icon.PLAYER_STOP, visible=False)
        self.around.on_click(lambda e: self._act(e, lambda: job.look_around(DEFAULT_HEADINGS)))
        self.look_at.on_click(lambda e: self._act(e, self._look_at_goal))
        self.go_look.on_click(lambda e: self._act(e, self._go_look))
        self.pause.on_click(lambda e: self._act(e, lambda: self._running().pause()))
        self.resume.on_click(lambda e: self._act(e, lambda: self._running().resume()))
        self.stop.on_click(lambda e: self._act(e, lambda: self._running().stop()))
        self._refresher = Refresher(self._refresh, "look-view")
        session.subscribe(self._on_event)
        self.refresh()

    def follow_goal(self, fields: Any) -> None:
        """Redraw when any of the Goal ``fields`` (viser text handles) changes: typed, or filled by a click."""
        for field in fields:
            field.on_update(lambda _e: self._refresher.poke())

    def _refuse_if_off(self, name: str) -> None:
        """Refuse a click on a button the rules have turned off since this tab drew it (the same words)."""
        self._refresher.now()
        state = self._states.get(name)
        if state is not None and not state.enabled and state.reason.startswith(look_rules.NO_GOAL):
            raise SessionError(f"{look_rules.LABELS[name]}: {state.reason}")

    def _look_at_goal(self) -> None:
        self._refuse_if_off("look_at")
        x, y = self._goal_point()
        try:
            point = (float(x), float(y))
        except ValueError:
            raise SessionError(f"Goal x / y must be numbers [m] to look at, got {x!r}, {y!r}") from None
        self._job.look_at(point)

    def _go_look(self) -> None:
        if self._go is None:
            raise SessionError("Go look needs the mission runner (no robot link)")
        self._refuse_if_off("go_look")
        x, y = self._goal_point()
        try:
            point = (float(x), float(y))
        except ValueError:
            raise SessionError(f"Goal x / y must be numbers [m] to go look at, got {x!r}, {y!r}") from None
        self._go.start(point)

    def _running(self) -> Any:
        """The job the Pause / Resume / Stop buttons act on (Go look when it runs, else the look)."""
        return self._go if self._go is not None and self._go.running else self._job

    def _act(self, event: Any, action: Callable[[], Any]) -> None:
        try:
            action()
        except SessionError as exc:
            tell(event.client, "Not possible", str(exc), "yellow", 7.0)
        self.refresh()

    def _on_event(self, topic: str, payload: Any) -> None:
        if topic in (JOB, RUN, ROBOT, ROUTE):  # ROBOT: the goal is compared with where the robot stands
            self._refresher.poke()  # never block the session's caller; the last redraw shows the latest state

    def refresh(self) -> None:
        """Buttons as the look's state allows."""
        self._refresher.now()

    def _refresh(self) -> None:
        job = self._running()
        running, paused = job.running, job.paused
        go_running = self._go is not None and self._go.running
        busy = look_rules.Busy(look=self._job.running, go_look=go_running, mission=self._session.run.active,
                               mapping=self._mapping is not None and self._mapping.running)
        robot = self._session.robot
        try:
            typed: tuple[str, ...] = tuple(self._goal_point())
        except LookupError:  # the Plan folder's Goal fields are made after these buttons
            typed = ()
        res = self._session.workspace.resolution
        goal = look_rules.look_at_goal(busy, robot, typed, res)
        states = {"capture": look_rules.capture(busy), "around": look_rules.look_around(busy, robot),
                  "look_at": goal, "go_look": goal}
        self._states = states
        buttons = {"around": self.around, "look_at": self.look_at, "go_look": self.go_look}
        if self._capture is not None:
            buttons["capture"] = self._capture
        hints = []
        for name, button in buttons.items():
            hint = look_rules.hover(name, states[name], DEFAULT_HEADINGS)
            if button.disabled != (not states[name].enabled):
                button.disabled = not states[name].enabled
            if button.hint != hint:
                button.hint = hint
            hints.append((button, hint))
        spans = hint_spans(hints)
        if self._hints.content != spans:  # redrawn on every robot report: send only what changed
            self._hints.content = spans
        # the Mission panel pauses / aborts the move under way; these act on the look itself
        self.pause.visible = running and not paused
        self.resume.visible = paused
        self.stop.visible = running
        text = self._go.outcome.message if self._go is not None else ""
        self.go_note.content = f"<small>Go look: {html.escape(text)}</small>" if text else ""
        self.go_note.visible = bool(text)


__all__ = ["LookView"]
