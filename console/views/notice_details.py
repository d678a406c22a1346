"""The whole text of the notices shown shortened, one click away: the *Notices: full text* expander.

A pop-up notice is kept short (:func:`console.views.client_notice.short_body`: a capture's "26 objects seen (2
new, 21 updated) in 4.1 s … (full text: Notices, under Capture & map)"), so it never spreads over the 3D view.
Its whole text (each object not used and why, the camera-pose warnings, ...) goes here: a folder under the
**Capture & map** button, closed, hidden until the first long notice; one click opens it. It lists the last
:data:`KEPT` long notices, newest first, each with its time and its parts ("; "-separated) one a line.
"""

from __future__ import annotations

import html
import threading
import time
from collections import deque
from typing import Any

from console.views.client_notice import on_long_notice

KEPT = 6
"""How many long notices the expander keeps (the oldest dropped first)."""

FOLDER = "Notices: full text"
"""The expander's label."""


def details_html(entries: Any) -> str:
    """The expander's text (HTML): ``(time text, title, body)`` entries, newest first, each part a line."""
    out = []
    for stamp, title, body in entries:
        parts = "".join(f"<li>{html.escape(p.strip())}</li>" for p in str(body).split("; ") if p.strip())
        out.append(f"<b>{html.escape(title)}</b> <span style='color:#777'>{html.escape(stamp)}</span>"
                   f"<ul style='margin:0.1em 0 0.5em 0; padding-left:1.2em'>{parts}</ul>")
    return "<small>" + "".join(out) + "</small>"


class NoticeDetails:
    """The expander; add it where it should sit in the panel (inside the Map folder, under Capture & map)."""

    def __init__(self, server: Any) -> None:
        self._lock = threading.Lock()
        self._entries: deque[tuple[str, str, str]] = deque(maxlen=KEPT)
        with server.gui.add_folder(FOLDER, expand_by_default=False, visible=False) as folder:
            self._folder = folder
            self._text = server.gui.add_html("")
        on_long_notice(server, self.add)

    def add(self, title: str, body: str) -> None:
        """Put a long notice's whole text at the top of the expander (and show the expander)."""
        with self._lock:
            self._entries.appendleft((time.strftime("%H:%M:%S"), str(title), str(body)))
            self._text.content = details_html(self._entries)
            if not self._folder.visible:
                self._folder.visible = True

    @property
    def text(self) -> str:
        """The expander's text as shown (HTML; tests)."""
        with self._lock:
            return str(self._text.content)


__all__ = ["FOLDER", "KEPT", "NoticeDetails", "details_html"]
