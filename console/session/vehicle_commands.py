"""Vehicle commands outside missions: Hold, Land here, Return, Disarm, Take control.

Whether a command applies (and why not) is decided by the session's rule for its button
(:mod:`console.session.button_rules`): the button is off with the same reason this class refuses
with, so they never disagree. This class carries a command out over the robot link. Land here and Return are flown as small missions through the mission manager (so they have
progress, Pause / Abort and the link-loss failsafe like any mission); Hold and Disarm go straight
to the link (:meth:`~console.link.base.RobotLink.hold`, :meth:`~console.link.base.RobotLink.disarm`),
so the simulator and MAVLink vehicles both do them.

At critical battery (:data:`console.session.operator_state.BATTERY_CRITICAL`) the session calls
:meth:`VehicleCommands.battery_land`: the running mission is aborted and the robot lands where it
is through the same Land here path.
"""

from __future__ import annotations

import logging
import time
from typing import Any

from console.session.button_rules import refusal
from console.session.session import Session, SessionError

log = logging.getLogger(__name__)

LABELS = {"hold": "Hold", "land": "Land here", "return": "Return", "disarm": "Disarm", "control": "Take control"}
"""The button label of each command."""


class VehicleCommands:
    """Carries out the vehicle commands for every tab.

    Args:
        session: The state (its rules say what applies).
        link: The robot link (``hold()``, ``disarm()``), or ``None``.
        runner: The mission runner (``execute(mission, command=...)``), or ``None``.
    """

    def __init__(self, session: Session, link: Any, runner: Any) -> None:
        self._session = session
        self._link = link
        self._runner = runner
        if runner is not None:  # the console's commands (a view's read-only copy has no runner)
            session.attach_battery_land(self.battery_land)

    def battery_land(self, timeout: float = 60.0) -> None:
        """Critical battery: end the running mission (the manager's abort; the robot holds) and
        land here. Blocking (the session runs it on its own thread); tells every tab the outcome."""
        run = self._session.run
        if run.active and self._runner is not None:
            try:
                self._runner.abort()
            except Exception as exc:  # ended meanwhile
                log.info("battery critical: abort: %s", exc)
            end = time.monotonic() + timeout  # the manager reports the end asynchronously
            while self._session.run.active and time.monotonic() < end:
                time.sleep(0.05)
        try:
            msg = self.run("land", forced=True)  # lands even on floor not seen: a forced landing beats a crash
        except SessionError as exc:
            self._session.notify("Battery critical", f"cannot land here automatically: {exc}", "error")
            return
        self._session.notify("Battery critical", f"the mission was ended; {msg}", "warning")

    def _check(self, name: str) -> None:
        why = refusal(name, LABELS[name], self._session.operator_state(self._runner is not None).commands)
        if why is not None:
            raise SessionError(why)

    def run(self, name: str, forced: bool = False) -> str:
        """Carry out command ``name`` (``hold``, ``land``, ``return``, ``disarm``); returns a message
        for the operator. Raises :class:`SessionError` with the reason when it does not apply or the
        robot refuses. ``forced`` (the critical-battery landing only, with ``land``): land where the
        robot is even on floor the known space has not seen (the session still checks the rest)."""
        if name not in LABELS:
            raise SessionError(f"unknown vehicle command {name!r}; expected one of {', '.join(LABELS)}")
        forced = forced and name == "land"
        if not forced:
            self._check(name)
        if name == "control":
            return self.take_control(confirm=True)
        try:
            if name == "hold":
                self._need(self._link, "robot link").hold()
                return "the robot holds where it is"
            if name == "disarm":
                self._need(self._link, "robot link").disarm()
                return "motors disarmed"
            mission = self._session.land_mission(forced) if name == "land" else self._session.return_mission()
            self._stop_bare_segment()
            self._need(self._runner, "mission manager").execute(mission, command=LABELS[name])
        except SessionError:
            raise
        except Exception as exc:  # the link or the manager refused: say why
            raise SessionError(f"{LABELS[name]} refused: {exc}") from None
        spot = mission.segments[-1].end
        return f"{LABELS[name].lower()}: landing at ({spot[0]:.2f}, {spot[1]:.2f})"

    def _stop_bare_segment(self, timeout: float = 10.0) -> None:
        """Land here / Return outrank a segment run outside any mission (a look's or a search's turn): it is
        held first, or the mission's first leg would be refused ('a turn segment is still running')."""
        link = self._link
        under_way = getattr(link, "segment_under_way", None)
        if self._session.run.active or under_way is None or not under_way():
            return
        link.hold()
        end = time.monotonic() + timeout
        while under_way() and time.monotonic() < end:
            time.sleep(0.02)

    def take_control(self, confirm: bool = False) -> str:
        """Take control back from a vehicle flying a mode it chose (RTL, LAND, another ground station).

        Without ``confirm``: only the question for the operator, saying what the vehicle does now.
        With it: the console may command the vehicle again (Resume then switches it to GUIDED).
        Raises :class:`SessionError` when the vehicle has not taken control or the link cannot say.
        """
        self._check("control")
        take = getattr(self._runner, "take_control", None)
        if take is None:
            raise SessionError("this robot link has no vehicle modes to take control from")
        try:
            return str(take(confirm))
        except Exception as exc:  # the manager could not read the vehicle
            raise SessionError(f"Take control refused: {exc}") from None

    @staticmethod
    def _need(thing: Any, what: str) -> Any:
        if thing is None:
            raise SessionError(f"this console has no {what}")
        return thing
