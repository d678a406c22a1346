"""Go look on the simulator without the browser: the chain of looks towards a goal behind the paper's
line of boxes until its route is planned, and the route then lands behind the line.

Ground-truth perception (the simulator's rendered depth for the known space), time x10; waits on the
jobs' state with generous deadlines (the machine may be loaded)."""

from __future__ import annotations

import math
import time
from pathlib import Path

import pytest

from console.session.go_look import looked_from
from console.session.session import SessionError

GOAL = (2.5, 5.0, 0.0)
MAX_LOOKS = 4


def _run_mission(rig) -> str:
    s = rig.session
    states: list[str] = []  # this mission's states (the last look's move ended "done" too)
    s.subscribe(lambda t, p: states.append(p.state) if t == "run" else None)
    rig.runner.execute(s.build_mission())
    end = time.monotonic() + 600
    while time.monotonic() < end:
        if "running" in states and states[-1] in ("done", "aborted", "failed"):
            return states[-1]
        time.sleep(0.05)
    return "timeout"


def test_go_look_chain_opens_a_goal_behind_the_line_and_the_route_lands_there(rig) -> None:
    s = rig.session
    assert rig.mapping.run_as("start")
    first = s.add_goal(GOAL)
    assert not first.ok and "not seen yet" in first.message and "Go look" in first.message, first.message
    kinds: list[str] = []
    for _ in range(MAX_LOOKS):
        rig.go_look.start(GOAL[:2])
        assert rig.go_look.wait(900), "Go look did not end"
        out = rig.go_look.outcome
        assert s.job.error is None, s.job.error
        if out.planned:
            break
        assert out.next_look is not None and "next look from (" in out.message, out.message
        assert "the floor at (2.50, 5.00) is still " in out.message
    out = rig.go_look.outcome
    assert out.planned, out.message
    assert 1 <= out.looks <= MAX_LOOKS
    kinds += out.kinds
    # no look repeats a capture's spot and heading
    poses = looked_from(s)
    for n, (a, ya) in enumerate(poses):
        for b, yb in poses[n + 1:]:
            assert not (math.dist(a, b) < 0.3 and abs((ya - yb + math.pi) % (2 * math.pi) - math.pi) < 0.2)
    s.register()
    final = s.build_mission()
    kinds.append("-".join(dict.fromkeys(final.kinds())))
    assert final.kinds()[-1] in ("land", "walk") and "land" in final.kinds()
    assert _run_mission(rig) == "done", s.run.message
    pos = rig.robot.latest_state().position
    assert pos[1] > 4.3 and pos[2] < 0.05 and math.dist(pos[:2], GOAL[:2]) < 0.5, pos
    journey = "-".join(kinds).split("-")
    assert journey[0] == "walk" and journey.index("takeoff") < journey.index("fly") < len(journey) - 1 - journey[::-1].index("land")


def test_go_look_refuses_bad_goals_and_a_busy_robot(rig) -> None:
    with pytest.raises(SessionError, match="finite"):
        rig.go_look.start((float("nan"), 1.0))
    with pytest.raises(SessionError, match="outside the workspace"):
        rig.go_look.start((9.0, 1.0))


def _wait_for(pred, what: str, timeout: float = 600.0) -> None:
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        if pred():
            return
        time.sleep(0.05)
    raise AssertionError(f"timed out waiting for {what}")


def test_pause_holds_the_move_resume_finishes_the_look_and_stop_aborts(rig) -> None:
    s, job = rig.session, rig.go_look
    assert rig.mapping.run_as("start")
    job.start(GOAL[:2])
    _wait_for(lambda: s.run.state == "running", "the move to the first look")
    job.pause()
    _wait_for(lambda: s.run.state == "paused", "the move to pause")
    assert job.paused and job.running
    _wait_for(lambda: math.hypot(*rig.robot.latest_state().velocity) < 0.02, "the robot to hold", 60)
    with pytest.raises(SessionError, match="already running"):
        job.start(GOAL[:2])
    job.resume()
    assert job.wait(900)
    assert job.outcome.looks == 1 and s.job.error is None, job.outcome.message
    # the next look, stopped on its way: the move is aborted, the look ends, no capture taken
    captures = len(s.scene.captures)
    job.start(GOAL[:2])
    _wait_for(lambda: s.run.state == "running" or not job.running, "the move to the next look")
    assert job.running, job.outcome.message  # the next look is elsewhere: a move is under way
    job.stop()
    assert job.wait(120)
    assert "stopped" in job.outcome.message and s.run.state == "aborted", (job.outcome.message, s.run)
    assert len(s.scene.captures) == captures
