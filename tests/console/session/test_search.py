"""The Find loop on the simulator: step mode waits for Approve; Pause holds, Land here acts, Resume
searches on; Stop ends it. (Automatic mode finding the dog: tests/console/cli/test_search_cli.py.)"""

from __future__ import annotations

import math
import time
from pathlib import Path

import pytest

from console.cli.search_cmd import HeadlessRig
from console.link.world_file import paper_world
from console.session.search import SearchConfig, target_matches
from console.session.session import NOTICE, SessionError

DOG = (2.5, 6.3)


def _until(cond, what: str, timeout: float = 600.0) -> None:
    deadline = time.monotonic() + timeout
    while not cond():
        if time.monotonic() > deadline:
            raise AssertionError(f"timed out waiting for {what}")
        time.sleep(0.02)


@pytest.fixture
def rig(tmp_path: Path):
    r = HeadlessRig(paper_world(), tmp_path / "s", time_scale=8.0)
    notices: list[str] = []
    r.session.subscribe(lambda t, p: notices.append(f"{p.title}: {p.body}") if t == NOTICE else None)
    r.notices = notices  # type: ignore[attr-defined]
    try:
        yield r
    finally:
        r.close()


def test_config_is_checked_naming_the_field() -> None:
    with pytest.raises(SessionError, match="mode: must be one of auto, step"):
        SearchConfig("robot dog", mode="fast")
    with pytest.raises(SessionError, match="max_captures: must be a whole number"):
        SearchConfig("robot dog", max_captures=0)
    with pytest.raises(SessionError, match="max_time: must be finite"):
        SearchConfig("robot dog", max_time=float("inf"))
    with pytest.raises(SessionError, match="target: must be 1..200 characters"):
        SearchConfig("  ")
    assert target_matches("robot_dog", "Robot dog") and target_matches("robot_dog", "robot dogs")
    assert not target_matches("robot_dog", "dog")


def test_pause_holds_in_the_air_land_here_acts_and_resume_searches_on(rig) -> None:
    s = rig.session
    rig.search.start(SearchConfig("robot dog", max_captures=16, target_height=0.4))
    _until(lambda: rig.robot.latest_state().position[2] > 0.5 and s.run.state == "running", "a flight")
    rig.search.pause()
    _until(lambda: not s.run.active, "the move to end where the robot is")
    assert rig.robot.latest_state().position[2] > 0.3  # holding in the air
    _until(lambda: "paused" in s.job.message, "the search to say it is paused")
    msg = rig.commands.run("land")  # Land here acts during a paused search, as after aborting a mission
    assert msg.startswith("land here: landing at"), msg
    _until(lambda: s.run.state == "done" and rig.robot.latest_state().position[2] < 0.05, "the landing")
    captures = rig.search.result.captures
    rig.search.resume()
    _until(lambda: rig.search.result.captures > captures, "a capture after Resume")  # it searches on from here
    rig.search.stop()
    assert rig.search.wait(300)
    assert rig.search.result.reason == "stopped by the operator"


def test_step_mode_waits_for_approve_and_stop_ends_the_search(rig) -> None:
    s = rig.session
    rig.search.start(SearchConfig("robot dog", mode="step", max_captures=5, target_height=0.4))
    with pytest.raises(SessionError, match="a search is already running"):
        rig.search.start(SearchConfig("robot dog"))
    _until(lambda: rig.search.waiting_approval, "the first proposed move")
    assert rig.search.chosen is not None and "m³ of unknown space" in rig.search.chosen.why
    start = rig.robot.latest_state().position
    time.sleep(0.5)
    assert rig.robot.latest_state().position == pytest.approx(start, abs=1e-6)  # nothing moves unapproved
    captures = rig.search.result.captures
    rig.search.approve()
    _until(lambda: rig.search.result.captures > captures, "the approved step's capture")
    _until(lambda: rig.search.waiting_approval, "the next proposed move")
    rig.search.stop()
    assert rig.search.wait(120)
    assert rig.search.result.reason == "stopped by the operator" and not rig.search.result.found
    with pytest.raises(SessionError, match="no move is waiting for approval"):
        rig.search.approve()
    assert s.job.message.startswith("stopped by the operator")
