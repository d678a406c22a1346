"""Limits with their numbers, at and past each bound, and ranges: ``--robot`` like ``--pose``, poses and
positions in scene files, the camera pitch that puts the horizon outside the photo."""

from __future__ import annotations

import json
import math
from pathlib import Path

import pytest

from console.cli.morphonavi import main
from pipeline.camera.geometry import CameraMount, Intrinsics
from pipeline.camera.horizon import horizon_check
from pipeline.file_kind import MAX_BYTES, MAX_SCENE_OBJECTS

ROOM = {"version": 1, "objects": [{"id": "box-1", "label": "cardboard_box", "position": [2.5, 4.0, 0.3],
                                   "size": [0.5, 0.6, 0.5]}]}


def _scene(tmp_path: Path, data: dict) -> Path:
    p = tmp_path / "scene.json"
    p.write_text(json.dumps(data))
    return p


@pytest.mark.parametrize("robot,said", [
    ("1e30,1,0,0", "--pose.x: must be within -10000..10000 m (the range of map --pose), got 1e+30"),
    ("1,-10000.5", "--pose.y: must be within -10000..10000 m"),
    ("1,1,1001", "--pose.z: must be within -1000..1000 m"),
    ("1,1,0,361", "--pose.yaw_deg: must be within -360..360 deg"),
])
def test_describe_robot_is_range_checked_like_pose(tmp_path: Path, capsys: pytest.CaptureFixture[str], robot: str,
                                                   said: str) -> None:
    assert main(["describe", str(_scene(tmp_path, ROOM)), "--robot", robot]) == 2
    assert said in capsys.readouterr().err


def test_describe_robot_at_the_bounds_is_accepted(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["describe", str(_scene(tmp_path, ROOM)), "--robot", "10000,-10000,1000,-360"]) == 0
    out = capsys.readouterr().out
    assert "Robot at (10000.00, -10000.00, 1000.00)" in out


@pytest.mark.parametrize("where,value,said", [
    ("robot_pose", {"x": 1e308, "y": 0.0}, "captures[0].robot_pose.x: 1e+308 m is outside -10000..10000 m"),
    ("camera_position", [0.0, 0.0, 2000.0], "captures[0].camera_position[2]: 2000 m is outside -1000..1000 m"),
    ("object", [1e308, 0.0, 0.3], "objects[0].position[0]: 1e+308 m is outside -10000..10000 m"),
])
def test_far_poses_in_a_scene_file_are_refused_with_the_field(tmp_path: Path, capsys: pytest.CaptureFixture[str],
                                                              where: str, value: object, said: str) -> None:
    data = json.loads(json.dumps(ROOM))
    if where == "object":
        data["objects"][0]["position"] = value
    else:
        data["captures"] = [{"id": "c", where: value}]
    scene = _scene(tmp_path, data)
    for argv in (["describe", str(scene)],
                 ["plan", str(scene), "--start", "2.5,0.7,0", "--goal", "2.5,5.7,0", "--out", str(tmp_path / "m.json")]):
        assert main(argv) == 2
        err = capsys.readouterr().err
        assert said in err and "e+308," not in err.split(said)[0]  # no 300-digit coordinates, no --bounds advice


def test_scene_object_count_limit_at_and_past_the_bound(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    def boxes(n: int) -> dict:
        return {"version": 1, "objects": [{"id": f"b{i}", "label": "cardboard_box",
                                           "position": [100.0 + i % 200, 100.0 + i // 200, 0.3],
                                           "size": [0.5, 0.6, 0.5]} for i in range(n)]}
    p = _scene(tmp_path, boxes(MAX_SCENE_OBJECTS + 1))
    assert main(["plan", str(p), "--start", "2.5,0.7,0", "--goal", "2.5,5.7,0", "--out", str(tmp_path / "m.json")]) == 2
    err = capsys.readouterr().err
    assert f"objects: {MAX_SCENE_OBJECTS + 1} objects is over the limit of {MAX_SCENE_OBJECTS}" in err
    from pipeline.file_kind import load_scene_file

    p.write_text(json.dumps(boxes(MAX_SCENE_OBJECTS)))
    assert len(load_scene_file(p).objects) == MAX_SCENE_OBJECTS


def test_scene_file_size_limit_is_checked_before_reading(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    p = tmp_path / "huge.json"
    with open(p, "wb") as f:  # sparse
        f.truncate(MAX_BYTES["scene"] + 1)
    assert main(["describe", str(p)]) == 2
    err = capsys.readouterr().err
    assert f"{p}: 100.0 MB is over the 100 MB limit for a scene file: not read" in err


@pytest.mark.parametrize("pitch,roll,said", [
    (89.9, 0.0, "puts the horizon above the photo"),
    (60.0, 0.0, "puts the horizon above the photo"),
    (-70.0, 0.0, "puts the horizon below the photo"),
    (0.0, 90.0, None),  # rolled on its side: the horizon crosses the photo vertically
    (10.0, 0.0, None),
    (20.0, 0.0, None),  # the top edge 4.6 deg above the horizon
])
def test_horizon_outside_the_photo_warns_with_the_numbers(pitch: float, roll: float, said: str | None) -> None:
    intr = Intrinsics(525.0, 525.0, 319.5, 239.5, 640, 480)
    got = horizon_check(intr, CameraMount((0.15, 0.0, 0.35), math.radians(pitch), 0.0, math.radians(roll)))
    if said is None:
        assert got is None
    else:
        assert got is not None and said in got and f"mount.pitch_deg = {pitch:g}" in got and " deg " in got


def test_map_warns_about_a_camera_looking_straight_down(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    import cv2
    import numpy as np

    photo = tmp_path / "photo.png"
    cv2.imwrite(str(photo), np.full((480, 640, 3), 90, np.uint8))
    cam = tmp_path / "camera.toml"
    cam.write_text("[intrinsics]\nfx = 525.0\nfy = 525.0\ncx = 319.5\ncy = 239.5\nwidth = 640\nheight = 480\n"
                   "[mount]\nposition = [0.15, 0.0, 0.35]\npitch_deg = 89.9\n")
    main(["map", str(photo), "--camera", str(cam), "--out", str(tmp_path / "s.json"),
          "--model-dir", str(tmp_path / "none")])  # no models here: the warning comes first
    err = capsys.readouterr().err
    assert f"warning: {cam}: mount.pitch_deg = 89.9, roll_deg = 0 puts the horizon above the photo" in err
    assert "the farthest floor it can show is 0.3 m away" in err


def test_the_bounds_describe_suggests_are_accepted_by_describe(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    import re

    data = {"version": 1, "objects": [
        {"id": "near", "label": "chair", "position": [2.0, 2.0, 0.45], "size": [0.5, 0.9, 0.5]},
        {"id": "far", "label": "chair", "position": [9000.0, 7000.0, 0.45], "size": [0.5, 0.9, 0.5]}]}
    scene = _scene(tmp_path, data)
    assert main(["describe", str(scene), "--robot", "1,1"]) == 0
    out = capsys.readouterr().out
    hint = re.search(r"e\.g\. (--bounds=\S+)(?: --resolution (\S+))?\)", out)
    assert hint is not None and hint.group(2) is not None, out  # 9 km: a coarser grid comes with it
    argv = ["describe", str(scene), "--robot", "1,1", hint.group(1), "--resolution", hint.group(2)]
    assert main(argv) == 0, capsys.readouterr().err
