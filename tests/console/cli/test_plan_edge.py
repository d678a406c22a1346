"""``morphonavi plan`` keeps the robot's radius from the workspace's edge: a goal at the paper room's
wall (x = 5) is refused naming the edge; a goal just inside the band's limit is planned, and no
waypoint of the mission comes nearer the walls than the radius."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from console.cli.morphonavi import main
from pipeline.scene import Scene
from pipeline.scene_json import scene_to_dict


def _empty_scene(tmp_path: Path) -> Path:
    scene = tmp_path / "empty.json"
    scene.write_text(json.dumps(scene_to_dict(Scene(objects=()))))
    return scene


def test_plan_refuses_a_goal_at_the_wall_naming_the_edge(tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    # before: "WALK ... -> (4.88, 0.12, 0.00)", the 0.35 m robot's body 0.23 m into the wall
    out = tmp_path / "m.json"
    assert main(["plan", str(_empty_scene(tmp_path)), "--start", "2.5,0.7,0", "--goal", "4.99,0.2,0",
                 "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert ("goal (4.99, 0.20, 0.00) is 0.01 m from the workspace's edge x = 5.00 (its cell centre (4.88, 0.12, 0.00): "
            "0.12 m; also 0.12 m from edge y = 0.00); the robot needs 0.35 m from it (its radius)") in err, err
    assert not out.exists()


def test_plan_near_the_walls_keeps_the_radius_from_them(tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    out = tmp_path / "m.json"
    assert main(["plan", str(_empty_scene(tmp_path)), "--start", "2.5,0.7,0", "--goal", "4.6,0.4,0",
                 "--goal", "0.4,7.6,0", "--goal", "2.5,4,2.4", "--out", str(out)]) == 0
    text = capsys.readouterr().out
    assert "goal snapped to (4.62, 0.38, 0.00)" in text and "goal snapped to (0.38, 7.62, 0.00)" in text, text
    mission = json.loads(out.read_text())
    pts = [p for seg in mission["segments"] for p in seg["waypoints"]]
    assert [4.625, 0.375, 0.0] in pts and [0.375, 7.625, 0.0] in pts  # it went as near as the radius lets it
    assert min(min(p[0], 5.0 - p[0], p[1], 8.0 - p[1]) for p in pts) >= 0.35 - 1e-9
    assert max(p[2] for p in pts) <= 3.0 - 0.45 + 1e-9
