"""An agent's proposed search for something the perception cannot name is refused as the console's Find panel and
`morphonavi search` refuse it (one check: SearchConfig's target), and a synonym of a class is accepted."""

from __future__ import annotations

from pathlib import Path

import pytest

from console.link.world import paper_room
from console.mcp.door import AgentDoor, AgentError
from console.session.session import Session


class _Search:
    def __init__(self) -> None:
        self.started: list = []
        self.running = self.paused = False

    def start(self, config) -> None:
        self.started.append(config)


@pytest.fixture()
def door(tmp_path: Path):
    s = Session(tmp_path / "s")
    s.spawn(paper_room(), origin="test")
    search = _Search()
    d = AgentDoor(s, runner=None, robot_spec="sim", search=search)
    yield d, search
    d.close()


def test_an_unknown_target_is_refused_naming_the_field_and_what_it_can_find(door) -> None:
    d, search = door
    with pytest.raises(AgentError) as err:
        d.call("propose_search", {"target": "unicorn", "why": "look"}, allow_actions=True)
    text = str(err.value)
    assert text.startswith("target: 'unicorn' is not an object the perception can name"), text
    assert "robot dog" in text and "assets/catalog.toml" in text
    assert search.started == []


def test_a_synonym_of_a_class_is_proposed(door) -> None:
    d, search = door
    p = d.call("propose_search", {"target": "quadruped", "why": "the paper's search"}, allow_actions=True)
    assert p["state"] == "pending" and search.started == []  # nothing starts before the operator approves
    d.queue.approve(p["id"])
    (config,) = search.started
    assert config.target == "quadruped" and config.target_height == pytest.approx(0.4)  # the robot dog's height
