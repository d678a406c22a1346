"""The Find panel: what to find, the mode and budgets, Start / Approve step / Pause / Resume / Stop,
and the chosen viewpoint drawn in the scene with its gain and cost.

The viewpoint's label ("next viewpoint: gain 3.1 m³, cost 4.2") is drawn per tab through the label declutter
(:mod:`console.views.object_labels`, layer ``search``): it never sits on the robot's label (which wins) nor on
another label. A refusal to start (a target the perception cannot name, with the classes it can) pops up as its
summary; the whole text is in *Notices: full text* (:mod:`console.views.notice_details`).

The buttons turn clicks into :class:`~console.session.search.SearchJob` calls; the steps show in
the panel's line and in the Map folder's job line ("Find: robot dog: next viewpoint ...").
"""

from __future__ import annotations

import html
from typing import Any, Callable

import numpy as np
import viser

from console.session.operator_state import BATTERY_LOW
from console.session.search import MODES, SearchJob
from console.session.search_inputs import PANEL_NAMES, search_config
from console.session.search_report import result_line
from console.session.search_types import BATTERY_RESERVE, MAX_CAPTURES, MAX_TIME, MIN_TIME
from console.session.session import JOB, RUN, SEARCH, Session, SessionError
from console.views.client_notice import tell
from console.views.object_labels import LabelSpot, show_in_layer
from console.views.refresher import Refresher


def _put(handle: Any, name: str, value: Any) -> None:
    """Set a GUI property only when it changes (viser sends every assignment: a button re-sent on every
    step would be re-drawn under the operator's pointer)."""
    if getattr(handle, name) != value:
        setattr(handle, name, value)


