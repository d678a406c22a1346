"""Every route the console offers builds: the planner lands only where Build's landing rule lets it
(planner/landing_spot.py no_landing: the floor under the whole footprint seen free, free ground, nothing
right above), and Build's refusal is known before the click (Session.build_refusal).

The paper's room, one capture from the start looking down the room, unknown space allowed (the operator's
"Plan into unknown space"); the robot hovers low over the floor near the start, where the capture saw only
part of the floor under it. A clicked floor goal ahead used to be offered with a landing on floor partly
not seen, which Build then refused ("cannot land at (2.12, 1.38): the floor under the robot's footprint
... has not been seen") while the robot hovered on.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import planner.route as planner_route
from console.session.session import SessionError
from planner.grid import CellState
from planner.landing_spot import landing_problem, no_landing
from planner.mission import SegmentKind
from tests.console.session.test_land_here_known_space import _hover, _session

HOVER = (1.625, 1.125, 0.625)  # low over the floor beside the start
GOAL = (2.5, 3.0, 0.0)  # a clicked floor goal ahead (seen)


def _hovering_session(tmp_path: Path):
    s = _session(tmp_path)
    s.set_plan_unknown(True)
    s.set_robot(_hover(HOVER))
    return s


def _ignore_landing_rule(monkeypatch: pytest.MonkeyPatch) -> None:
    """The planner as it was: landings anywhere the robot may walk (no landing refused)."""
    monkeypatch.setattr(planner_route, "no_landing", lambda grid: np.zeros(grid.state.shape[:2], dtype=bool))


def test_a_clicked_floor_goal_from_a_hovering_robot_is_offered_with_a_landing_build_accepts(tmp_path: Path) -> None:
    s = _hovering_session(tmp_path)
    res = s.add_goal(GOAL)
    assert res.ok, res.message
    s.register()
    assert s.build_refusal() is None
    mission = s.build_mission()
    assert mission.kinds()[:2] == ["fly", "land"], mission.summary()
    lands = [seg.spot for seg in mission.segments if seg.kind is SegmentKind.LAND]
    for spot in lands:  # the one landing rule, the way Build checks it
        assert landing_problem(s.grid, spot[:2], clear=True) is None, spot
    assert mission.segments[-1].end[:2] == pytest.approx(GOAL[:2], abs=0.2)


def test_the_planner_without_the_landing_rule_offers_what_build_refuses(tmp_path: Path,
                                                                         monkeypatch: pytest.MonkeyPatch) -> None:
    """The operator's case, as the planner did it: offered, registered, refused by Build; the refusal is
    known before the click (Build mission off with the reason), in the very words of the click's refusal."""
    s = _hovering_session(tmp_path)
    _ignore_landing_rule(monkeypatch)
    res = s.add_goal(GOAL)
    assert res.ok, res.message
    s.register()
    why = s.build_refusal()
    assert why is not None and "has not been seen" in why, why
    with pytest.raises(SessionError) as refused:
        s.build_mission()
    assert str(refused.value) == why
    assert why.startswith("cannot build the mission: cannot land at (")
    # with the rule back, planning the goal again offers a route that builds, and the refusal is gone
    monkeypatch.undo()
    s.clear_route()
    assert s.build_refusal() is None
    res = s.add_goal(GOAL)
    assert res.ok, res.message
    s.register()
    assert s.build_refusal() is None
    assert "land" in s.build_mission().kinds()


def test_the_gate_agrees_with_the_landing_rule_on_every_floor_cell(tmp_path: Path) -> None:
    """no_landing is exactly where Build's landing check (clear: free ground) or a closed cell above refuses."""
    s = _hovering_session(tmp_path)
    grid = s.grid
    ws = grid.workspace
    gate = no_landing(grid)
    assert gate.any() and not gate.all()
    for i in range(ws.shape[0]):
        for j in range(ws.shape[1]):
            c = ws.centers(np.array([[i, j, 0]]))[0]
            above = grid.state[i, j, 1] == CellState.OCCUPIED
            assert bool(gate[i, j]) == (landing_problem(grid, c[:2], clear=True) is not None or above), (i, j)
