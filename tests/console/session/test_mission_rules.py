"""One rule for what each mission and route button may do in each mission state (console/session/mission_rules.py),
applied by the session (refused with the reason) and by the route buttons (console/session/operator_state.route_edits)."""

from __future__ import annotations

from pathlib import Path

import pytest

from console.session import mission_rules
from console.session.operator_state import route_edits
from console.session.session import RunStatus, Session, SessionError

UNDER_WAY = ("running", "paused", "failsafe")
EDITS = ("plan", "register", "discard", "undo", "clear", "build", "execute", "replan", "add_landing")


def test_every_state_and_button_has_a_rule() -> None:
    for state in mission_rules.STATES:
        assert set(mission_rules.RULES[state]) == set(mission_rules.BUTTONS)
        for button in EDITS:  # no edit, build or execute while a mission is under way, paused included
            why = mission_rules.blocker(button, state)
            assert (why is None) == (state not in UNDER_WAY), (state, button, why)
    assert [s for s in mission_rules.STATES if mission_rules.allowed("pause", s)] == ["running"]
    assert [s for s in mission_rules.STATES if mission_rules.allowed("resume", s)] == ["paused", "failsafe"]
    assert [s for s in mission_rules.STATES if mission_rules.allowed("abort", s)] == list(UNDER_WAY)
    assert mission_rules.blocker("build", "paused") == (
        "a mission is paused: resume or abort it before building a new one (Resume continues the paused mission, "
        "not a new build)")
    assert mission_rules.blocker("resume", "done") == "nothing to resume: the mission is done"
    with pytest.raises(ValueError, match="button"):
        mission_rules.blocker("fly", "idle")
    with pytest.raises(ValueError, match="state"):
        mission_rules.blocker("build", "hovering")
    table = mission_rules.table_markdown()
    assert "| paused | - | - | - | - | - | - | - | - | - | - | yes | yes |" in table


def test_route_buttons_follow_the_mission_state() -> None:
    assert route_edits(True, 2)["build"] and route_edits(True, 2)["register"]
    for state in UNDER_WAY:
        assert not any(route_edits(True, 2, run_state=state).values()), state
    assert route_edits(True, 2, run_state="done") == route_edits(True, 2)


def test_the_session_refuses_build_and_edits_while_a_mission_is_paused(tmp_path: Path) -> None:
    session = Session(tmp_path / "session", start=(2.6, 0.6, 0.0))
    assert session.add_goal((2.5, 3.0, 0.0)).ok
    session.register()
    first = session.build_mission()
    session.set_run(RunStatus("paused", 0, 0.3, "paused by the operator"))
    with pytest.raises(SessionError, match="a mission is paused: resume or abort it before building a new one"):
        session.build_mission()
    assert session.mission is not None and session.mission.id == first.id  # Resume still runs this one
    with pytest.raises(SessionError, match="a mission is paused: resume or abort it before removing"):
        session.undo()
    with pytest.raises(SessionError, match="before clearing the route"):
        session.clear_route()
    res = session.add_goal((4.0, 3.0, 0.0))
    assert not res.ok and res.message == "a mission is paused: resume or abort it before planning a new goal"
    with pytest.raises(SessionError, match="before re-planning from the robot"):
        session.replan_from_robot()
    session.set_run(RunStatus("aborted", 0, 0.3, "aborted"))
    assert session.build_mission().id != first.id  # ended: building is allowed again
