"""Ask before an action that cannot be taken back: a modal in the clicking tab with the question,
what confirming does, and two buttons (the action, and Cancel).

Used with :class:`console.session.session_store.ConfirmNeeded`: the session refuses the action until
it is called again with its confirming flag, and this modal is how the operator gives it.
"""

from __future__ import annotations

import html
from typing import Any, Callable

import viser

ABOVE_NOTICES = ("<style>.mantine-Modal-overlay, .mantine-Modal-inner { z-index: 10000 !important; }</style>")
"""The question stays above the notices stacked over the 3D view (they would cover its buttons)."""


def ask(client: Any, question: str, detail: str, confirm: str, on_confirm: Callable[[], None],
        color: str = "red") -> Any:
    """Show ``question`` (the modal's title) and ``detail`` to ``client``; ``on_confirm`` runs (on the
    GUI thread pool) when the operator presses ``confirm``; Cancel just closes. Returns the modal."""
    with client.gui.add_modal(question) as modal:
        client.gui.add_html(ABOVE_NOTICES)
        client.gui.add_markdown(html.escape(detail))
        yes = client.gui.add_button(confirm, color=color, icon=viser.Icon.CHECK)
        no = client.gui.add_button("Cancel", icon=viser.Icon.X)

    def decide(agreed: bool) -> None:
        modal.close()
        if agreed:
            on_confirm()

    yes.on_click(lambda _e: decide(True))
    no.on_click(lambda _e: decide(False))
    return modal
