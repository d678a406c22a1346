"""How long the battery lasts in the air: the charge's measured drain rate and the time left to land.

The console already has the battery rules (:mod:`console.session.operator_state`): below
:data:`~console.session.operator_state.BATTERY_CRITICAL` a robot in the air is landed where it is. While
the robot is in the air, :class:`DrainRate` fits a straight line (least squares, numpy) to the charge
reports of the last :data:`WINDOW` seconds in the air, and :func:`time_left` is the time until the charge
reaches the critical level at that rate: the time the operator has to land or Return before the console
lands the robot by itself. A multirotor draws about the same power hovering as flying slowly, so the
flight's own samples measure the hover drain.

When the drain changes in the air (a climb, a gust, a heavier payload, a simulator run faster), a line
through 120 s of reports would average the old drain with the new one for up to two minutes: at a drain
tripled 20 s ago it still gave about three times the time there is. So when a report lies more than
:data:`CHANGE` off the fitted line (more than one whole-percent step of a MAVLink battery report, which a
steady drain never does), the reports are split where two lines fit them best (least squares over every
split) and those before the change are dropped (the last :data:`MIN_SPAN` seconds are always kept): the
estimate follows the new drain within seconds.

An estimate needs :data:`MIN_SPAN` seconds of samples in the air and a falling charge; until then (and
with an unknown charge) there is none, and the panel says the drain is being measured. Times are the
link's report stamps [s]; charges are fractions in [0, 1].
"""

from __future__ import annotations

import math
import threading
from collections import deque

import numpy as np

from console.session.operator_state import BATTERY_CRITICAL

WINDOW = 120.0
"""How far back [s] the drain rate looks (charge reports in the air only)."""
MIN_SPAN = 8.0
"""Seconds [s] of charge reports in the air needed before an estimate is given."""
STEP = 0.5
"""Reports closer than this [s] to the last one kept are skipped (the link reports at tens of Hz)."""
MAX_SAMPLES = 1000
"""At most this many reports are kept."""
MIN_RATE = 1e-5
"""A drain below this [1/s] (full to empty in more than a day) is no drain: no time is given."""
CHANGE = 0.015
"""A report this far [charge fraction] from the fitted line means the drain changed: the older reports go.
More than a whole-percent step (MAVLink's ``battery_remaining``), so a steady drain keeps its window."""


class DrainRate:
    """The charge's drain rate [1/s] in the air, from the robot's reports (thread-safe)."""

    def __init__(self, window: float = WINDOW, min_span: float = MIN_SPAN) -> None:
        if not (math.isfinite(window) and window > 0):
            raise ValueError(f"window: must be a finite number of seconds > 0, got {window!r}")
        if not (math.isfinite(min_span) and 0 < min_span <= window):
            raise ValueError(f"min_span: must be within 0..window ({window} s), got {min_span!r}")
        self.window, self.min_span = float(window), float(min_span)
        self._samples: deque[tuple[float, float]] = deque(maxlen=MAX_SAMPLES)
        self._lock = threading.Lock()

    def add(self, stamp: float, charge: float | None, airborne: bool) -> None:
        """One report: its time [s], charge [0..1] or ``None``, and whether the robot is in the air.

        On the ground the samples are dropped (a landing, a recharge or a battery swap starts over);
        unknown or non-finite values are ignored."""
        with self._lock:
            if not airborne:
                self._samples.clear()
                return
            if charge is None or not isinstance(charge, (int, float)) or not math.isfinite(charge) \
                    or not math.isfinite(stamp):
                return
            if self._samples and stamp < self._samples[-1][0] + STEP:
                return  # a repeat, an older report, or one too close to the last kept
            if self._samples and charge > self._samples[-1][1] + 0.05:
                self._samples.clear()  # the charge jumped up: another battery, start over
            self._samples.append((float(stamp), float(charge)))
            while self._samples and self._samples[-1][0] - self._samples[0][0] > self.window:
                self._samples.popleft()

    def rate(self) -> float | None:
        """The drain [charge fraction per s, > 0], or ``None`` when not measured yet (too short, not falling).

        The slope of a least-squares line (``numpy.polyfit``) through the reports kept; reports before a
        change of drain are dropped first (see the module's text)."""
        with self._lock:
            if len(self._samples) < 3 or self._samples[-1][0] - self._samples[0][0] < self.min_span:
                return None
            t, c = np.array(self._samples).T
            t = t - t[0]
            slope, icpt = np.polyfit(t, c, 1)
            if float(np.max(np.abs(c - (slope * t + icpt)))) > CHANGE:  # the drain changed: keep the reports since
                k = min(_change_point(t, c), int(np.searchsorted(t, t[-1] - self.min_span, side="right")) - 1)
                if k > 0:
                    for _ in range(k):
                        self._samples.popleft()
                    t, c = t[k:] - t[k], c[k:]
                    slope = np.polyfit(t, c, 1)[0]
        slope = float(slope)
        return -slope if -slope >= MIN_RATE else None


