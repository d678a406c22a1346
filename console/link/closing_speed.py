"""One rule for motion time-outs that follow the speed the robot really moves at.

A deadline computed from the speeds the console *commanded* is wrong for a vehicle that moves at its own,
slower speed (a refused or lost ``MAV_CMD_DO_CHANGE_SPEED``, a firmware limit): when it passes while the
robot is still closing in, the deadline moves to the time the rest takes at the *measured* closing speed::

    new deadline = now + remaining / closing x max(factor, 1) + slack

with ``closing`` the decrease of the remaining distance over the last ``PROGRESS_WINDOW`` seconds (at
least half a window of samples). Below ``MIN_CLOSING_SPEED`` the robot counts as stopped and the
deadline stands. The MAVLink link's own motion time-outs and the mission manager's segment watchdog both
use this rule, so they agree on what "still closing in" means.

Distances [m], speeds [m/s], times [s] (``time.monotonic``).
"""

from __future__ import annotations

from collections import deque

PROGRESS_WINDOW = 2.0
"""Window [s] over which the measured closing speed is taken."""

MIN_CLOSING_SPEED = 0.05
"""Below this closing speed [m/s] a robot past its time-out counts as not progressing."""


class ClosingTrack:
    """The remaining distance over the last :data:`PROGRESS_WINDOW` seconds, and the deadline rule."""

    def __init__(self, window: float = PROGRESS_WINDOW) -> None:
        if not window > 0:
            raise ValueError(f"window must be > 0 s, got {window}")
        self.window = window
        self._track: deque[tuple[float, float]] = deque()  # (monotonic [s], remaining [m])

    def add(self, now: float, remaining: float) -> None:
        """One sample: ``remaining`` [m] to go at ``now`` [s]."""
        self._track.append((now, remaining))
        while len(self._track) > 2 and now - self._track[1][0] >= self.window:
            self._track.popleft()

    def closing_speed(self) -> float | None:
        """Decrease of the remaining distance [m/s] over the window, or None (under half a window)."""
        if len(self._track) < 2 or self._track[-1][0] - self._track[0][0] < 0.5 * self.window:
            return None
        (t0, d0), (t1, d1) = self._track[0], self._track[-1]
        return (d0 - d1) / (t1 - t0)

    def later_deadline(self, now: float, factor: float, slack: float) -> tuple[float, float] | None:
        """``(new deadline [s], closing speed [m/s])`` while the robot still closes in, else None."""
        closing = self.closing_speed()
        if closing is None or closing < MIN_CLOSING_SPEED:
            return None
        remaining = self._track[-1][1]
        return now + remaining / closing * max(factor, 1.0) + slack, closing


__all__ = ["ClosingTrack", "MIN_CLOSING_SPEED", "PROGRESS_WINDOW"]
