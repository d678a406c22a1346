"""Which of the robot's status messages the robot panel still shows: current news, not old errors.

The link keeps the robot's latest status messages (``(number, "SEVERITY: text")``, numbered since
the link opened). The panel showed the last few forever, so "ERROR: walk refused" stayed in red
after later missions succeeded. :class:`MessageShelf` shows a message only while it is news:

- for :data:`MESSAGE_SECONDS` after the panel first saw it, and
- until a mission (or vehicle command) ends ``done`` after it: a later success is newer news about
  what the robot is doing, so the older messages are cleared (they stay in the log and the recording).

A link that restarts its numbering (reconnect) is noticed: numbers below the cleared mark start over.
Times are ``time.monotonic()`` seconds.
"""

from __future__ import annotations

import threading
import time
from typing import Callable, Sequence

MESSAGE_SECONDS = 60.0
"""How long [s] a robot message stays in the panel after it first appeared."""


class MessageShelf:
    """Filters the robot's messages down to the current ones (see the module docstring).

    Args:
        keep: Seconds a message is shown after it first appeared [s], > 0.
        clock: The time source (``time.monotonic``; tests pass their own).
    """

    def __init__(self, keep: float = MESSAGE_SECONDS, clock: Callable[[], float] = time.monotonic) -> None:
        if not keep > 0:
            raise ValueError(f"keep: must be > 0 s, got {keep!r}")
        self.keep = float(keep)
        self._clock = clock
        self._lock = threading.Lock()
        self._seen: dict[int, float] = {}
        self._cleared = 0  # messages numbered up to this are old news
        self._newest = 0

    def current(self, messages: Sequence[tuple[int, str]]) -> tuple[tuple[int, str], ...]:
        """The messages still news now, oldest first."""
        now = self._clock()
        with self._lock:
            if messages and max(n for n, _ in messages) < self._cleared:  # the link started counting again
                self._cleared, self._seen = 0, {}
            for n, _ in messages:
                self._seen.setdefault(n, now)
                self._newest = max(self._newest, n)
            live = {n for n, _ in messages}
            self._seen = {n: t for n, t in self._seen.items() if n in live}
            return tuple((n, t) for n, t in messages if n > self._cleared and now - self._seen[n] <= self.keep)

    def clear(self) -> None:
        """A later success: every message seen so far is old news."""
        with self._lock:
            self._cleared = max(self._cleared, self._newest)


__all__ = ["MESSAGE_SECONDS", "MessageShelf"]