def _change_point(t: np.ndarray, c: np.ndarray) -> int:
    """The index where a second line starts that fits ``(t, c)`` best as two lines (least squares; at least 3
    reports each); 0 when there are too few reports. Prefix sums give every split's squared error at once."""
    n = len(t)
    if n < 6:
        return 0

    def sse(cnt: np.ndarray, st: np.ndarray, sc: np.ndarray, stt: np.ndarray, stc: np.ndarray,
            scc: np.ndarray) -> np.ndarray:
        sxx = stt - st * st / cnt
        sxy = stc - st * sc / cnt
        syy = scc - sc * sc / cnt
        return syy - np.where(sxx > 0, sxy * sxy / np.where(sxx > 0, sxx, 1.0), 0.0)

    sums = [np.concatenate(([0.0], np.cumsum(v))) for v in (np.ones(n), t, c, t * t, t * c, c * c)]
    k = np.arange(3, n - 2)  # the right line starts at report k
    left = sse(*(s[k] for s in sums))
    right = sse(*(s[n] - s[k] for s in sums))
    return int(k[int(np.argmin(left + right))])


def time_left(charge: float | None, rate: float | None, critical: float = BATTERY_CRITICAL) -> float | None:
    """Seconds [s] until ``charge`` falls to ``critical`` at ``rate`` [1/s]; ``None`` when either is unknown."""
    if charge is None or rate is None or not (math.isfinite(charge) and math.isfinite(rate)) or rate <= 0:
        return None
    return max(0.0, (float(charge) - critical) / rate)


def minutes_text(seconds: float) -> str:
    """``about 3 min`` (whole minutes, rounded down: a time left to land is never overstated),
    ``less than 1 min`` below a minute."""
    if seconds < 60.0:
        return "less than 1 min"
    return f"about {math.floor(seconds / 60.0):d} min"


def hover_text(charge: float | None, rate: float | None, critical: float = BATTERY_CRITICAL) -> str:
    """What the robot panel says about the battery while the robot hovers (plain text)."""
    if charge is None or not isinstance(charge, (int, float)) or not math.isfinite(charge):
        return "hovering: battery charge unknown, no time estimate"
    if charge <= 0.0:  # no drain to measure: the vehicle comes down now, whatever was wanted
        return "hovering: battery empty: the robot comes down where it is"
    if charge <= critical:
        return f"hovering: battery at the critical level ({100 * critical:.0f} %): the robot lands now"
    left = time_left(charge, rate, critical)
    if left is None:
        return "hovering: measuring the battery drain for a time estimate…"
    if left <= 0:
        return f"hovering: battery at the critical level ({100 * critical:.0f} %): the robot lands now"
    return (f"hovering: {minutes_text(left)} of battery left to land (the console lands the robot at "
            f"{100 * critical:.0f} %)")


__all__ = ["CHANGE", "DrainRate", "MIN_RATE", "MIN_SPAN", "WINDOW", "hover_text", "minutes_text", "time_left"]
