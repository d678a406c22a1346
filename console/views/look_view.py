"""The Look around / Look at / Go look buttons (and Pause / Resume / Stop while a look runs).

The buttons turn clicks into :class:`~console.session.look.LookJob` and
:class:`~console.session.go_look.GoLookJob` calls; the progress shows in the Map folder's job line,
as for Capture & map ("Look around: heading 3/6 (210°): turning"). "Look at goal" faces the point in
the Plan folder's Goal x / y fields (a floor click fills them); "Go look" takes the suggested look
towards that goal when it was refused as not seen yet (go there, face it, capture, plan it again);
the line under the buttons says what the last Go look found and where the next look is.
"""

from __future__ import annotations

import html
from typing import Any, Callable

import viser

from console.session.go_look import GoLookJob
from console.session.look import DEFAULT_HEADINGS, LookJob
from console.session.session import JOB, RUN, Session, SessionError
from console.views.client_notice import tell
from console.views.refresher import Refresher


class LookView:
    """Look buttons in the current GUI container.

    Args:
        server: The viser server.
        session: Its job and run status enable the buttons.
        job: The look job.
        goal_point: Returns the Goal fields' ``(x, y)`` [m] as typed text, for Look at and Go look.
        go_look: The Go look job (``None``: no Go look button, e.g. without a mission runner).
    """

    def __init__(self, server: viser.ViserServer, session: Session, job: LookJob,
                 goal_point: Callable[[], tuple[str, str]], go_look: GoLookJob | None = None) -> None:
        self._session = session
        self._job = job
        self._go = go_look
        self._goal_point = goal_point
        gui = server.gui
        self.around = gui.add_button(
            "Look around", icon=viser.Icon.ROTATE_360,
            hint=f"Turn in place through {DEFAULT_HEADINGS} headings, capturing and mapping at each (a full circle)")
        self.look_at = gui.add_button("Look at goal", icon=viser.Icon.EYE,
                                      hint="Turn to face the point in the Goal x / y fields and capture & map")
        self.go_look = gui.add_button(
            "Go look", icon=viser.Icon.TELESCOPE, visible=go_look is not None,
            hint="For the goal in the Goal x / y fields, refused as unseen: go to the suggested look (a mission you "
                 "see), face the goal, capture & map, and plan the goal again (or offer the next look)")
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

    def _look_at_goal(self) -> None:
        x, y = self._goal_point()
        try:
            point = (float(x), float(y))
        except ValueError:
            raise SessionError(f"Goal x / y must be numbers [m] to look at, got {x!r}, {y!r}") from None
        self._job.look_at(point)

    def _go_look(self) -> None:
        if self._go is None:
            raise SessionError("Go look needs the mission runner (no robot link)")
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
        if topic in (JOB, RUN):
            self._refresher.poke()  # never block the session's caller; the last redraw shows the latest state

    def refresh(self) -> None:
        """Buttons as the look's state allows."""
        self._refresher.now()

    def _refresh(self) -> None:
        job = self._running()
        running, paused = job.running, job.paused
        go_running = self._go is not None and self._go.running
        busy = running or go_running or self._session.run.active
        self.around.disabled = busy
        self.look_at.disabled = busy
        self.go_look.disabled = busy
        # the Mission panel pauses / aborts the move under way; these act on the look itself
        self.pause.visible = running and not paused
        self.resume.visible = paused
        self.stop.visible = running
        text = self._go.outcome.message if self._go is not None else ""
        self.go_note.content = f"<small>Go look: {html.escape(text)}</small>" if text else ""
        self.go_note.visible = bool(text)


__all__ = ["LookView"]
