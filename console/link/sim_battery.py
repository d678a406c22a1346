"""The simulated robot's battery failsafes: critical charge lands, an empty battery comes down and disarms.

Modelled on ArduCopter's battery failsafe (``ArduCopter/events.cpp``, ``Copter::handle_battery_failsafe``,
with ``AP_BattMonitor``'s ``BATT_CRT_VOLT`` / ``BATT_FS_CRT_ACT``):

- **critical** (:attr:`~console.link.sim_config.SimConfig.battery_critical`, action Land): in the air the
  robot ends its segment and lands where it is by itself, once per flight (mode ``failsafe``, "battery
  critical: landing"); a landing the body cannot finish (a surface too small to stand on) is said and
  not retried.
- **empty** (0 %): the motors cannot hold the robot any more, whatever was commanded: it ends its
  segment and comes straight down onto whatever is under it (the floor or an object's top, even one it
  cannot stand on), touches down and disarms; on the ground it disarms at once (like the firmware's
  disarm when landed, ``should_disarm_on_failsafe``). Hold and Abort do not stop that descent and every
  segment is refused ("battery empty").

:class:`SimBattery` is a part of :class:`~console.link.sim.SimRobot` (it uses the robot's state under its lock).
"""

from __future__ import annotations

import logging
import math
import threading
from typing import Callable

import numpy as np

from console.link.base import Mode, RunStatus, SegmentRun
from console.link.sim_config import SimConfig
from console.link.sim_motion import Phase

log = logging.getLogger(__name__)


class SimBattery:
    """The battery failsafes of :class:`~console.link.sim.SimRobot` (a mixin: the robot holds the state)."""

    config: SimConfig
    _pos: np.ndarray
    _floor: float
    _landed: bool
    _armed: bool
    _battery: float
    _battery_landing: bool
    _phases: list[Phase]
    _run: SegmentRun | None
    _lock: threading.RLock
    _say: Callable[[str, str], None]
    _finish: Callable[..., None]

    def _landing_phases(self, mode: Mode, forced: bool = False) -> list[Phase]:
        """Straight down from where the robot is to the floor (or the first top face met), then settle."""
        x, y = float(self._pos[0]), float(self._pos[1])
        cfg = self.config
        return [Phase("descend", mode, target=(x, y, self._floor), speed=cfg.descent_rate,
                      forced=forced),
                Phase("settle", mode if forced else Mode.LANDING, duration=cfg.settle_time, forced=forced)]

    def _battery_failsafe(self) -> None:
        """Critical charge in the air: land where it is (once per flight); empty: :meth:`_battery_empty`."""
        if self._battery <= 0.0:
            self._battery_empty()
            return
        if self._landed:
            self._battery_landing = False
            return
        if self._battery_landing or self._battery > self.config.battery_critical:
            return
        self._battery_landing = True
        log.info("simulated robot: battery %.0f %%, landing by itself", 100 * self._battery)
        self._say("CRITICAL", "battery critical: landing")
        self._finish(RunStatus.FAILED, f"battery critical ({100 * self._battery:.0f} %): landing",
                     say=False)
        self._phases = self._landing_phases(Mode.FAILSAFE)

    def _battery_empty(self) -> None:
        """0 %: come straight down and disarm, whatever was commanded (once; the descent is not stoppable)."""
        phases = self._phases
        if phases and phases[0].forced:
            return  # coming down already
        if self._landed:
            if self._armed or self._run is not None:
                self._finish(RunStatus.FAILED, "battery empty (0 %): the motors stop", say=False)
                self._armed = False
                self._say("CRITICAL", "battery empty: motors disarmed")
            return
        log.info("simulated robot: battery empty, coming down")
        self._say("CRITICAL", "battery empty: coming down where it is, motors off on touchdown")
        self._finish(RunStatus.FAILED, "battery empty (0 %): the robot comes down where it is",
                     say=False)
        self._phases = self._landing_phases(Mode.FAILSAFE, forced=True)

    def _battery_refusal(self) -> str | None:
        """Why no segment may run now (the battery is empty), or ``None``."""
        if self._battery > 0.0:
            return None
        return "battery empty (0 %): the robot cannot move" + ("" if self._landed
                                                                 else " (it is coming down where it is)")

    def set_battery(self, fraction: float) -> None:
        """Set the charge (for tests and demos) [0..1]; the failsafes act on the next step."""
        if not (isinstance(fraction, (int, float)) and math.isfinite(fraction) and 0.0 <= fraction <= 1.0):
            raise ValueError(f"battery: must be a number within 0..1, got {fraction!r}")
        with self._lock:
            self._battery = float(fraction)


__all__ = ["SimBattery"]