class SearchView:
    """Find controls in the current GUI container.

    Args:
        server: The viser server (the viewpoint marker goes into its scene).
        session: Its job and run status enable the buttons.
        job: The search.
        height_of: The target's height [m] for a class or prompt (the catalog's).
    """

    def __init__(self, server: viser.ViserServer, session: Session, job: SearchJob,
                 height_of: Callable[[str], float]) -> None:
        self._server, self._session, self._job, self._height_of = server, session, job, height_of
        gui = server.gui
        self.target = gui.add_text("Find", "robot dog", hint="A catalog class, one of its synonyms or detector prompts "
                                   "(robot dog, quadruped, a quadruped robot); other words are refused with the classes "
                                   "the perception can name")
        self.mode = gui.add_dropdown("Search mode", MODES, initial_value="auto",
                                     hint="auto: moves on its own; step: each move waits for Approve step")
        # text fields, not number inputs: the browser would clamp a typed 0 to 1, send nothing for 'nan' (the
        # server keeping its last value) and make 1e309 1309; Start search checks the text as typed and refuses
        # naming the field with its range (search_config)
        self.captures = gui.add_text("Capture budget", "20", hint=f"Captures, 1..{MAX_CAPTURES}")
        self.minutes = gui.add_text("Time budget [min]", "15", hint=f"Minutes, {MIN_TIME / 60.0:g}..{MAX_TIME / 60.0:g}")
        self.reserve = gui.add_text("Battery reserve [%]", f"{round(100 * BATTERY_RESERVE)}",
                                    hint=f"{round(100 * BATTERY_LOW)}..99 %: the search ends when the charge falls "
                                    "below this, before the console's battery rules act (left to Return or land)")
        self.start = gui.add_button("Start search", icon=viser.Icon.SEARCH, color="blue",
                                    hint="Capture, choose the next viewpoint, go there, repeat until it is found")
        self.approve = gui.add_button("Approve step", icon=viser.Icon.CHECK, visible=False)
        self.pause = gui.add_button("Pause search", icon=viser.Icon.PLAYER_PAUSE, visible=False,
                                    hint="End the move where the robot is (it holds); Hold, Land here and Return then "
                                         "act; Resume plans again from there")
        self.resume = gui.add_button("Resume search", icon=viser.Icon.PLAYER_PLAY, visible=False)
        self.stop = gui.add_button("Stop search", icon=viser.Icon.PLAYER_STOP, visible=False)
        self.line = gui.add_markdown("")
        self.start.on_click(lambda e: self._act(e, self._start))
        self.approve.on_click(lambda e: self._act(e, job.approve))
        self.pause.on_click(lambda e: self._act(e, job.pause))
        self.resume.on_click(lambda e: self._act(e, job.resume))
        self.stop.on_click(lambda e: self._act(e, job.stop))
        self._marker: Any = None
        self._fallback: list[Any] = []  # the label's server-wide handles, only without a declutter
        self._drawn: Any = None
        self._refresher = Refresher(self._refresh, "search-view")
        session.subscribe(self._on_event)
        self.refresh()

    def _start(self) -> None:
        """Start the search the fields ask for; every field is checked first, as ``morphonavi search`` checks
        its options (:func:`~console.session.search_inputs.search_config`: same rules, same words)."""
        self._job.start(search_config(PANEL_NAMES, self.target.value, mode=self.mode.value,
                                      max_captures=self.captures.value, max_time=self.minutes.value,
                                      battery_reserve=self.reserve.value, height_of=self._height_of))

    def _act(self, event: Any, action: Callable[[], Any]) -> None:
        try:
            action()
        except SessionError as exc:
            tell(event.client, "Not possible", str(exc), "yellow", 7.0, about="find")  # a long one: its summary
        self.refresh()

    def _on_event(self, topic: str, payload: Any) -> None:
        if topic in (JOB, RUN, SEARCH):
            self._refresher.poke()  # never block the session's caller; the last redraw shows the latest state

    def drawn_viewpoint(self) -> Any:
        """The viewpoint drawn now (tests), or ``None``."""
        return self._drawn

    def refresh(self) -> None:
        """Buttons, the step line and the viewpoint marker as the search's state allows."""
        self._refresher.now()

    def _refresh(self) -> None:
        job = self._job
        running, paused = job.running, job.paused
        _put(self.start, "disabled", running or self._session.run.active)
        _put(self.approve, "visible", running and job.waiting_approval)
        _put(self.pause, "visible", running and not paused)
        _put(self.resume, "visible", running and paused)
        _put(self.stop, "visible", running)
        steps = job.steps
        r = job.result
        if r is not None and not running and r.reason:
            line = html.escape(result_line(r))  # the end notice's words
            text = f"<b>{line}</b>" if r.found else f"<b>ended</b>: {line}"
            if r.left_unseen:
                text += f"<br>left unseen: {html.escape(r.left_unseen)}"
        elif paused:
            text = f"<b>paused</b> ({html.escape(job.pause_reason)}): Hold, Land here and Return act on the robot; " \
                   "Resume plans again from where it is"
        else:
            text = html.escape(steps[-1]) if steps else ""
        _put(self.line, "content", f"<small>{text}</small>")
        vp = job.chosen if running else None
        if vp is not self._drawn:
            self._drawn = vp
            for h in [self._marker, *self._fallback]:
                if h is not None:
                    try:
                        h.remove()
                    except Exception:
                        pass
            self._marker, self._fallback = None, []
            if vp is not None:
                e = np.asarray(vp.eye, dtype=np.float32)
                tip = e + 0.6 * np.array([np.cos(vp.yaw), np.sin(vp.yaw), 0.0], dtype=np.float32)
                self._marker = self._server.scene.add_line_segments(
                    "/search/viewpoint", points=np.array([[e, tip]], dtype=np.float32),
                    colors=(255, 140, 0), thickness=0.04)
            self._show_label(vp)

    def _show_label(self, vp: Any) -> None:
        """The viewpoint's label (``None``: none), in every tab's declutter (server-wide only without one:
        :func:`~console.views.object_labels.show_in_layer`)."""
        spots = [] if vp is None else [LabelSpot(f"next viewpoint: gain {vp.gain:.1f} m³, cost {vp.cost:.1f}",
                                                 tuple(float(v) for v in vp.eye), (), "top-left")]
        self._fallback = show_in_layer(self._server, "search", spots, "/search/viewpoint_why")
