"""Return's hover text and the mission panel's line name the spot Return really lands at.

The words come from :func:`console.session.button_rules.return_hint`, which asks
:func:`planner.landing_spot.return_spots` -- the function the session's Return plans to -- so the hint, the
robot panel's button and the mission Return flies agree: the take-off spot when the robot may land there;
beside a wall or an object the nearest spot it fits, how far from the take-off spot and why; no spot at all:
Return off with the reason, and refused with the same words.
"""

from __future__ import annotations

import math
import time
from pathlib import Path

import pytest
import viser

from console.link.base import Mode, RobotState
from console.session import button_rules
from console.session.session import Session, SessionError
from console.session.session_types import RunStatus, robot_snapshot
from console.session.topics import NOTICE
from console.session.vehicle_commands import VehicleCommands
from pipeline.scene import Scene, SceneObject
from planner.landing_spot import landing_problem

BOX = SceneObject("box-1", "cardboard_box", (2.5, 4.0, 0.6), (0.5, 1.2, 0.5))


def _snap(p: tuple[float, float, float], mode: Mode, armed: bool = True) -> object:
    return robot_snapshot(RobotState(time=time.time(), position=p, mode=mode, armed=armed, landed=p[2] < 0.05))


class _Runner:
    def __init__(self) -> None:
        self.flown: list = []

    def execute(self, mission: object, command: str = "") -> None:
        self.flown.append((mission, command))

    def abort(self) -> None: ...


class _Link:
    def hold(self) -> None: ...

    def disarm(self) -> None: ...


def _session(tmp_path: Path, launch: tuple[float, float]) -> tuple[Session, list]:
    s = Session(tmp_path / "s", start=(launch[0], launch[1], 0.0), autosave=False)
    s.spawn(Scene(objects=(BOX,)))
    notices: list = []
    s.subscribe(lambda topic, payload: notices.append(payload) if topic == NOTICE else None)
    s.set_robot(_snap((launch[0], launch[1], 0.0), Mode.IDLE, armed=False))  # stood disarmed: the take-off spot
    s.set_robot(_snap((2.5, 2.5, 1.5), Mode.HOLDING))
    return s, notices


def test_beside_the_wall_the_hint_names_the_spot_return_lands_at(tmp_path: Path) -> None:
    s, notices = _session(tmp_path, (0.2, 0.7))  # 0.2 m from the wall x = 0: inside the robot's 0.35 m
    view = s.operator_state()
    assert view.commands["return"].enabled
    d = math.dist((0.375, 0.625), (0.2, 0.7))
    said = (f"Return: lands at (0.38, 0.62), {d:.2f} m from the take-off spot (0.20, 0.70), where the robot cannot "
            "land: too near the wall")
    assert view.return_hint == said
    assert button_rules.hover_text("return", "Return", view.commands["return"], view.launch, view.return_hint) == said
    end = VehicleCommands(s, _Link(), _Runner()).run("return")  # the mission Return flies ends where the hint said
    assert end == "return: landing at (0.38, 0.62)"
    assert [n.body for n in notices if n.title == "Return"] == [said]  # its notice: the same words


def test_an_object_on_the_take_off_spot_moves_the_landing_and_the_hint_says_which(tmp_path: Path) -> None:
    s, _ = _session(tmp_path, (2.5, 0.7))
    assert s.operator_state().return_hint == "Return: lands at the take-off spot (2.50, 0.70)"
    crate = SceneObject("crate-7", "cardboard_box", (2.5, 0.9, 0.3), (0.5, 0.6, 0.5))  # mapped after take-off
    s.spawn(Scene(objects=(crate,)))
    hint = s.operator_state().return_hint
    assert "from the take-off spot (2.50, 0.70), where the robot cannot land: cardboard box 'crate-7' is" in hint, hint
    mission = s.return_mission()
    end = mission.segments[-1].end
    assert hint.startswith(f"Return: lands at ({end[0]:.2f}, {end[1]:.2f}), ")  # the spot Return plans to
    assert landing_problem(s.grid, end) is None


def test_with_no_spot_that_fits_return_is_off_and_says_why(tmp_path: Path) -> None:
    s, _ = _session(tmp_path, (0.2, 0.7))
    s.spawn(Scene(objects=(SceneObject("mat", "sports_mat", (2.5, 4.0, 0.025), (8.0, 0.05, 5.0)),)))  # the floor
    view = s.operator_state()
    ret = view.commands["return"]
    why = "cannot plan the return: no floor spot fits the landing rule (the take-off spot (0.20, 0.70): too near the wall)"
    assert ret.shown and not ret.enabled and ret.reason == why
    assert view.return_hint.startswith("Return: no floor spot near the take-off spot (0.20, 0.70) fits")
    assert button_rules.hover_text("return", "Return", ret, view.launch, view.return_hint).endswith(f"Return is off: {why}")
    with pytest.raises(SessionError, match=r"^Return is not possible now: cannot plan the return: no floor spot"):
        VehicleCommands(s, _Link(), _Runner()).run("return")
    with pytest.raises(SessionError, match=r"^cannot plan the return: no floor spot fits"):
        s.return_mission()


def test_the_robot_panel_button_and_a_running_return_show_the_same_spot(tmp_path: Path) -> None:
    from console.views.robot_view import RobotView

    s, _ = _session(tmp_path, (0.2, 0.7))
    server = viser.ViserServer(host="127.0.0.1", port=0, verbose=False)
    try:
        runner = _Runner()
        panel = RobotView(server, s, "sim", commands=VehicleCommands(s, _Link(), runner))
        s.set_robot(_snap((2.5, 2.5, 1.5), Mode.HOLDING))
        hint = s.operator_state().return_hint
        assert panel._buttons["return"].hint == hint and hint.startswith("Return: lands at (0.38, 0.62), ")
        mission = s.return_mission()
        s.mission_started(mission, "Return")
        s.set_run(RunStatus("running", 0, 0.1))
        end = mission.segments[-1].end
        assert s.operator_state().return_hint.startswith(f"Return: lands at ({end[0]:.2f}, {end[1]:.2f}), ")
    finally:
        server.stop()
