"""An agent may propose a search (Find); nothing starts until the operator approves, bad arguments are
refused naming the field, and the agent's Hold pauses a running search (the robot holds)."""

from __future__ import annotations

from pathlib import Path

import pytest

from console.link.world import paper_room
from console.mcp.door import AgentDoor, AgentError
from console.session.session import Session


class FakeSearch:
    """The search job's surface the door uses."""

    def __init__(self) -> None:
        self.started: list = []
        self.running = False
        self.paused = False

    def start(self, config) -> None:
        self.started.append(config)
        self.running = True

    def pause(self) -> None:
        self.paused = True


@pytest.fixture()
def door(tmp_path: Path):
    s = Session(tmp_path / "s")
    s.spawn(paper_room(), origin="test")
    search = FakeSearch()
    d = AgentDoor(s, runner=None, robot_spec="sim", search=search)
    yield d, search
    d.close()


def test_a_search_starts_only_when_the_operator_approves(door) -> None:
    d, search = door
    with pytest.raises(AgentError, match="proposals are off"):
        d.call("propose_search", {"target": "robot dog", "why": "find the dog"})
    p = d.call("propose_search", {"target": "robot dog", "why": "the paper's search", "mode": "step",
                                  "max_captures": 8}, allow_actions=True)
    assert p["state"] == "pending" and search.started == []  # nothing moves before the operator decides
    decided = d.queue.approve(p["id"])
    assert decided.state == "approved" and "search for 'robot dog' started (step mode, at most 8 captures)" in decided.outcome
    (config,) = search.started
    assert config.target == "robot dog" and config.mode == "step" and config.max_captures == 8
    assert config.target_height > 0.0


def test_a_rejected_search_never_starts(door) -> None:
    d, search = door
    p = d.call("propose_search", {"target": "robot dog", "why": "look"}, allow_actions=True)
    assert d.queue.reject(p["id"], "battery low").outcome == "rejected by the operator: battery low"
    assert search.started == []


@pytest.mark.parametrize("args, field", [
    ({"target": "robot dog"}, "why"),
    ({"why": "x"}, "target"),
    ({"target": "robot dog", "why": "x", "mode": "wander"}, "mode"),
    ({"target": "robot dog", "why": "x", "max_captures": 0}, "max_captures"),
    ({"target": "robot dog", "why": "x", "max_captures": 2.5}, "max_captures"),
])
def test_bad_search_arguments_name_the_field(door, args, field) -> None:
    d, search = door
    with pytest.raises(AgentError, match=field):
        d.call("propose_search", args, allow_actions=True)
    assert search.started == []


def test_the_agents_hold_pauses_a_running_search(door) -> None:
    d, search = door
    search.running = True
    assert "the search is paused" in d.call("hold", {"why": "a person walked in"})
    assert search.paused
