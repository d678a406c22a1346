"""The Agent panel: what a language-model agent proposes and why, with Approve / Reject, in every tab.

It draws the agent door's approval queue (:class:`console.mcp.proposals.ProposalQueue`): the oldest
waiting proposal (what it would do, the agent's reason in its own words, the mission's segments),
how many more wait, and the last decisions. **Approve** carries the proposal out (off the UI
thread: e.g. the mission manager starts the proposed mission), **Reject** refuses it; the optional
note goes back to the agent with the decision. The panel sits at the top of the control panel and
shows itself at the agent's first request; a candidate path the agent planned is labelled
*proposed by the agent* at its goal in the 3D view. That label is drawn per tab through the label declutter
(:mod:`console.views.object_labels`, layer ``agent``): it never sits on the robot's label (which wins) nor on
another label.
"""

from __future__ import annotations

import html
import logging
import threading
from typing import Any

import viser

from console.views.client_notice import tell
from console.views.object_labels import LabelSpot, board_for, show_in_layer
from console.session.session import ROUTE, Session

log = logging.getLogger(__name__)

LABEL_NODE = "/agent/candidate_label"
"""The label's server-wide node, used only on a server without a label declutter."""
AGENT_LABEL = "proposed by the agent"
LABEL_LIFT_M = 0.6
"""Height of the label's anchor (its bottom centre) above the agent's goal [m]."""
HISTORY_SHOWN = 3


def proposal_html(p: Any, more: int) -> str:
    """The waiting proposal for the panel: title, the agent's reason, the details (Markdown table)."""
    why = html.escape(p.why) if p.why else "<i>(no reason given)</i>"
    extra = f"<br><small>{more} more proposal{'s' if more != 1 else ''} waiting</small>" if more else ""
    return (f"<div style='border-left:3px solid #e8590c;padding-left:6px'><small>The agent proposes "
            f"(<code>{html.escape(p.id)}</code>):</small><br><b>{html.escape(p.title)}</b><br>"
            f"<small>Why (the agent's words): {why}</small></div>{extra}")


def history_html(decided: list[Any]) -> str:
    if not decided:
        return ""
    rows = [f"<code>{html.escape(p.id)}</code> {html.escape(p.state)}: {html.escape(p.outcome[:160])}"
            for p in decided[-HISTORY_SHOWN:][::-1]]
    return "<small>" + "<br>".join(rows) + "</small>"


