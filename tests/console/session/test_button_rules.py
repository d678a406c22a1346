"""One rule per button: a button is off exactly when the session would refuse its click, with the same words.

Land here over a mapped box, on the ground and over unseen floor; Hold while the robot stands or hovers
still; Return with nothing to return to and the words of where it lands; Execute without a mission. For a
table of robot states the robot panel's buttons (a real viser server, no browser) and the session's answer
to the same command (``VehicleCommands.run``) are compared one by one.
"""

from __future__ import annotations

import time
from pathlib import Path
from typing import Any

import pytest
import viser

from console.link.base import Mode, RobotState
from console.session import button_rules
from console.session.operator_state import CommandState
from console.session.session import Session, SessionError
from console.session.session_types import RobotSnapshot, RunStatus, robot_snapshot
from console.session.vehicle_commands import LABELS, VehicleCommands
from pipeline.camera.geometry import Pose
from pipeline.scene import Scene, SceneObject
from planner.grid import Workspace

START = (2.5, 0.7, 0.0)
CRATE = SceneObject("crate", "cardboard_box", (3.3, 1.8, 0.3), (0.5, 0.6, 0.5))
OVER_CRATE = (3.3, 1.8, 1.5)
OVER_FLOOR = (2.0, 2.5, 1.5)


def _snap(p: tuple[float, float, float], mode: Mode, armed: bool = True, landed: bool | None = None) -> RobotSnapshot:
    landed = p[2] < 0.05 if landed is None else landed
    return robot_snapshot(RobotState(time=time.time(), position=p, mode=mode, armed=armed, landed=landed))


class _Runner:
    """Records the missions it is asked to fly (a mission manager that never moves anything)."""

    def __init__(self) -> None:
        self.flown: list[tuple[Any, str]] = []

    def execute(self, mission: Any, command: str = "") -> None:
        self.flown.append((mission, command))

    def abort(self) -> None: ...


class _Link:
    """Records Hold and Disarm."""

    def __init__(self) -> None:
        self.calls: list[str] = []

    def hold(self) -> None:
        self.calls.append("hold")

    def disarm(self) -> None:
        self.calls.append("disarm")


def _session(tmp_path: Path) -> Session:
    s = Session(tmp_path / "s", start=START, autosave=False)
    s.spawn(Scene(objects=(CRATE,)), origin="the operator's map")
    s.set_robot(_snap(START, Mode.IDLE, armed=False))  # seen standing disarmed: the take-off spot
    return s


def test_land_here_is_off_over_a_mapped_box_and_refused_with_the_same_words(tmp_path: Path) -> None:
    s = _session(tmp_path)
    commands = VehicleCommands(s, _Link(), _Runner())
    s.set_robot(_snap(OVER_CRATE, Mode.HOLDING))
    land = s.operator_state().commands["land"]
    assert land.shown and not land.enabled
    assert land.reason == ("cannot land here: crate is below the robot at (3.30, 1.80): use Return, "
                           "or plan a goal on free floor")
    with pytest.raises(SessionError) as refused:
        s.land_mission()
    assert str(refused.value) == land.reason  # the session's refusal is the button's reason
    with pytest.raises(SessionError, match="Land here is not possible now: cannot land here: crate is below"):
        commands.run("land")
    s.set_robot(_snap(OVER_FLOOR, Mode.HOLDING))  # free floor below: on, and it lands
    assert s.operator_state().commands["land"].enabled
    assert "land here: landing at (2.00, 2.50)" == commands.run("land")


def test_land_here_on_the_ground_says_there_is_nothing_to_land(tmp_path: Path) -> None:
    s = _session(tmp_path)
    s.set_robot(_snap((2.0, 2.5, 0.0), Mode.IDLE, armed=True))
    land = s.operator_state().commands["land"]
    assert not land.shown and land.reason == "the robot is not flying: nothing to land"
    with pytest.raises(SessionError, match="^the robot is not flying: nothing to land$"):
        VehicleCommands(s, _Link(), _Runner()).run("land")


def test_hold_is_off_while_the_robot_stands_or_hovers_still(tmp_path: Path) -> None:
    s = _session(tmp_path)
    link = _Link()
    commands = VehicleCommands(s, link, _Runner())
    s.set_robot(_snap(OVER_FLOOR, Mode.HOLDING))
    hold = s.operator_state().commands["hold"]
    assert hold.shown and not hold.enabled and hold.reason == "the robot already hovers in place: nothing to hold"
    with pytest.raises(SessionError, match="Hold is not possible now: the robot already hovers in place"):
        commands.run("hold")
    s.set_robot(_snap((2.0, 2.5, 0.0), Mode.IDLE, armed=True))
    assert s.operator_state().commands["hold"].reason == "the robot already stands still: nothing to hold"
    assert link.calls == []
    s.set_robot(_snap(OVER_FLOOR, Mode.FLYING))  # under way (another station's command): Hold stops it
    assert s.operator_state().commands["hold"].enabled
    assert commands.run("hold") == "the robot holds where it is" and link.calls == ["hold"]


