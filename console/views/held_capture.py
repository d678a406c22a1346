"""The operator's answer to a held-back capture: Merge / Replace / Discard buttons in the Map folder.

A capture whose objects disagree with the map everywhere (another room, a wrong robot pose) is held
back by the Capture & map job (:meth:`console.session.mapping_job.MappingJob.resolve_held`); these buttons
show only while one is held and call that method. The view holds no state of its own.
"""

from __future__ import annotations

from typing import Any

import viser

from console.views.client_notice import tell
from console.session.mapping_job import MappingJob
from console.session.session import JOB, Session, SessionError

ACTIONS = ("Merge", "Replace", "Discard")


class HeldCaptureControls:
    """The button group, visible while :attr:`MappingJob.held` names a capture.

    Args:
        server: The viser server (the buttons go into the current GUI folder).
        session: Announces the job's changes (topic ``job``).
        job: The Capture & map job holding the capture.
    """

    def __init__(self, server: viser.ViserServer, session: Session, job: MappingJob) -> None:
        self._job = job
        self.buttons = server.gui.add_button_group(
            "Held capture", ACTIONS, visible=False,
            hint="The last capture disagrees with the map: Merge it anyway, Replace the map's objects "
                 "(pinned ones stay) with it, or Discard it")
        self.buttons.on_click(self._on_click)
        session.subscribe(lambda topic, _payload: self.refresh() if topic == JOB else None)

    def refresh(self) -> None:
        """Show the buttons while a capture is held back."""
        self.buttons.visible = self._job.held is not None

    def choose(self, action: str, client: Any = None) -> str | None:
        """Carry out ``Merge`` / ``Replace`` / ``Discard``; tells ``client`` the outcome or the refusal."""
        try:
            done = self._job.resolve_held(action.lower())
        except SessionError as exc:
            tell(client, "Held capture", str(exc), "yellow")
            self.refresh()
            return None
        tell(client, "Held capture", done, "green")
        self.refresh()
        return done

    def _on_click(self, event: Any) -> None:
        self.choose(str(event.target.value), event.client)
