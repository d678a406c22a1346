"""The Session panel: where the session is saved, named snapshots (Save as, Load, Delete) and the
saved list. Overwriting a snapshot and deleting one ask first (:mod:`console.views.confirm`).

The session does the work and the checks (:class:`console.session.session_store.Persistence`); this
view only turns clicks into calls and shows what they say.
"""

from __future__ import annotations

import html
from typing import Any, Callable

import viser

from console.session.session import Session, SessionError
from console.session.session_store import ConfirmNeeded
from console.views.client_notice import tell
from console.views.confirm import ask


class SessionFilesView:
    """Folder and save status, the snapshot name, Save as / Load / Delete, the saved list.

    Args:
        server: The viser server (the controls go into the current GUI container).
        session: The session whose files these are.
    """

    def __init__(self, server: viser.ViserServer, session: Session) -> None:
        self._session = session
        gui = server.gui
        gui.add_markdown(f"<small>Folder: <code>{html.escape(str(session.folder))}</code></small>")
        self._status = gui.add_markdown("")
        self.show_status()
        self.name = gui.add_text("Name", "snapshot", hint="A file name inside the session folder (.json is added)")
        self._save = gui.add_button("Save as", icon=viser.Icon.DEVICE_FLOPPY,
                                    hint="Save the session under the name above (asks before saving over a snapshot)")
        self._load = gui.add_button("Load", icon=viser.Icon.FOLDER_OPEN, hint="Load the snapshot named above (Undo brings the map back)")
        self._delete = gui.add_button("Delete snapshot", icon=viser.Icon.TRASH, color="red",
                                      hint="Delete the snapshot named above from the session folder (asks first)")
        self._listing = gui.add_markdown("")
        self._save.on_click(lambda e: self.save_as(e.client, str(self.name.value)))
        self._load.on_click(lambda e: self.load(e.client, str(self.name.value)))
        self._delete.on_click(lambda e: self.delete(e.client, str(self.name.value)))
        self.refresh()

    def show_status(self) -> None:
        """Saving works or not, what the restore left out (:meth:`Session.status_text`)."""
        text, warn = self._session.status_text()
        style = ' style="color:#d62728"' if warn else ""
        self._status.content = f"<small{style}>{html.escape(text)}</small>"

    def refresh(self) -> None:
        saves = self._session.list_saves()
        self._listing.content = ("<small>saved: " + ", ".join(f"<code>{html.escape(s)}</code>" for s in saves[:12])
                                 + "</small>") if saves else ""

    def save_as(self, client: Any, name: str, overwrite: bool = False) -> None:
        """Save as ``name``; over an existing snapshot only once the operator said so."""
        self._run(client, "Not saved", lambda: self._session.save(name, overwrite=overwrite),
                  lambda path: tell(client, "Saved", f"{path.name} in the session folder", "green"),
                  lambda: self.save_as(client, name, overwrite=True))

    def load(self, client: Any, name: str) -> None:
        self._run(client, "Not loaded", lambda: self._session.load(name),
                  lambda notes: tell(client, "Loaded", "; ".join(notes) or name, "green"), None)

    def delete(self, client: Any, name: str, confirmed: bool = False) -> None:
        """Delete the snapshot ``name`` once the operator confirmed."""
        self._run(client, "Not deleted", lambda: self._session.delete_save(name, confirmed=confirmed),
                  lambda file: tell(client, "Deleted", f"{file} was removed from the session folder", "blue"),
                  lambda: self.delete(client, name, confirmed=True))

    def _run(self, client: Any, failed: str, action: Callable[[], Any], done: Callable[[Any], None],
             again: Callable[[], None] | None) -> None:
        try:
            result = action()
        except ConfirmNeeded as ask_first:
            if again is not None and client is not None:
                ask(client, ask_first.question, ask_first.detail, ask_first.confirm, again)
            return
        except SessionError as exc:
            tell(client, failed, str(exc), "red")
            return
        done(result)
        self.refresh()
