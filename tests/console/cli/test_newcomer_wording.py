"""Found by trying the console as a newcomer: counts read with the right plural, no "segment(s)"."""

from __future__ import annotations

from pipeline.scene import SceneObject
from planner.grid import Workspace, build_grid
from planner.route import Route


def _blocked_route(stops: list[tuple[float, float, float]]) -> list[str]:
    route = Route(build_grid([], Workspace(resolution=0.25), margin=0.3), (0.5, 0.5, 0.0))
    for stop in stops:
        assert route.propose(stop).ok
        route.register()
    wall = SceneObject("wall", "cardboard_box", (2.5, 1.5, 1.5), (0.5, 3.0, 5.0))  # across every stop's path
    return route.set_grid(build_grid([wall], Workspace(resolution=0.25), margin=0.3))


def test_one_removed_segment_is_counted_in_the_singular() -> None:
    notes = _blocked_route([(4.5, 1.5, 0.0)])
    assert "1 registered segment now crosses obstacles and was removed" in notes
    assert not any("(s)" in n for n in notes)


def test_two_removed_segments_are_counted_in_the_plural() -> None:
    notes = _blocked_route([(4.5, 1.5, 0.0), (4.5, 3.0, 0.0)])
    assert "2 registered segments now cross obstacles and were removed" in notes


def _removal_notices(tmp_path, stops: list[tuple[float, float, float]]) -> list[str]:
    from console.session.session import Session
    from console.session.topics import NOTICE
    from pipeline.scene import Scene

    session = Session(tmp_path / "session", start=(0.5, 0.5, 0.0))
    for stop in stops:
        assert session.add_goal(stop).ok
        session.register()
    seen: list[str] = []
    session.subscribe(lambda topic, payload: seen.append(payload.body) if topic == NOTICE else None)
    session.spawn(Scene((SceneObject("wall", "cardboard_box", (2.5, 1.5, 1.5), (0.5, 3.0, 2.9)),)))
    return [b for b in seen if "registered segment" in b]


def test_the_session_notice_for_one_removed_segment_agrees_in_number(tmp_path) -> None:
    (body,) = _removal_notices(tmp_path, [(4.5, 1.5, 0.0)])
    assert "registered segment 1 (to (4.62, 1.62, 0.00)) now crosses obstacles and was removed" in body, body
    assert body.endswith("Undo brings it back."), body


def test_the_session_notice_for_two_removed_segments_agrees_in_number(tmp_path) -> None:
    (body,) = _removal_notices(tmp_path, [(4.5, 1.5, 0.0), (4.5, 3.0, 0.0)])
    assert ("registered segments 1-2 (to (4.62, 1.62, 0.00), (4.62, 3.12, 0.00)) now cross obstacles and were removed"
            in body), body
    assert body.endswith("Undo brings them back."), body


def _flight_mission():
    from planner.mission import Mission, MissionSegment, SegmentKind

    return Mission((
        MissionSegment(SegmentKind.WALK, ((0.5, 0.5, 0.0), (1.0, 0.5, 0.0))),
        MissionSegment(SegmentKind.TAKEOFF, ((1.0, 0.5, 0.0), (1.0, 0.5, 0.4))),
        MissionSegment(SegmentKind.FLY, ((1.0, 0.5, 0.4), (2.0, 0.5, 1.5))),
        MissionSegment(SegmentKind.LAND, ((2.0, 0.5, 1.5), (2.0, 0.5, 0.0))),
    ), bounds_min=(0.0, 0.0, 0.0), bounds_max=(5.0, 8.0, 3.0))


def test_segment_kinds_read_as_words_everywhere_the_operator_sees_them() -> None:
    from console.views.mission_view import built_text, segment_table
    from console.views.paths_view import legend_html

    mission = _flight_mission()
    assert built_text(mission) == "4 segments: walk → take-off → fly → land"
    assert "take-off" in segment_table(mission) and "takeoff" not in segment_table(mission)
    assert "take-off" in legend_html() and "takeoff" not in legend_html()  # the legend names what the table says


def test_the_go_to_list_is_in_natural_order() -> None:
    from console.views.scene_summary_view import goto_entries

    objs = [SceneObject(i, "cardboard_box", (1.0, 1.0, 0.2), (0.45, 0.4, 0.45))
            for i in ("cardboard_box-10", "cardboard_box-2", "cardboard_box-1", "cardboard_box-2-2")]
    objs.append(SceneObject("compressor-1", "compressor", (2.0, 1.0, 0.2), (0.4, 0.5, 0.4)))
    ids = list(goto_entries(objs).values())
    assert ids == ["cardboard_box-1", "cardboard_box-2", "cardboard_box-2-2", "cardboard_box-10", "compressor-1"]


def test_the_route_start_says_its_height_when_the_robot_hovers() -> None:
    from types import SimpleNamespace

    from console.views.paths_view import PathsView

    hovering = SimpleNamespace(start=(2.62, 0.62, 1.62), registered=(), candidate=None, candidate_goal=None)
    assert "Start (2.62, 0.62, 1.62) m" in PathsView._route_text(hovering)
    standing = SimpleNamespace(start=(2.5, 0.7, 0.0), registered=(), candidate=None, candidate_goal=None)
    assert "Start (2.50, 0.70) m" in PathsView._route_text(standing)  # on the floor: x, y as before


def test_no_mission_text_does_not_ask_for_a_path_that_is_registered() -> None:
    from console.views.mission_view import no_mission_text

    assert "register a path" in no_mission_text(registered=0)
    text = no_mission_text(registered=2)
    assert "register a path" not in text and "Build mission" in text
