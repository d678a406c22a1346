"""Who flies the vehicle: the console's mode authority and the trust in the vehicle's estimator.

:class:`ModeAuthority` follows the autopilot's mode from every HEARTBEAT. Once the console has put the
vehicle in a mode (GUIDED for a segment, BRAKE for a hold, LAND), any other mode the console did not
command (RTL or LAND chosen by a battery / GCS / EKF failsafe, BRAKE by a fence, LOITER from the pilot's
switch, a second ground station) means the vehicle (or someone else) took control: the console sends
no more targets and no mode command of its own until the operator explicitly takes control again
(:meth:`ModeAuthority.take_control`). The reason is the vehicle's own STATUSTEXT around the change
(``vehicle took control: mode RTL (Battery 1 is low 10.40V used 4200 mAh)``); a mode first seen in the
heartbeat that ends a silence was chosen while the console could not hear the vehicle, and says so
(``vehicle took control: mode RTL while the console could not hear it (7.5 s) (GCS Failsafe (now cleared))``).

:class:`EstimatorWatch` flags position steps the vehicle cannot have flown (an EKF position reset, a GPS
glitch: a step larger than ``max_speed x dt + margin`` between two LOCAL_POSITION_NED samples) and the
EKF_STATUS_REPORT / ESTIMATOR_STATUS flags and variances of a reset or glitch; each new fault counts up
``resets`` so the mission manager can hold and pause.

Positions are the vehicle's local NED [m]; times monotonic [s].
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from typing import Callable, Iterable

from console.link.base import LinkError


RECENT_COMMAND = 10.0
"""A mode the console commanded this recently [s] (even unacknowledged) is the console's own when it shows up."""


def _answer_to_us(text: str) -> bool:
    """A line answering one of the console's commands (mode.cpp ``Mode change to BRAKE failed: ...``, arming
    checks): never the reason for a mode the vehicle chose."""
    return text.split(": ", 1)[-1].startswith(("Mode change to ", "PreArm:", "Arm:"))


class VehicleInControl(LinkError):
    """The vehicle is in a mode the console did not command: nothing is sent until the operator takes control."""


@dataclass(frozen=True)
class Takeover:
    mode: str
    time: float  # monotonic [s]
    previous: str
    unheard: float = 0.0  # [s] the vehicle had been silent before the heartbeat that showed it (0: heard)


class ModeAuthority:
    """The console's claim on the vehicle's mode (use under the telemetry lock or from one thread).

    Args:
        reasons: Returns the vehicle's STATUSTEXT lines ``(monotonic time, severity, text)``.
    """

    def __init__(self, reasons: Callable[[], Iterable[tuple[float, int, str]]]) -> None:
        self.reasons = reasons
        self.expected: str | None = None  # the mode the console put the vehicle in (None: no claim)
        self.confirmed = False  # a heartbeat has shown ``expected`` since it was commanded
        self.before: str | None = None  # the mode heartbeats showed when ``expected`` was commanded
        self.pending: set[str] = set()  # modes being commanded right now
        self.recent: dict[str, float] = {}  # mode -> monotonic [s] the console last commanded it (ACK or not)
        self.taken: Takeover | None = None
        self.current: str | None = None

    def observe(self, mode: str, unheard: float = 0.0) -> Takeover | None:
        """One heartbeat's mode; returns a new takeover, if this is one. ``unheard`` [s]: the heartbeat
        ends a silence that long (the mode was chosen while the console could not hear the vehicle)."""
        previous, self.current = self.current, mode
        if self.expected is None or self.taken is not None or mode in self.pending:
            return None
        if mode != self.expected and time.monotonic() - self.recent.get(mode, -math.inf) < RECENT_COMMAND:
            self.expected = mode  # our own command got through although its ACK was lost
        if mode == self.expected:
            self.confirmed = True
            return None
        if not self.confirmed and mode == self.before:
            return None  # a heartbeat sent before our mode change took effect
        self.taken = Takeover(mode, time.monotonic(), previous or "", unheard)
        return self.taken

    def commanding(self, mode: str) -> None:
        self.pending.add(mode)
        self.recent[mode] = time.monotonic()

    def commanded(self, mode: str, ok: bool) -> None:
        """The console's mode command ended (``ok``: accepted or seen)."""
        self.pending.discard(mode)
        if ok:
            self.confirmed = self.current == mode
            self.before = None if self.confirmed else self.current
            self.expected = mode

    def check(self, what: str) -> None:
        """Raise :class:`VehicleInControl` if the vehicle took control."""
        if self.taken is not None:
            raise VehicleInControl(f"{what} not sent: {self.describe()}")

    def reason(self) -> str:
        """The vehicle's own words around the takeover (warning or worse, 5 s before to 2 s after; 5 s after
        a takeover seen when the link returned: a failsafe's "... Cleared" comes once it hears us)."""
        t = self.taken
        if t is None:
            return ""
        lines = [(at, text) for at, sev, text in self.reasons()
                 if sev <= 4 and t.time - 5.0 <= at <= t.time + (5.0 if t.unheard else 2.0)
                 and not text.startswith("WARNING: link:") and not _answer_to_us(text)]
        before = [x for x in lines if x[0] <= t.time]
        pick = before[-1] if before else (lines[0] if lines else None)
        text = pick[1].split(": ", 1)[-1] if pick else ""
        # a failsafe's lines sent while the link was down are lost; its "... Cleared" (events.cpp
        # failsafe_*_off_event) sent once heard again names it: the mode it chose stays
        return text.removesuffix(" Cleared") + " (now cleared)" if text.endswith(" Cleared") else text

    def describe(self) -> str:
        """``vehicle took control: mode RTL (Battery 1 is low ...)`` or ``""``."""
        t = self.taken
        if t is None:
            return ""
        why = self.reason() or ("its reason, if it gave one, was lost with the link: its own failsafe (GCS, battery, "
                                "EKF), another ground station or the pilot" if t.unheard > 0 else
                                "no reason given: another ground station, the pilot's mode switch or a script")
        when = f" while the console could not hear it ({t.unheard:.1f} s)" if t.unheard > 0 else ""
        return f"vehicle took control: mode {t.mode}{when} ({why})"

    def take_control(self) -> None:
        """The operator takes control again: the console may command modes and targets."""
        self.taken = None
        self.expected = None
        self.confirmed = False
        self.recent.clear()

    def release(self) -> None:
        """The console no longer claims the vehicle (mission over, reboot): mode changes are the vehicle's."""
        self.take_control()


