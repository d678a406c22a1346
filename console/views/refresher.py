"""A view's redraw on its own thread, coalesced and in order.

A session event may arrive on any thread (the mission runner, a search, the link), and the caller must never
wait for a redraw. Starting one thread per event lets an older redraw, which read the state before a newer one,
write its buttons *after* it: a button made visible by the newer state is hidden again until the next event.
:class:`Refresher` runs the redraw on one worker: :meth:`poke` marks it due and returns at once; the worker
reads the state afresh each time, so the last redraw always shows the latest state, and a burst of events
costs one redraw.
"""

from __future__ import annotations

import logging
import threading
from typing import Callable

log = logging.getLogger(__name__)


class Refresher:
    """Run ``draw`` on a daemon worker whenever :meth:`poke` was called since its last run.

    ``draw`` is also serialised with direct calls made through :meth:`now` (a click handler that wants the
    buttons right away), so two redraws never interleave their writes.
    """

    def __init__(self, draw: Callable[[], None], name: str) -> None:
        self._draw = draw
        self._due = threading.Event()
        self._lock = threading.Lock()
        self._closed = False
        self._thread = threading.Thread(target=self._run, name=name, daemon=True)
        self._thread.start()

    def poke(self) -> None:
        """Mark a redraw due (returns at once; never blocks the caller)."""
        self._due.set()

    def now(self) -> None:
        """Redraw on the calling thread, serialised with the worker's redraws."""
        with self._lock:
            self._draw()

    def close(self) -> None:
        """Stop the worker (a pending redraw is dropped)."""
        self._closed = True
        self._due.set()

    def _run(self) -> None:
        while True:
            self._due.wait()
            if self._closed:
                return
            self._due.clear()  # cleared before drawing: an event during the draw causes one more
            try:
                self.now()
            except Exception:  # a redraw failing must not end the panel's updates
                log.exception("redraw failed")
