"""Words a new operator read on the command line: counts in the right number, a zero-length plan refused as
the console refuses it, a JSON array named as such, a missing model folder named, and the option errors of
``map`` before any note about the photo's camera."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from console.cli.morphonavi import main
from console.wording import plural
from pipeline.scene import Scene
from pipeline.scene_json import scene_to_dict
from planner.mission import Mission, MissionSegment, SegmentKind, count_text


def _empty_scene(tmp_path: Path) -> Path:
    scene = tmp_path / "empty.json"
    scene.write_text(json.dumps(scene_to_dict(Scene(objects=()))))
    return scene


def _one_walk() -> str:
    seg = MissionSegment(SegmentKind.WALK, ((1.0, 1.0, 0.0), (1.25, 1.0, 0.0)))
    return Mission(segments=(seg,)).summary()


@pytest.mark.parametrize("text, expected, not_expected", [
    (plural(1, "object") + " seen", "1 object seen", "1 objects"),  # the Mapped notice (mapping_job)
    (plural(2, "object"), "2 objects", None),
    (plural(1, "unlabelled obstacle cell"), "1 unlabelled obstacle cell", "cells"),
    (f"path of {count_text(1, 'cell')}", "path of 1 cell", "1 cells"),  # planner.route's propose message
    (count_text(0, "cell"), "0 cells", None),
    (_one_walk(), ": 1 segment, 0.25 m", "1 segments"),  # `morphonavi plan`'s mission summary
    (_one_walk(), ", 2 waypoints", None),
])
def test_counts_are_said_in_the_right_number(text: str, expected: str, not_expected: str | None) -> None:
    assert expected in text, text
    assert not_expected is None or not_expected not in text, text


def test_plan_refuses_a_goal_where_the_robot_already_is(tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    # before: exit 0, "mission ...: 1 segments, 0.00 m" written
    out = tmp_path / "m.json"
    assert main(["plan", str(_empty_scene(tmp_path)), "--start", "1,1,0", "--goal", "1,1,0", "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert "--goal 1,1,0: goal is where the robot already is (0.00 m): pick a goal at least one cell" in err, err
    assert "Traceback" not in err and not out.exists()


def test_plan_of_one_segment_says_one_segment(tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    out = tmp_path / "m.json"
    assert main(["plan", str(_empty_scene(tmp_path)), "--start", "1,1,0", "--goal", "1.3,1,0", "--out", str(out)]) == 0
    text = capsys.readouterr().out
    assert ": 1 segment, 0.25 m" in text and "1 segments" not in text, text


def test_describe_names_a_json_array(tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    path = tmp_path / "list.json"
    path.write_text("[1, 2]")
    assert main(["describe", str(path)]) == 2
    err = capsys.readouterr().err
    assert "list.json is not a scene: it is a JSON array, not a MorphoNavi file" in err, err
    assert "keys: list" not in err


def test_models_verify_names_a_missing_folder(tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    missing = tmp_path / "missing"
    assert main(["models", "verify", "--model-dir", str(missing)]) == 2  # was 1: "no models found in ..."
    err = capsys.readouterr().err
    assert f"--model-dir {missing}: the folder does not exist" in err, err


def _photo(tmp_path: Path) -> Path:
    from PIL import Image

    rng = np.random.default_rng(0)
    path = tmp_path / "photo.jpg"
    Image.fromarray(rng.integers(0, 255, (480, 640, 3), dtype=np.uint8)).save(path)
    return path


@pytest.mark.parametrize("option", [["--threads", "0"], ["--catalog", "LIST"]])
def test_map_checks_its_options_before_any_camera_note(tmp_path: Path, capsys: pytest.CaptureFixture,
                                                       option: list[str]) -> None:
    listed = tmp_path / "list.json"
    listed.write_text("[1, 2]")
    option = [str(listed) if v == "LIST" else v for v in option]
    assert main(["map", str(_photo(tmp_path)), *option, "--out", str(tmp_path / "s.json")]) == 2
    got = capsys.readouterr()
    assert "error" in got.err and "Traceback" not in got.err, got.err
    # before: "warning: no camera file: intrinsics assumed ..." and the mount note came first
    assert "warning" not in got.out + got.err and "note:" not in got.out + got.err, got