class ApprovalView:
    """The Agent folder (see the module docstring).

    Args:
        server: The viser server.
        session: The state (the candidate path, for the label).
        door: The agent door (:class:`console.mcp.door.AgentDoor`): its ``queue`` and ``agent_goal``.
    """

    def __init__(self, server: viser.ViserServer, session: Session, door: Any) -> None:
        self._server, self._session, self._door = server, session, door
        self._lock = threading.Lock()
        self._shown_id: str | None = None
        gui = server.gui
        self.folder = gui.add_folder("Agent", order=-1.0, visible=False)  # top of the panel, from the agent's first request
        with self.folder:
            self._intro = gui.add_markdown("<small>A language-model agent is connected through MCP. It reads the map "
                                           "and proposes; nothing moves until you approve.</small>")
            self._proposal = gui.add_html("")
            self._details = gui.add_markdown("", visible=False)
            self._note = gui.add_text("Note to the agent", "", hint="Optional: sent back with your decision",
                                      visible=False)
            self._approve = gui.add_button("Approve", color="green", icon=viser.Icon.CHECK, visible=False,
                                           hint="Carry out what the agent proposes")
            self._reject = gui.add_button("Reject", color="red", icon=viser.Icon.X, visible=False,
                                          hint="Refuse it; the agent is told")
            self._history = gui.add_html("")
        self._approve.on_click(lambda e: self._decide(e, True))
        self._reject.on_click(lambda e: self._decide(e, False))
        self._spots: list[LabelSpot] = []  # the label placed now (in the declutter), [] or one
        self._fallback: list[Any] = []  # its server-wide nodes (a server without a label declutter)
        self._unsubscribe = [door.queue.subscribe(lambda *_: self.refresh()),
                             session.subscribe(self._on_event)]
        self.refresh()

    @property
    def note_text(self) -> str:
        """The note typed for the agent, as the server has it."""
        return str(self._note.value)

    @property
    def labelled(self) -> bool:
        """Whether the 3D view labels a candidate as proposed by the agent (each tab shows it where it overlaps
        no label that wins: the robot's)."""
        return bool(self._spots)

    @property
    def label_spots(self) -> list[LabelSpot]:
        """The label placed now, ``[]`` or one: text and anchor (world [m], bottom centre)."""
        return list(self._spots)

    def close(self) -> None:
        for u in self._unsubscribe:
            u()
        self._unsubscribe = []

    def _on_event(self, topic: str, _payload: Any) -> None:
        if topic == ROUTE:
            self._draw_label()
        elif topic == "agent":
            self.folder.visible = True

    # --- drawing ---------------------------------------------------------------------------------
    def refresh(self) -> None:
        """Redraw the waiting proposal, the buttons and the history from the queue."""
        with self._lock:
            queue = self._door.queue
            pending, decided = queue.pending(), queue.decided()
            if pending or decided:
                self.folder.visible = True
            first = pending[0] if pending else None
            self._shown_id = first.id if first is not None else None
            if first is None:
                self._proposal.content = "<small>No proposal waiting.</small>"
                self._details.visible = False
            else:
                self._proposal.content = proposal_html(first, len(pending) - 1)
                self._details.content = first.details
                self._details.visible = bool(first.details)
            for widget in (self._approve, self._reject, self._note):
                widget.visible = first is not None
            self._approve.disabled = self._reject.disabled = first is None
            self._history.content = history_html(decided)
        self._draw_label()

    def _draw_label(self) -> None:
        """Label the goal the agent planned while it is the candidate's or the registered route's last goal."""
        snap = self._session.route_snapshot()
        mine = self._door.agent_goal
        near = self._session.workspace.resolution / 2 + 1e-6  # a registered goal is its cell's centre [m]
        goal = next((g for g in (snap.candidate_goal, snap.goals[-1] if snap.goals else None)
                     if g is not None and mine is not None and max(abs(a - b) for a, b in zip(g, mine)) < near), None)
        spots = [] if goal is None else [LabelSpot(AGENT_LABEL, (float(goal[0]), float(goal[1]),
                                                                 float(goal[2]) + LABEL_LIFT_M), (), "bottom-center")]
        with self._lock:
            if spots == self._spots and (not spots or (board_for(self._server) is not None) == (not self._fallback)):
                return  # unchanged, and drawn where it belongs (a declutter made since: moved into it)
            for h in self._fallback:
                try:
                    h.remove()
                except Exception:  # noqa: BLE001 - already gone with the scene
                    pass
            self._spots = spots
            self._fallback = show_in_layer(self._server, "agent", spots, LABEL_NODE)

    # --- clicks -----------------------------------------------------------------------------------
    def _decide(self, event: Any, approve: bool) -> None:
        pid = self._shown_id
        if pid is None:
            return
        note = str(self._note.value).strip()[:500]
        self._note.value = ""
        self._approve.disabled = self._reject.disabled = True  # one decision per click, in every tab
        threading.Thread(target=self._carry_out, args=(event.client, pid, approve, note), name="agent-decision",
                         daemon=True).start()

    def _carry_out(self, client: Any, pid: str, approve: bool, note: str) -> None:
        from console.mcp.proposals import ProposalError

        queue = self._door.queue
        try:
            p = queue.approve(pid, note) if approve else queue.reject(pid, note)
        except ProposalError as exc:
            tell(client, "Not decided", str(exc), "yellow")
            self.refresh()
            return
        color = {"approved": "green", "rejected": "gray", "failed": "red"}.get(p.state, "blue")
        tell(client, f"Proposal {p.state}", p.outcome, color)


__all__ = ["AGENT_LABEL", "ApprovalView", "history_html", "proposal_html"]
