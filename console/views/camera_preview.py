"""Low-rate live preview of a live camera (``--camera``) in the camera panel.

The view only draws: a daemon thread copies the source's :meth:`CameraSource.preview` (<= 320 px
wide, refreshed at most every 0.5 s by the source) and its status line into two GUI handles every
``interval`` seconds. Without a live camera (simulator renders, a photo folder) there is no preview.
"""

from __future__ import annotations

import html
import logging
import threading
from typing import Any, Callable

import numpy as np

log = logging.getLogger(__name__)


def live_source(link: Any) -> Any | None:
    """The live camera behind a robot link (the simulator's photo source or a MAVLink link's
    camera callable) when it has a preview, else ``None``."""
    for candidate in (getattr(link, "captures", None), getattr(link, "camera", None)):
        if candidate is not None and callable(getattr(candidate, "preview", None)):
            return candidate
    return None


class LivePreview:
    """Copies ``source.preview()`` into ``image_handle.image`` and ``source.status`` into
    ``status_handle.content`` every ``interval`` [s] until :meth:`close`."""

    def __init__(self, source: Any, image_handle: Any, status_handle: Any, interval: float = 0.5) -> None:
        self.source = source
        self._image = image_handle
        self._status = status_handle
        self._interval = float(interval)
        self._stop = threading.Event()
        self._shown: np.ndarray | None = None
        self._thread = threading.Thread(target=self._run, name="camera preview", daemon=True)
        self._thread.start()

    def _run(self) -> None:
        while not self._stop.wait(self._interval):
            try:
                frame = self.source.preview()
                if frame is not None and frame is not self._shown:
                    self._image.image = frame
                    self._shown = frame
                self._status.content = f"<small>live camera: {html.escape(str(self.source.status))}</small>"
            except Exception:  # noqa: BLE001 - a closed GUI or source ends the preview, never the console
                if not self._stop.is_set():
                    log.exception("live camera preview stopped")
                return

    def close(self) -> None:
        self._stop.set()
        self._thread.join(timeout=2.0)


def live_preview(server: Any, link: Any, interval: float = 0.5,
                 notify: Callable[[str, str, str], None] | None = None) -> LivePreview | None:
    """Add the live preview to the current GUI container when ``link`` has a live camera.

    ``notify(title, body, level)`` (the session's) is told when the stream is lost or back.
    """
    source = live_source(link)
    if source is None:
        return None
    if notify is not None and getattr(source, "on_notice", None) is None:
        source.on_notice = lambda text: notify("Live camera", text, "warning" if "lost" in text else "info")
    from console.views.capture_view import placeholder

    status = server.gui.add_markdown("<small>live camera: connecting</small>")
    image = server.gui.add_image(placeholder("waiting for the live camera"), label="Live camera", format="jpeg")
    return LivePreview(source, image, status, interval)


__all__ = ["LivePreview", "live_preview", "live_source"]
