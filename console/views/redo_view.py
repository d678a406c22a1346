"""Redo beside Undo, and the keyboard: Ctrl+Z undoes, Ctrl+Shift+Z redoes (Cmd on a Mac).

The Undo button sits in the objects panel (:class:`console.views.objects_view.ObjectsView` makes it);
this view owns its label, state and click as it owns Redo's. The Redo button is placed right after it (viser orders a container's elements by ``order``), and both
keys are viser commands (also listed in its command palette, Ctrl+K). The session does the work
(:meth:`console.session.session.Session.undo_edit` / ``redo_edit``). Both buttons say what they would do
(``Undo move box-3``, ``Redo move box-3``) and are off when there is nothing to do; they are set when the
view is built too, so a session restored at start-up (its ``history.json`` read back before the page
existed) shows its Undo and Redo at once.
"""

from __future__ import annotations

from typing import Any

import viser

from console.session import look_rules
from console.session.session import CAPTURE, MISSION, ROUTE, SCENE, Session, SessionError
from console.views.client_notice import tell
from console.views.page_a11y import hint_spans

LABEL_CHARS = 40
"""The button's label is cut to this many characters (the panel's width)."""


class RedoView:
    """The Redo button (after ``undo_button`` when given) and the Undo / Redo keys.

    Args:
        server: The viser server (the button goes into the current GUI container).
        session: The session whose edits are undone and redone.
        undo_button: The Undo button to sit beside (its ``order``), or ``None`` (next in the container).
    """

    def __init__(self, server: viser.ViserServer, session: Session, undo_button: Any = None) -> None:
        self._session = session
        self._undo_button = undo_button
        order = getattr(undo_button, "order", None)
        self.button = server.gui.add_button(
            "Redo", icon=viser.Icon.ARROW_FORWARD_UP, color="gray", disabled=True,
            hint=look_rules.DOES["redo"],
            order=None if order is None else float(order) + 0.5)
        self.button.on_click(lambda e: self.redo(e.client))
        self._keys = [
            server.gui.add_command("Undo map edit", description="Undo the last spawn, move, delete, capture or load",
                                   hotkey="Z", modifier="cmd/ctrl", icon=viser.Icon.ARROW_BACK_UP),
            server.gui.add_command("Redo map edit", description="Put back the edit Undo took away",
                                   hotkey="Z", modifier="cmd/ctrl+shift", icon=viser.Icon.ARROW_FORWARD_UP),
        ]
        if undo_button is not None:
            undo_button.on_click(lambda e: self.undo(e.client))
        self._keys[0].on_trigger(lambda e: self.undo(e.client))
        self._keys[1].on_trigger(lambda e: self.redo(e.client))
        self._hints = server.gui.add_html("")  # Undo / Redo hover text, shown by the page script (page_a11y)
        session.subscribe(self._on_event)
        self.sync()

    def sync(self) -> None:
        """Show what Undo would take away and Redo would put back, or turn each off (why: on hover)."""
        hints = []
        if self._undo_button is not None:
            hints.append(_show(self._undo_button, "Undo", self._session.undo_label))
        hints.append(_show(self.button, "Redo", self._session.redo_label))
        spans = hint_spans(hints)
        if self._hints.content != spans:
            self._hints.content = spans

    def undo(self, client: Any) -> None:
        try:
            tell(client, "Undone", self._session.undo_edit().removeprefix("undone: "), "blue")
        except SessionError as exc:
            tell(client, "Cannot undo", str(exc), "red")

    def redo(self, client: Any) -> None:
        try:
            tell(client, "Redone", self._session.redo_edit().removeprefix("redone: "), "blue")
        except SessionError as exc:
            tell(client, "Cannot redo", str(exc), "red")

    def _on_event(self, topic: str, _payload: Any) -> None:
        if topic in (SCENE, CAPTURE, ROUTE, MISSION):
            self.sync()


def _show(button: Any, verb: str, what: str | None) -> tuple[Any, str]:
    """``verb`` and what it acts on (``Undo move box-3``, cut to :data:`LABEL_CHARS`), off when there is nothing;
    returns the button and its hover text (:func:`console.session.look_rules.hover`)."""
    label = verb if what is None else f"{verb} {what}"[:LABEL_CHARS]
    if button.label != label:
        button.label = label
    if button.disabled != (what is None):
        button.disabled = what is None
    name = verb.lower()
    hint = look_rules.hover(name, look_rules.history(what, name))
    if what is not None:
        hint = f"{hint} · {verb} {what}"  # the label may be cut: the whole of it
    if button.hint != hint:
        button.hint = hint
    return button, hint
