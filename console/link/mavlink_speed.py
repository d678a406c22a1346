"""Speeds that hold on ArduCopter: sent after position control starts, re-sent after every controller
change, checked against the measured speed.

ArduCopter resets the horizontal speed to ``WPNAV_SPEED`` when GUIDED enters position control (the
first position target after a mode change, a take-off or velocity targets: ``ArduCopter/mode_guided.cpp``,
``pos_control_start`` -> ``pva_control_start``), so a ``MAV_CMD_DO_CHANGE_SPEED`` sent before that target
is lost. :class:`SpeedGuard` therefore, before the first target of each entry into position control,
sends a target *where the vehicle is* (it holds there), then the speeds, and only then the segment's
targets; and it watches the measured speed: faster than ``overspeed_factor`` x the commanded speed
(+ 0.15 m/s) for ``OVERSPEED_TIME`` the speeds are sent again (a warning), and if the vehicle is still
too fast ``OVERSPEED_TIME`` after that it is stopped (BRAKE in the air) and the segment fails with the
figures. Speed commands are optional: a refusal or a lost ACK is a warning, never a failure.

Positions world frame [m], speeds [m/s], times [s].
"""

from __future__ import annotations

import logging
import threading
import time
from typing import Callable

import numpy as np

from console.link.base import LinkError
from console.link.mavlink_commands import SPEED_CLIMB, SPEED_DESCENT, SPEED_GROUND, Commander
from console.link.mavlink_config import MavlinkConfig
from console.link.mavlink_telemetry import Telemetry

log = logging.getLogger(__name__)

OVERSPEED_TIME = 0.5
"""How long [s] the vehicle must be too fast before the speed is re-sent (and again before it is stopped)."""


class SpeedGuard:
    """The commanded speeds of one link.

    Args:
        config: Speeds (``fly_speed``, ``climb_rate``, ``descent_rate``, ``ground.speed``), ``overspeed_factor``.
        telemetry: The measured velocity.
        commander: Speed commands, targets and the controller in use.
    """

    def __init__(self, config: MavlinkConfig, telemetry: Telemetry, commander: Commander) -> None:
        self.config, self.telemetry, self.commander = config, telemetry, commander
        self.stop: Callable[[], None] | None = None  # set by the link: stop the vehicle where it is
        self._applied_for: int | None = None  # commander.controller_changes when the speeds were sent
        self._over_since: float | None = None
        self._resent = False
        self.overspeed_events = 0

    def commanded(self, ground: bool) -> float:
        return self.config.ground.speed if ground else self.config.fly_speed

    def send_speeds(self, ground: bool, cancel: threading.Event) -> None:
        """MAV_CMD_DO_CHANGE_SPEED for what comes next (horizontal; climb and descent in the air)."""
        cfg = self.config
        if ground:
            self.commander.change_speed(SPEED_GROUND, cfg.ground.speed, cancel, cfg.ground.target_component)
            return
        self.commander.change_speed(SPEED_GROUND, cfg.fly_speed, cancel)
        self.commander.change_speed(SPEED_CLIMB, cfg.climb_rate, cancel)
        self.commander.change_speed(SPEED_DESCENT, cfg.descent_rate, cancel)

    def before_target(self, here: np.ndarray, ground: bool, yaw: float | None, component: int | None,
                      cancel: threading.Event) -> None:
        """Called before each position target: if position control is (re-)entered now, enter it
        where the vehicle is and send the speeds first."""
        c = self.commander
        if c.controller == "pos" and self._applied_for == c.controller_changes:
            return
        z = float(self.config.floor) if ground else float(here[2])
        c.send_position_target((float(here[0]), float(here[1]), z), yaw, component)
        self.send_speeds(ground, cancel)
        self._applied_for = c.controller_changes
        self._over_since, self._resent = None, False

    def watch(self, ground: bool, cancel: threading.Event) -> None:
        """Compare the measured speed with the commanded one (see the module)."""
        cfg = self.config
        with self.telemetry.lock:
            v = np.asarray(self.telemetry.v.vel_ned, dtype=np.float64)
        measured = float(np.linalg.norm(v[:2]))
        want = self.commanded(ground)
        limit = want * cfg.overspeed_factor + 0.15
        now = time.monotonic()
        if measured <= limit:
            self._over_since = None
            return
        if self._over_since is None:
            self._over_since = now
            return
        if now - self._over_since < OVERSPEED_TIME:
            return
        if not self._resent:
            self._resent, self._over_since = True, now
            self.overspeed_events += 1
            self.telemetry.warn("overspeed", f"the vehicle moves at {measured:.2f} m/s, commanded {want:.2f} m/s: "
                                             "speed sent again")
            self.send_speeds(ground, cancel)
            return
        if self.stop is not None:
            try:
                self.stop()
            except LinkError as exc:
                log.warning("overspeed stop failed: %s", exc)
        raise LinkError(f"the vehicle moves at {measured:.2f} m/s although {want:.2f} m/s was commanded (twice): "
                        "stopped; check the vehicle's speed parameters (WPNAV_SPEED) and its speed commands")


__all__ = ["SpeedGuard", "OVERSPEED_TIME"]
