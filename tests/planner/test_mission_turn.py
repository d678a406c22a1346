"""TURN segments: yaw in place to a heading, validated, and a JSON round trip."""

from __future__ import annotations

import json
import math

import pytest

from planner.mission import Mission, MissionError, MissionSegment, SegmentKind, heading_to, turn_segment


def test_turn_round_trips_through_json(tmp_path) -> None:
    walk = MissionSegment(SegmentKind.WALK, ((1.0, 1.0, 0.0), (2.0, 1.0, 0.0)))
    turn = turn_segment((2.0, 1.0, 0.0), math.radians(135))
    m = Mission((walk, turn))
    path = m.save(tmp_path / "m.json")
    data = json.loads(path.read_text())
    assert data["segments"][1] == {"kind": "turn", "waypoints": [[2.0, 1.0, 0.0]], "yaw": round(math.radians(135), 6)}
    back = Mission.load(path)
    assert back.kinds() == ["walk", "turn"]
    assert back.segments[1].yaw == pytest.approx(math.radians(135), abs=1e-6)
    assert back.segments[1].length == 0.0
    assert "to heading 135 deg" in back.summary()


def test_turn_yaw_is_wrapped_and_heading_to_points_at_the_target() -> None:
    assert turn_segment((0, 0, 0), 3 * math.pi / 2).yaw == pytest.approx(-math.pi / 2)
    assert heading_to((1, 1, 0), (1, 3, 0)) == pytest.approx(math.pi / 2)
    assert heading_to((1, 1, 0), (0, 1, 5)) == pytest.approx(math.pi)
    with pytest.raises(MissionError, match="right at the robot"):
        heading_to((1, 1, 0), (1, 1, 2))


@pytest.mark.parametrize("seg, message", [
    ({"kind": "turn", "waypoints": [[0, 0, 0]]}, r"segments\[0\]\.yaw: must be a finite number"),
    ({"kind": "turn", "waypoints": [[0, 0, 0]], "yaw": "north"}, r"segments\[0\]\.yaw: must be a finite number"),
    ({"kind": "turn", "waypoints": [[0, 0, 0]], "yaw": float("nan")}, r"segments\[0\]\.yaw"),
    ({"kind": "turn", "waypoints": [[0, 0, 0], [1, 0, 0]], "yaw": 0.0}, r"segments\[0\]: turn segment needs exactly 1"),
    ({"kind": "walk", "waypoints": [[0, 0, 0], [1, 0, 0]], "yaw": 0.5}, r"segments\[0\]\.yaw: only a turn"),
    ({"kind": "spin", "waypoints": [[0, 0, 0]]}, r"walk/takeoff/fly/land/turn"),
])
def test_bad_turns_name_the_field(seg, message) -> None:
    with pytest.raises(MissionError, match=message):
        Mission.from_dict({"version": 1, "segments": [seg]})


def test_yaw_only_on_turns_in_code() -> None:
    with pytest.raises(MissionError, match="yaw is only for a turn"):
        MissionSegment(SegmentKind.FLY, ((0, 0, 1), (1, 0, 1)), yaw=0.3)
    with pytest.raises(MissionError, match="yaw must be a finite number"):
        MissionSegment(SegmentKind.TURN, ((0, 0, 0),))