EKF_CONST_POS_MODE, EKF_UNINITIALIZED, EKF_GPS_GLITCH = 128, 1024, 32768
"""EKF_STATUS_REPORT flags (EKF_STATUS_FLAGS)."""
ESTIMATOR_CONST_POS_MODE, ESTIMATOR_GPS_GLITCH, ESTIMATOR_ACCEL_ERROR = 128, 1024, 2048
"""ESTIMATOR_STATUS flags (ESTIMATOR_STATUS_FLAGS)."""
VARIANCE_LIMIT = 0.8
"""EKF variance (normalised test ratio) above which the estimate is not trusted (ArduPilot's
FS_EKF_THRESH default, and where ground stations turn the EKF indicator red)."""


class EstimatorWatch:
    """Position jumps and estimator fault flags.

    Args:
        max_speed: Fastest the vehicle can really move [m/s]; a step faster than this is a jump.
        margin: Step always allowed (noise) [m].
    """

    def __init__(self, max_speed: float, margin: float = 0.5) -> None:
        self.max_speed, self.margin = max_speed, margin
        self._last: tuple[tuple[float, float, float], float] | None = None  # (ned, time [s])
        self.resets = 0
        self.fault = ""  # standing flag / variance fault, "" when fine
        self.jump = ""  # the last jump, for the operator
        self.jump_m = 0.0
        self.jump_time = -math.inf  # monotonic [s]

    def position(self, ned: tuple[float, float, float], t: float) -> str | None:
        """One valid position sample at vehicle time ``t`` [s]; returns a jump's text, if any."""
        last, self._last = self._last, (ned, t)
        if last is None:
            return None
        dt = max(t - last[1], 1e-3)
        step = math.dist(ned, last[0])
        if step <= self.max_speed * dt + self.margin:
            return None
        self.resets += 1
        self.jump_m, self.jump_time = step, time.monotonic()
        self.jump = (f"position jumped {step:.2f} m in {dt:.2f} s ({step / dt:.0f} m/s; the vehicle moves at most "
                     f"{self.max_speed:g} m/s): estimator reset or glitch")
        return self.jump

    def forget(self) -> None:
        """After a reboot / reconnect: the next sample starts a new track."""
        self._last = None

    def flags(self, text: str) -> str | None:
        """A fault text from the status flags (``""``: fine); returns it when it is new."""
        if text and not self.fault:
            self.resets += 1
            self.fault = text
            return text
        self.fault = text
        return None

    @staticmethod
    def ekf_fault(flags: int, variances: dict[str, float]) -> str:
        why = []
        if flags & EKF_GPS_GLITCH:
            why.append("GPS glitch")
        if flags & EKF_UNINITIALIZED:
            why.append("EKF uninitialised")
        bad = [f"{k} {v:.2f}" for k, v in variances.items() if math.isfinite(v) and v > VARIANCE_LIMIT]
        if bad:
            why.append(f"EKF variance above {VARIANCE_LIMIT:g} ({', '.join(bad)})")
        return "; ".join(why)

    @staticmethod
    def estimator_fault(flags: int, ratios: dict[str, float]) -> str:
        why = []
        if flags & ESTIMATOR_GPS_GLITCH:
            why.append("GPS glitch")
        if flags & ESTIMATOR_ACCEL_ERROR:
            why.append("accelerometer error")
        bad = [f"{k} {v:.2f}" for k, v in ratios.items() if math.isfinite(v) and v > 1.0]
        if bad:
            why.append(f"estimator test ratio above 1 ({', '.join(bad)})")
        return "; ".join(why)


__all__ = ["ModeAuthority", "VehicleInControl", "Takeover", "EstimatorWatch", "VARIANCE_LIMIT"]
