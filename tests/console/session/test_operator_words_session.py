"""Words a new operator read in the console: a detection the map did not use is named by the photo (never
by a map-like id that a map object may carry), the Find panel's end line says what the notice says, and
Go look on the robot's own spot gives Look at goal's reason. World frame, z up [m]."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from console.session.search_report import result_line
from console.session.search_types import SearchResult
from console.session.session import SessionError
from pipeline.mapping.map_fusion import fuse
from pipeline.scene import Scene, SceneObject

BOUNDS = ((0.0, 0.0, 0.0), (5.0, 8.0, 3.0))
BOX = (0.4, 0.3, 0.4)


def test_a_detection_not_used_is_named_by_the_photo_not_like_a_map_object() -> None:
    # the map's cardboard_box-1 is at (1, 1); the capture's own "cardboard_box-1" is another box, outside the room
    mapped = Scene(objects=(SceneObject("cardboard_box-1", "cardboard_box", (1.0, 1.0, 0.15), BOX),))
    seen = Scene(objects=(SceneObject("cardboard_box-1", "cardboard_box", (9.0, 1.0, 0.15), BOX, score=0.81),))
    _, report = fuse(mapped, seen, bounds=BOUNDS, check_consistency=False)
    notes = [n for n in report.notes() if "not used" in n]
    assert notes and notes[0].startswith("detection 1 (cardboard_box, 0.81) not used: "), report.notes()
    assert not any("cardboard_box-1" in n for n in notes), notes  # before: "cardboard_box-1 (cardboard_box) not used"
    assert report.rejected[0].name == "detection 1 (cardboard_box, 0.81)"


def test_find_panel_line_says_what_the_notice_says() -> None:
    found = SearchResult(found=True, target="robot dog", target_id="robot_dog-1", distance_to_target=0.98,
                         captures=12, path_length=39.1, reason="found")
    assert result_line(found) == "found robot_dog-1 at 0.98 m (12 captures, 39.1 m travelled)"
    ended = SearchResult(reason="not found: budget of 1 capture used", captures=1, path_length=0.0)
    assert result_line(ended) == "not found: budget of 1 capture used (1 capture, 0.0 m travelled)"


def test_find_panel_draws_the_result_line(tmp_path: Path) -> None:
    from types import SimpleNamespace

    import viser

    from console.session.search_types import target_height
    from console.session.session import Session
    from console.views.search_view import SearchView

    result = SearchResult(found=True, target_id="robot_dog-1", distance_to_target=0.98, captures=12,
                          path_length=39.1, reason="found")
    job = SimpleNamespace(running=False, paused=False, waiting_approval=False, pause_reason="", steps=[],
                          result=result, chosen=None)
    server = viser.ViserServer(host="127.0.0.1", port=0, verbose=False)
    view = SearchView(server, Session(tmp_path / "s", autosave=False), job, target_height)  # type: ignore[arg-type]
    try:
        view._refresh()
        # before: "found: found (12 captures, 39.1 m)"
        assert view.line.content == "<small><b>found robot_dog-1 at 0.98 m (12 captures, 39.1 m travelled)</b></small>"
    finally:
        view._refresher.close()
        server.stop()


def test_go_look_on_the_robots_own_spot_says_look_at_goals_reason(rig) -> None:
    from console.session.look import LookJob

    p = rig.robot.latest_state().position
    spot = (float(p[0]), float(p[1]))
    # before: it started and ended "no reachable spot sees (2.50, 0.70) or the space around it: Look around"
    with pytest.raises(SessionError) as go:
        rig.go_look.start(spot)
    look = LookJob(rig.session, rig.robot, rig.mapping)
    with pytest.raises(SessionError) as at:
        look.look_at(spot)
    reason = f"({spot[0]:.2f}, {spot[1]:.2f}) is right at the robot: no heading to face"
    assert str(go.value) == f"go look: {reason}" and str(at.value) == f"look at: {reason}", (go.value, at.value)
    assert not rig.go_look.running and math.isfinite(spot[0])


def test_an_agents_search_of_one_capture_says_one_capture(tmp_path: Path) -> None:
    from console.mcp.door import AgentDoor
    from console.session.session import Session

    class _Search:
        running = paused = False

        def start(self, config) -> None:
            self.running = True

    door = AgentDoor(Session(tmp_path / "s"), runner=None, robot_spec="sim", search=_Search())
    try:
        p = door.call("propose_search", {"target": "robot dog", "why": "one look", "max_captures": 1},
                      allow_actions=True)
        assert p["title"].endswith("(auto mode, at most 1 capture)"), p  # before: "at most 1 captures"
        assert door.queue.approve(p["id"]).outcome == "search for 'robot dog' started (auto mode, at most 1 capture)"
    finally:
        door.close()