def test_return_says_where_it_lands_and_is_off_with_nothing_to_return_to(tmp_path: Path) -> None:
    s = _session(tmp_path)
    s.set_robot(_snap(OVER_FLOOR, Mode.HOLDING))
    view = s.operator_state()
    assert view.launch == pytest.approx(START)
    assert button_rules.return_hint(view.launch) == "Return: lands at the take-off spot (2.50, 0.70)"
    assert button_rules.hover_text("return", "Return", view.commands["return"], view.launch) == \
        "Return: lands at the take-off spot (2.50, 0.70)"
    s.set_robot(_snap(START, Mode.IDLE, armed=True))  # armed at the take-off spot: nothing to return to
    ret = s.operator_state().commands["return"]
    assert ret.shown and not ret.enabled and ret.reason == "the robot is at the launch spot"
    with pytest.raises(SessionError, match="^Return is not possible now: the robot is at the launch spot$"):
        VehicleCommands(s, _Link(), _Runner()).run("return")
    with pytest.raises(SessionError, match="^the robot is at the launch spot$"):
        s.return_mission()

    never = Session(tmp_path / "t", start=START, autosave=False)  # never seen standing disarmed
    never.set_robot(_snap(OVER_FLOOR, Mode.HOLDING))
    ret = never.operator_state().commands["return"]
    assert not ret.enabled and "launch spot is unknown" in ret.reason
    assert "not known yet" in button_rules.return_hint(None)


def test_hover_text_names_the_button_and_its_reason_once() -> None:
    off = CommandState(True, False, "the robot link is lost")
    assert button_rules.hover_text("hold", "Hold", off, None) == "Vehicle command: Hold · Hold is off: the robot link is lost"
    own = CommandState(True, False, "Land here is off: the floor below (1.00, 2.00) has not been seen")
    assert button_rules.hover_text("land", "Land here", own, None).count("Land here is off") == 1
    assert button_rules.refusal("hold", "Hold", {"hold": CommandState()}) == \
        "Hold applies only while the robot is armed or off the ground"
    assert button_rules.refusal("hold", "Hold", {"hold": CommandState(True, True)}) is None


def test_a_running_mission_hides_the_commands_and_a_call_says_why() -> None:
    ws = Workspace()
    states = button_rules.vehicle_commands(_snap(OVER_FLOOR, Mode.FLYING), RunStatus("running"), ws, START)
    assert all(not c.shown for c in states.values())
    for name in ("hold", "land", "return"):
        assert states[name].reason == "a mission is running: use Pause or Abort"
    assert button_rules.land_here(None, RunStatus(), ws, START, None).reason == "no state from the robot yet"


STATES = {
    "hovering over the crate": _snap(OVER_CRATE, Mode.HOLDING),
    "hovering over free floor": _snap(OVER_FLOOR, Mode.HOLDING),
    "flying": _snap(OVER_FLOOR, Mode.FLYING),
    "walking, armed": _snap((2.0, 2.5, 0.0), Mode.WALKING),
    "standing armed at the take-off spot": _snap(START, Mode.IDLE),
    "standing disarmed elsewhere": _snap((2.0, 2.5, 0.0), Mode.IDLE, armed=False),
    "hovering, link lost": robot_snapshot(RobotState(time=time.time(), position=OVER_FLOOR, mode=Mode.HOLDING,
                                                     armed=True, landed=False, link_ok=False)),
}


@pytest.mark.parametrize("state", sorted(STATES))
def test_the_panel_buttons_and_the_session_never_disagree(tmp_path: Path, state: str) -> None:
    from console.views.robot_view import RobotView

    s = _session(tmp_path)
    server = viser.ViserServer(host="127.0.0.1", port=0, verbose=False)
    try:
        runner, link = _Runner(), _Link()
        commands = VehicleCommands(s, link, runner)
        view = RobotView(server, s, "sim", commands=commands)
        s.set_robot(STATES[state])
        for name, button in view._buttons.items():
            if name == "control":
                continue  # asks first (a confirmation), tested in test_take_control
            usable = button.visible and not button.disabled
            try:
                commands.run(name)
                done = True
            except SessionError as exc:
                done = False
                reason = str(exc)
            assert done == usable, f"{state}: {LABELS[name]} button usable={usable} but the session did={done}"
            if not done and button.visible:  # the reason on hover is the one the session refused with
                assert reason.split(": ", 1)[1] in button.hint or reason in button.hint, (reason, button.hint)
            s.set_run(RunStatus())  # a command's mission "started" nothing here: back to idle for the next
    finally:
        server.stop()
