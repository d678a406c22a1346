"""The operator in charge during a search, on the simulator in the paper's room (headless, as the console
wires it): the mission panel's Pause / Resume / Abort act on the move under way as on any mission, Hold,
Land here and Return pause the search and act on the robot, Land here over floor not seen lands on the
nearest seen-free floor, Resume plans again from wherever the robot is, and the battery budget ends the
search with its report. Every wait is on state, with generous deadlines."""

from __future__ import annotations

import math
import time
from pathlib import Path
from typing import Any

import pytest

from console.cli.search_cmd import HeadlessRig
from console.link.world_file import paper_world
from console.session.operator_state import BATTERY_LOW
from console.session.search import SearchConfig
from console.session.session import SEARCH, SessionError

DEADLINE = 600.0


def _until(cond: Any, what: str, timeout: float = DEADLINE) -> None:
    deadline = time.monotonic() + timeout
    while not cond():
        if time.monotonic() > deadline:
            raise AssertionError(f"timed out waiting for {what}")
        time.sleep(0.02)


@pytest.fixture
def rig(tmp_path: Path):
    r = HeadlessRig(paper_world(), tmp_path / "s", time_scale=8.0)
    r.events = []  # type: ignore[attr-defined]
    r.session.subscribe(lambda t, p: r.events.append(p) if t == SEARCH else None)  # type: ignore[attr-defined]
    try:
        yield r
    finally:
        r.close()


def _pos(rig: Any) -> tuple[float, float, float]:
    return tuple(float(v) for v in rig.robot.latest_state().position)  # type: ignore[return-value]


def _moving(rig: Any) -> bool:
    """The search's own move (a mission) is running."""
    s = rig.session
    return s.run.state == "running" and not s.operator_state(True).running


def _kinds(rig: Any) -> list[str]:
    return [e["kind"] for e in rig.events if "kind" in e]


def test_mission_pause_pauses_the_search_and_mission_resume_continues_the_same_move(rig) -> None:
    s = rig.session
    rig.search.start(SearchConfig("robot dog", max_captures=12, target_height=0.4))
    _until(lambda: _moving(rig) and math.dist(_pos(rig)[:2], (2.5, 0.7)) > 0.3, "the search's first move")
    captures = rig.search.result.captures
    rig.runner.pause()  # the mission panel's Pause
    _until(lambda: s.run.state == "paused" and rig.search.paused, "the move and the search to pause")
    assert "mission Pause" in rig.search.pause_reason
    here = _pos(rig)
    time.sleep(0.5)
    assert math.dist(_pos(rig), here) < 0.02 and rig.search.result.captures == captures  # it holds: nothing moves
    rig.runner.resume()  # the mission panel's Resume: the same move goes on, and the search with it
    _until(lambda: not rig.search.paused, "the search to go on with the move")
    _until(lambda: rig.search.result.captures > captures, "the capture at the end of the move")
    assert "resumed" in _kinds(rig)
    rig.search.stop()
    assert rig.search.wait(300) and rig.search.result.reason == "stopped by the operator"


def test_find_resume_continues_a_move_the_mission_panel_paused(rig) -> None:
    s = rig.session
    rig.search.start(SearchConfig("robot dog", max_captures=12, target_height=0.4))
    _until(lambda: _moving(rig) and math.dist(_pos(rig)[:2], (2.5, 0.7)) > 0.3, "the search's first move")
    captures = rig.search.result.captures
    rig.runner.pause()
    _until(lambda: rig.search.paused, "the search to pause with the move")
    rig.search.resume()  # the Find panel's Resume continues the paused move (the manager's Resume)
    _until(lambda: s.run.state in ("running", "done"), "the move to go on")
    _until(lambda: rig.search.result.captures > captures, "the capture at the end of the move")
    rig.search.stop()
    assert rig.search.wait(300)


def test_mission_abort_ends_the_move_pauses_the_search_and_resume_plans_again(rig) -> None:
    s = rig.session
    rig.search.start(SearchConfig("robot dog", max_captures=12, target_height=0.4))
    _until(lambda: _moving(rig) and math.dist(_pos(rig)[:2], (2.5, 0.7)) > 0.3, "the search's first move")
    captures = rig.search.result.captures
    rig.runner.abort()  # the mission panel's Abort: the move ends, the robot holds, the search pauses
    _until(lambda: not s.run.active and rig.search.paused, "the move to end and the search to pause")
    assert "aborted" in rig.search.pause_reason and rig.search.running
    time.sleep(0.5)
    assert rig.search.result.captures == captures and not s.run.active  # nothing starts on its own
    rig.search.resume()
    _until(lambda: rig.search.result.captures > captures, "a capture after Resume")
    assert "resumed" in _kinds(rig)
    rig.search.stop()
    assert rig.search.wait(300)


