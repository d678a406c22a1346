"""``morphonavi plan`` with the robot-sized grid and known space: gaps narrower than the robot, the rule it
says it used, goals not seen yet, ``--unknown allow``."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from console.cli.morphonavi import main
from pipeline.mapping.known_space import KnownSpace
from pipeline.scene import Scene, SceneObject
from pipeline.scene_json import scene_to_dict


def _line_with_gap(gap: float) -> Scene:
    """1.2 m boxes (0.5 m wide) along x at y = 4 m, wall to wall, one ``gap`` [m] centred at x = 2.5."""
    objs = []
    x = 2.5 - gap / 2 - 0.25
    n = 0
    while x > 0.0:
        objs.append(SceneObject(f"l{n}", "cardboard_box", (x, 4.0, 0.6), (0.5, 1.2, 0.5)))
        x -= 0.5
        n += 1
    x = 2.5 + gap / 2 + 0.25
    while x < 5.0:
        objs.append(SceneObject(f"r{n}", "cardboard_box", (x, 4.0, 0.6), (0.5, 1.2, 0.5)))
        x += 0.5
        n += 1
    return Scene(objects=tuple(objs))


def _walks_through(mission: dict) -> bool:
    for seg in mission["segments"]:
        if seg["kind"] != "walk":
            continue
        ys = [p[1] for p in seg["waypoints"]]
        if min(ys) < 3.5 and max(ys) > 4.5:
            return True
    return False


def test_plan_never_walks_through_a_gap_narrower_than_the_robot(tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    for gap, through in ((0.5, False), (1.2, True)):
        scene = tmp_path / f"gap{gap}.json"
        scene.write_text(json.dumps(scene_to_dict(_line_with_gap(gap))))
        out = tmp_path / f"m{gap}.json"
        assert main(["plan", str(scene), "--start", "2.5,1,0", "--goal", "2.5,6.5,0", "--out", str(out)]) == 0
        text = capsys.readouterr().out
        assert "robot radius 0.35 m walking (height 0.45 m), 0.35 m flying" in text
        assert "fully known: no known space in the scene" in text
        mission = json.loads(out.read_text())
        assert _walks_through(mission) is through, (gap, [s["kind"] for s in mission["segments"]])
        if not through:
            assert "takeoff" in [s["kind"] for s in mission["segments"]]  # over the line instead


def test_plan_with_known_space_refuses_unseen_goals_unless_allowed(tmp_path: Path,
                                                                   capsys: pytest.CaptureFixture) -> None:
    ks = KnownSpace.empty((0.0, 0.0, 0.0), (5.0, 8.0, 3.0), 0.25)
    free = np.zeros(ks.shape, bool)
    free[:, :20, :] = True  # y < 5 m seen free
    ks = ks.updated(free, np.zeros_like(free))
    data = scene_to_dict(Scene())
    data["known_space"] = ks.to_dict()
    scene = tmp_path / "seen.json"
    scene.write_text(json.dumps(data))
    out = tmp_path / "m.json"
    args = ["plan", str(scene), "--start", "2.5,1,0", "--goal", "2.5,7,0", "--out", str(out)]
    assert main(args) == 2
    cap = capsys.readouterr()
    assert "only seen-free space is planned through (unknown space closed)" in cap.out
    assert "not seen yet" in cap.err and ("look from (" in cap.err or "Look around" in cap.err)
    assert main(args + ["--unknown", "allow"]) == 0
    cap = capsys.readouterr()
    assert "unknown space allowed" in cap.out and "m of it through unseen space" in cap.out
    bad = tmp_path / "bad.json"
    bad.write_text(json.dumps({**data, "known_space": {**data["known_space"], "resolution": -1}}))
    assert main(["plan", str(bad), "--start", "2.5,1,0", "--goal", "2.5,2,0", "--out", str(out)]) == 2
    assert "known_space.resolution" in capsys.readouterr().err
