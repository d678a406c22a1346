"""Take control: while the vehicle flies a mode it chose (a failsafe's RTL, another ground station's
LAND), the console's vehicle commands are off with the reason and only *Take control* is on; it asks
first, saying what the vehicle does, and only a confirmed click hands control back (server side, no
browser: the viser GUI handles are inspected)."""

from __future__ import annotations

import time
from pathlib import Path
from typing import Any, Iterator

import pytest
import viser

from console.link.base import Mode, RobotState
from console.session.session import Session, SessionError
from console.session.session_types import robot_snapshot
from console.session.vehicle_commands import VehicleCommands
from console.views.robot_view import RobotView

START = (2.5, 0.7, 0.0)
TAKEN = "vehicle took control: mode RTL (Battery 1 is low 10.40V used 4200 mAh)"


class _Runner:
    """The mission runner's take-control part, as the manager answers it."""

    def __init__(self) -> None:
        self.calls: list[bool] = []

    def execute(self, mission: object, command: str = "") -> None: ...

    def pause(self) -> None: ...

    def resume(self) -> None: ...

    def abort(self) -> None: ...

    def take_control(self, confirm: bool = False) -> str:
        self.calls.append(confirm)
        if not confirm:
            return f"{TAKEN}; the robot is returning, autopilot mode RTL, in the air at (2.50, 3.00, 2.40). Take control?"
        return "control taken: resume continues the mission"


@pytest.fixture()
def server() -> Iterator[viser.ViserServer]:
    srv = viser.ViserServer(host="127.0.0.1", port=0, verbose=False)
    yield srv
    srv.stop()


def _snap(control: str = "", **kw: Any) -> Any:
    base: dict[str, Any] = dict(time=time.time(), position=(2.5, 3.0, 2.4), mode=Mode.HOLDING, landed=False,
                                armed=True, vehicle_control=control)
    base.update(kw)
    return robot_snapshot(RobotState(**base))


def test_only_take_control_is_on_while_the_vehicle_flies_its_own_mode(server: viser.ViserServer,
                                                                      tmp_path: Path) -> None:
    session = Session(tmp_path / "session", start=START, autosave=False)
    runner = _Runner()
    commands = VehicleCommands(session, None, runner)
    view = RobotView(server, session, "mavlink:test", commands)
    session.set_robot(robot_snapshot(RobotState(time=time.time(), position=START, mode=Mode.IDLE, landed=True)))

    session.set_robot(_snap())  # the console's own flight: no Take control
    cmds = session.operator_state().commands
    assert cmds["hold"].shown and not cmds["control"].shown
    assert not view._buttons["control"].visible
    with pytest.raises(SessionError, match="Take control applies only"):
        commands.run("control")

    session.set_robot(_snap(TAKEN, mode=Mode.FLYING))
    cmds = session.operator_state().commands
    for name in ("hold", "land", "return"):
        assert cmds[name].shown and not cmds[name].enabled
        assert cmds[name].reason == f"the vehicle flies its own mode ({TAKEN}): Take control first"
    assert cmds["control"].shown and cmds["control"].enabled
    assert view._buttons["control"].visible and not view._buttons["control"].disabled
    assert view._buttons["land"].disabled and "Take control first" in view._why_not.content
    with pytest.raises(SessionError, match="Land here is not possible now: the vehicle flies its own mode"):
        commands.run("land")

    question = commands.take_control(confirm=False)  # what the panel's confirmation shows
    assert "returning, autopilot mode RTL" in question and runner.calls == [False]
    assert commands.run("control") == "control taken: resume continues the mission"
    assert runner.calls == [False, True]


def test_take_control_over_a_link_without_modes_says_so(tmp_path: Path) -> None:
    session = Session(tmp_path / "session", start=START, autosave=False)
    commands = VehicleCommands(session, None, None)
    session.set_robot(_snap(TAKEN))
    with pytest.raises(SessionError, match="no vehicle modes to take control from"):
        commands.take_control()


def test_a_lost_link_keeps_take_control_off(tmp_path: Path) -> None:
    session = Session(tmp_path / "session", start=START, autosave=False)
    session.set_robot(_snap(TAKEN, link_ok=False, position_valid=False, pose_age=3.0,
                            health="stale: no valid position for 3.0 s"))
    c = session.operator_state().commands["control"]
    assert c.shown and not c.enabled and c.reason