def test_hold_during_a_turn_in_the_air_pauses_the_search(rig) -> None:
    s = rig.session
    rig.search.start(SearchConfig("robot dog", max_captures=30, target_height=0.4))

    def turning_in_the_air() -> bool:  # between moves (no mission runs) the simulator flies a turn in place
        st = rig.robot.latest_state()
        return st.position[2] > 0.5 and not s.run.active and rig.search.running and st.mode.value == "flying"

    _until(turning_in_the_air, "a turn in the air")
    msg = rig.commands.run("hold")  # Hold shows between moves while the robot is off the ground
    assert "holds" in msg, msg
    _until(lambda: rig.search.paused, "the search to pause")
    assert "Hold" in rig.search.pause_reason, rig.search.pause_reason
    captures = rig.search.result.captures
    time.sleep(0.5)
    assert rig.search.result.captures == captures and not s.run.active  # nothing starts on its own
    rig.search.stop()
    assert rig.search.wait(300) and rig.search.result.reason == "stopped by the operator"


def test_land_here_behind_the_line_lands_on_seen_floor_and_resume_walks_and_flies_on(rig) -> None:
    s = rig.session
    rig.search.start(SearchConfig("robot dog", max_captures=30, target_height=0.4))
    _until(lambda: (lambda p: p[1] > 4.2 and p[2] > 0.5)(_pos(rig)), "a flight over the line of boxes")
    rig.search.pause()
    _until(lambda: not s.run.active and rig.search.paused, "the move to end where the robot is")
    _until(lambda: _kinds(rig)[-1:] == ["paused"], "the search to say it is paused")
    held = _pos(rig)
    assert held[2] > 0.5 and s.plan_unknown == "closed"
    state = s.operator_state(True).commands["land"]
    assert state.enabled, state  # over floor no capture saw: a search lands on the nearest seen-free floor
    msg = rig.commands.run("land")
    assert msg.startswith("land here: landing at"), msg
    _until(lambda: s.run.state == "done" and _pos(rig)[2] < 0.05, "the landing")
    spot = _pos(rig)
    from console.session.operator_state import unseen_floor

    assert not unseen_floor(spot, s.grid)  # landed on floor seen free
    captures = rig.search.result.captures
    rig.search.resume()
    _until(lambda: rig.search.result.captures > captures or not rig.search.running, "a capture after Resume")
    assert rig.search.running, rig.search.result
    resumed = [e for e in rig.events if e.get("kind") == "resumed"]
    assert resumed and resumed[-1]["robot"][2] < 0.05  # from where it landed
    moves = [e for e in rig.events if e.get("kind") == "move" and e.get("mission")]
    assert moves[-1]["mission"]["kinds"][0] == "walk" or moves[-1]["mission"]["kinds"][0] == "takeoff"
    rig.search.stop()
    assert rig.search.wait(300)


def test_land_here_while_the_search_captures_pauses_it_and_return_then_resume_searches_from_the_launch_spot(rig) -> None:
    s = rig.session
    rig.search.start(SearchConfig("robot dog", max_captures=30, target_height=0.4))
    _until(lambda: _pos(rig)[2] > 0.5 and _moving(rig), "a flight")
    _until(lambda: not s.run.active and rig.search.running and _pos(rig)[2] > 0.5, "the move's end in the air")
    try:
        rig.commands.run("return")  # between moves: Return takes over and the search pauses
    except SessionError as exc:  # the search started its next move meanwhile: pause it first
        assert "mission" in str(exc), exc
        rig.search.pause()
        _until(lambda: not s.run.active and rig.search.paused, "the pause")
        rig.commands.run("return")
    launch = s.operator_state(True).launch  # where Return lands: the take-off spot
    _until(lambda: rig.search.paused, "the search to pause for Return")
    _until(lambda: not s.run.active and _pos(rig)[2] < 0.05, "the return and landing")
    assert launch is not None and math.dist(_pos(rig)[:2], launch[:2]) < 0.3, (launch, _pos(rig))
    captures = rig.search.result.captures
    rig.search.resume()
    _until(lambda: rig.search.result.captures > captures, "a capture after Resume")
    resumed = [e for e in rig.events if e.get("kind") == "resumed"]
    assert math.dist(resumed[-1]["robot"][:2], launch[:2]) < 0.3
    rig.search.stop()
    assert rig.search.wait(300)


def test_battery_budget_ends_the_search_before_the_battery_rules_act_and_says_what_was_left_unseen(rig) -> None:
    rig.search.start(SearchConfig("robot dog", max_captures=30, target_height=0.4, min_battery=0.4))
    _until(lambda: rig.search.result is not None and rig.search.result.captures >= 1, "the first capture")
    rig.robot.set_battery(0.38)  # below the search's reserve, above the console's low-battery rule
    assert rig.search.wait(DEADLINE)
    r = rig.search.result
    assert r.reason.startswith("battery: 38 % left, below the search's reserve of 40 %"), r.reason
    assert not r.found and r.battery is not None and r.battery > BATTERY_LOW
    assert "m² of floor unseen" in r.left_unseen and "reachable" in r.left_unseen, r.left_unseen
    ends = [e for e in rig.events if "found" in e]
    assert len(ends) == 1 and ends[0]["reason"] == r.reason and ends[0]["left_unseen"] == r.left_unseen


def test_battery_budget_is_checked_naming_the_field() -> None:
    with pytest.raises(SessionError, match="min_battery: must be finite and within 0.25..1"):
        SearchConfig("robot dog", min_battery=0.1)
    with pytest.raises(SessionError, match="min_battery"):
        SearchConfig("robot dog", min_battery=float("nan"))
