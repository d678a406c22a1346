"""The one output rule through every command with ``--out``: an input is never overwritten (exit 2, both
named, the input unchanged), and what is written has the user's normal file mode."""

from __future__ import annotations

import json
import os
import stat
from pathlib import Path

import cv2
import numpy as np
import pytest

from console.cli.morphonavi import main

SCENE = {"version": 1, "objects": [{"id": "box-1", "label": "cardboard_box", "position": [2.5, 4.0, 0.3],
                                    "size": [0.5, 0.6, 0.5]}]}


def _scene(tmp_path: Path) -> Path:
    p = tmp_path / "scene.json"
    p.write_text(json.dumps(SCENE))
    return p


def test_plan_refuses_to_write_the_mission_over_its_scene(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    scene = _scene(tmp_path)
    before = scene.read_bytes()
    assert main(["plan", str(scene), "--start", "2.5,0.7,0", "--goal", "2.5,5.7,0", "--out", str(scene)]) == 2
    err = capsys.readouterr().err
    assert f"--out {scene}: is the scene {scene} read by this command; writing there would overwrite it" in err
    assert scene.read_bytes() == before
    link = tmp_path / "alias.json"
    link.symlink_to(scene)
    assert main(["plan", str(scene), "--start", "2.5,0.7,0", "--goal", "2.5,5.7,0", "--out", str(link)]) == 2
    assert scene.read_bytes() == before


@pytest.mark.parametrize("umask", [0o022, 0o002])
def test_plan_writes_the_mission_with_the_users_mode(tmp_path: Path, capsys: pytest.CaptureFixture[str],
                                                     umask: int) -> None:
    scene = _scene(tmp_path)
    out = tmp_path / "mission.json"
    old = os.umask(umask)
    try:
        assert main(["plan", str(scene), "--start", "2.5,0.7,0", "--goal", "2.5,5.7,0", "--out", str(out)]) == 0
    finally:
        os.umask(old)
    assert stat.S_IMODE(out.stat().st_mode) == 0o666 & ~umask
    assert json.loads(out.read_text())["segments"]


@pytest.fixture
def photos(tmp_path: Path) -> Path:
    folder = tmp_path / "photos"
    folder.mkdir()
    for i in range(3):
        cv2.imwrite(str(folder / f"board_{i:02d}.png"), np.full((120, 160, 3), 90 + i, np.uint8))
    return folder


@pytest.mark.parametrize("given", ["files", "folder"])
def test_calibrate_refuses_to_write_over_its_photos(photos: Path, capsys: pytest.CaptureFixture[str], given: str) -> None:
    target = photos / "board_01.png"
    before = target.read_bytes()
    inputs = sorted(str(p) for p in photos.iterdir()) if given == "files" else [str(photos)]
    assert main(["calibrate", *inputs, "--out", str(target)]) == 2
    err = capsys.readouterr().err
    assert f"--out {target}" in err and str(photos) in err and "overwrite" in err
    assert target.read_bytes() == before


def test_calibrate_refuses_a_new_photo_name_inside_its_photo_folder(photos: Path,
                                                                    capsys: pytest.CaptureFixture[str]) -> None:
    new = photos / "board_09.png"
    assert main(["calibrate", str(photos), "--out", str(new)]) == 2
    err = capsys.readouterr().err
    assert f"--out {new}: is inside the photo folder {photos}" in err and not new.exists()


def test_calibrate_refuses_a_photo_name_for_the_camera_file(photos: Path, tmp_path: Path,
                                                            capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "camera.png"
    assert main(["calibrate", str(photos), "--out", str(out)]) == 2
    assert "a camera file is TOML text" in capsys.readouterr().err and not out.exists()


def test_calibrate_with_the_wrong_board_says_to_check_board(photos: Path, tmp_path: Path,
                                                            capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["calibrate", str(photos), "--board", "9x6", "--min-views", "2",
                 "--out", str(tmp_path / "camera.toml")]) == 2
    err = capsys.readouterr().err
    assert "the board was found in 0 of 3 photos" in err
    assert "check --board 9x6 first: it counts INNER corners" in err


def test_bench_refuses_to_write_over_its_dataset(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    (tmp_path / "index.json").write_text("[]")
    assert main(["bench", str(tmp_path), "--gt-boxes", "--no-models", "--no-progress",
                 "--out", str(tmp_path / "index.json")]) == 2
    err = capsys.readouterr().err
    assert "is the dataset index" in err and (tmp_path / "index.json").read_text() == "[]"


@pytest.mark.parametrize("command", ["plan", "map", "calibrate", "bench"])
def test_every_out_refuses_a_folder_and_a_missing_folder_in_words(tmp_path: Path, photos: Path,
                                                                  capsys: pytest.CaptureFixture[str],
                                                                  command: str) -> None:
    scene = _scene(tmp_path)
    head = {"plan": ["plan", str(scene), "--start", "2.5,0.7,0", "--goal", "2.5,5.7,0"],
            "map": ["map", str(photos / "board_00.png"), "--model-dir", str(tmp_path / "none")],
            "calibrate": ["calibrate", str(photos)],
            "bench": ["bench", str(tmp_path), "--gt-boxes", "--no-models", "--no-progress"]}[command]
    assert main([*head, "--out", str(tmp_path)]) == 2
    assert f"--out {tmp_path} is a directory; give a file name such as" in capsys.readouterr().err
    assert main([*head, "--out", str(tmp_path / "no" / "x.json")]) == 2
    err = capsys.readouterr().err
    assert "does not exist" in err and "Errno" not in err
