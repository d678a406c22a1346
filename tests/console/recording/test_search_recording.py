"""A search is recorded step by step (/search/step, /search/result follow their schemas) and replay draws
its viewpoints and the chosen paths. The search runs headless on the simulator in the paper's room (step
mode: three approved steps, the first two turns in place and the third a walk, then Stop), recorded by the console's Recorder; every wait is on state."""

from __future__ import annotations

import dataclasses
import json
import time
from pathlib import Path
from typing import Any

import pytest
from jsonschema import Draft202012Validator
from mcap.reader import make_reader

from console.cli.search_cmd import HeadlessRig
from console.link.world_file import paper_world
from console.recording import recording_schemas as rs
from console.recording.channel_schemas import CHANNEL_SCHEMAS
from console.recording.recording import Recorder
from console.session.search import SearchConfig


def _until(cond: Any, what: str, timeout: float = 600.0) -> None:
    deadline = time.monotonic() + timeout
    while not cond():
        if time.monotonic() > deadline:
            raise AssertionError(f"timed out waiting for {what}")
        time.sleep(0.02)


@pytest.fixture(scope="module")
def recorded(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Any]:
    tmp = tmp_path_factory.mktemp("search_rec")
    rig = HeadlessRig(paper_world(), tmp / "s", time_scale=8.0)
    rec = Recorder(rig.session, folder=tmp / "rec").start()
    try:
        rig.search.start(SearchConfig("robot dog", mode="step", max_captures=6, target_height=0.4))
        for n in range(3):  # three approved steps, each with its capture
            _until(lambda: rig.search.waiting_approval, f"proposed move {n + 1}")
            captures = rig.search.result.captures
            rig.search.approve()
            _until(lambda: rig.search.result.captures > captures or not rig.search.running, f"capture after move {n + 1}")
        _until(lambda: rig.search.waiting_approval, "the fourth proposed move")
        rig.search.stop()
        assert rig.search.wait(300)
        result = rig.search.result
    finally:
        rig.close()
        rec.close()
    assert rec.failed is None and rec.paths
    return rec.paths[0], result


def test_search_steps_and_result_are_recorded_following_their_schemas(recorded: Any) -> None:
    path, result = recorded
    steps, ends = [], []
    with open(path, "rb") as f:
        for schema, channel, message in make_reader(f).iter_messages():
            if channel.topic in (rs.SEARCH_STEP, rs.SEARCH_RESULT):
                assert channel.message_encoding == "json" and schema.encoding == "jsonschema"
                assert json.loads(schema.data) == CHANNEL_SCHEMAS[channel.topic]
                data = json.loads(message.data)
                errors = [e.message for e in Draft202012Validator(CHANNEL_SCHEMAS[channel.topic]).iter_errors(data)]
                assert errors == [], (channel.topic, data)
                (ends if channel.topic == rs.SEARCH_RESULT else steps).append(data)
    kinds = [s["kind"] for s in steps]
    assert kinds[0] == "start" and kinds.count("viewpoint") >= 4 and kinds.count("approve") >= 4
    assert [s["index"] for s in steps] == list(range(1, len(steps) + 1))
    chosen = [s for s in steps if s["kind"] == "viewpoint"]
    assert all(s["viewpoint"]["gain"] > 0 and s["viewpoint"]["why"] and s["candidates"] for s in chosen)
    assert all(s["choose_seconds"] is not None and s["choose_seconds"] >= 0 for s in chosen)
    caps = [s["capture_id"] for s in steps if s["kind"] == "capture"]
    assert len(caps) == result.captures and all(caps), caps  # every capture's id
    moves = [s for s in steps if s["kind"] == "move" and s["mission"]]
    assert moves and all(len(m["mission"]["path"]) >= 2 and m["mission"]["kinds"] for m in moves)
    assert len(ends) == 1 and ends[0]["reason"] == "stopped by the operator" and ends[0]["found"] is False
    assert ends[0]["search_id"] == steps[0]["search_id"] and ends[0]["captures"] == result.captures
    assert ends[0]["left_unseen"], ends[0]  # what was left unseen, and why
    assert ends[0]["contacts"] == result.contacts  # every field of the result, contacts too
    assert {k for k in ends[0] if k != "search_id"} == set(dataclasses.asdict(result))


def test_replay_draws_the_viewpoints_and_the_chosen_paths(recorded: Any) -> None:
    from console.cli.replay_cmd import open_replay

    path, result = recorded
    app = open_replay(path, port=0)
    try:
        rec = app.recording
        end = rec.state_at(rec.end)
        assert end.search_result is not None and end.search_result["reason"] == "stopped by the operator"
        assert end.search_result["contacts"] == result.contacts  # replay reads every field of the result
        view = app.views["search"]
        app.seek(rec.duration)
        assert view.drawn["viewpoints"] >= 3 and view.drawn["paths"] >= 1, view.drawn
        assert "stopped by the operator" in view._line.content
        first_move = rec.times(rs.SEARCH_STEP)[0]
        app.seek_time(first_move)  # at the first step: nothing chosen yet
        assert view.drawn == {"viewpoints": 0, "paths": 0}
        assert "searching for robot dog" in view._line.content
    finally:
        app.stop()


def test_the_replay_line_says_how_many_moves_ended_in_a_contact() -> None:
    from console.recording.replay_search import search_line

    steps = [{"search_id": "s1", "index": 4, "text": "capture 2"}]
    end = {"search_id": "s1", "found": True, "reason": "found robot_dog-1 at 0.62 m", "left_unseen": "", "contacts": 2}
    assert "2 moves ended in a contact with something the map did not show" in search_line(steps, end)
    assert "contact" not in search_line(steps, {**end, "contacts": 0})
    old = {k: v for k, v in end.items() if k != "contacts"}  # a recording made before the field
    assert "found robot_dog-1" in search_line(steps, old) and "contact" not in search_line(steps, old)
