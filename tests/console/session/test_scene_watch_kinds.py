"""The watched scene folder treats a file by its kind: other MorphoNavi files are named, not read as empty
scenes; broken links are reported; a rewritten file replaces what it added; the merge is not under the
session lock; poses and quaternions are range-checked with the field named."""

from __future__ import annotations

import json
import os
import time
from pathlib import Path

import pytest

from console.session.scene_watch import SceneWatcher
from pipeline.file_kind import MCAP_MAGIC


def _age(path: Path, seconds: float = 2.0) -> None:
    t = time.time() - seconds
    os.utime(path, (t, t), follow_symlinks=False)


def _watcher(tmp_path: Path) -> tuple[SceneWatcher, list[tuple[str, int]], list[tuple[str, str]]]:
    got: list[tuple[str, int]] = []
    errors: list[tuple[str, str]] = []
    w = SceneWatcher(tmp_path / "inbox", lambda s, n: got.append((n, len(s.objects))),
                     lambda n, e: errors.append((n, e)), settle=0.2)
    return w, got, errors


SESSION = {"version": 2, "kind": "morphonavi-session", "saved": 0, "frame": "world",
           "workspace": {"min": [0, 0, 0], "max": [5, 8, 3], "resolution": 0.25}, "margin": 0.35,
           "scene": {"version": 1, "objects": [{"id": "a", "label": "chair", "position": [1, 1, 0.4],
                                                "size": [0.5, 0.8, 0.5]}]},
           "route": {}, "mission": None, "settings": {}, "last_capture": None}
MISSION = {"version": 1, "id": "ab12", "created": 0, "frame": "world", "bounds": {"min": [0, 0, 0], "max": [5, 8, 3]},
           "segments": [{"kind": "walk", "waypoints": [[0, 0, 0], [1, 0, 0]]}]}
GRAPH = {"schema": "morphonavi.scene_graph", "version": 2, "frame": "world", "objects": [], "relations": [],
         "groups": []}
DATASET = {"image": "000001.png", "width": 640, "height": 480, "K": [[500, 0, 320], [0, 500, 240], [0, 0, 1]],
           "objects": []}


@pytest.mark.parametrize("name,data,said", [
    ("session.json", SESSION, "is a console session"),
    ("mission.json", MISSION, "is a mission"),
    ("graph.json", GRAPH, "is a scene graph"),
    ("000001.json", DATASET, "dataset photo's camera JSON"),
    ("other.json", {"hello": 1}, "JSON of no MorphoNavi kind"),
])
def test_a_json_file_of_another_kind_is_named_not_spawned_as_an_empty_scene(tmp_path: Path, name: str, data: dict,
                                                                           said: str) -> None:
    w, got, errors = _watcher(tmp_path)
    (w.folder / name).write_text(json.dumps(data))
    _age(w.folder / name)
    w.poll()
    assert got == [] and len(errors) == 1
    assert errors[0][0] == name and said in errors[0][1] and "nothing was added" in errors[0][1]
    w.poll()
    assert len(errors) == 1  # once


@pytest.mark.parametrize("name,content,said", [
    ("run.mcap", MCAP_MAGIC + b"\x00" * 32, "is a recording (MCAP), not a scene: replay it with `morphonavi replay FILE.mcap`"),
    ("camera.toml", b"[intrinsics]\nfx = 500.0\n", "is a camera file (camera.toml)"),
    ("photo.png", b"\x89PNG\r\n\x1a\n" + b"\x00" * 16, "is a photo"),
])
def test_other_morphonavi_files_are_named_once(tmp_path: Path, name: str, content: bytes, said: str) -> None:
    w, got, errors = _watcher(tmp_path)
    (w.folder / name).write_bytes(content)
    (w.folder / "notes.txt").write_text("left alone")
    w.poll()
    w.poll()
    assert got == [] and errors == [(name, errors[0][1])] and said in errors[0][1]
    assert "the watched folder reads scene JSON files only" in errors[0][1]


def test_dangling_links_and_link_loops_are_reported_once(tmp_path: Path) -> None:
    w, got, errors = _watcher(tmp_path)
    (w.folder / "gone.json").symlink_to(tmp_path / "nowhere.json")
    (w.folder / "a.json").symlink_to(w.folder / "b.json")
    (w.folder / "b.json").symlink_to(w.folder / "a.json")
    w.poll()
    w.poll()
    said = dict(errors)
    assert len(errors) == 3 and got == []
    assert "a symbolic link to" in said["gone.json"] and "does not exist: not read" in said["gone.json"]
    assert "a loop of symbolic links" in said["a.json"] and "a loop of symbolic links" in said["b.json"]


def test_zero_camera_quaternion_and_far_poses_name_the_field(tmp_path: Path) -> None:
    w, got, errors = _watcher(tmp_path)
    base = {"version": 1, "objects": [{"id": "a", "label": "chair", "frame": "camera", "position": [0, 0, 2],
                                       "size": [0.5, 0.8, 0.5], "source": {"capture": "c"}}]}
    (w.folder / "q.json").write_text(json.dumps({**base, "captures": [
        {"id": "c", "camera_position": [1, 1, 1], "camera_quaternion": [0, 0, 0, 0]}]}))
    (w.folder / "far.json").write_text(json.dumps({**base, "captures": [
        {"id": "c", "robot_pose": {"x": 1e308, "y": 0}}]}))
    for n in ("q.json", "far.json"):
        _age(w.folder / n)
    w.poll()
    said = dict(errors)
    assert got == []
    assert "captures[0].camera_quaternion: is all zero" in said["q.json"] and "[0, 0, 0, 1]" in said["q.json"]
    assert "captures[0].robot_pose.x: 1e+308 m is outside -10000..10000 m" in said["far.json"]
    assert not any("norm" in e for e in said.values())  # not scipy's words


def test_a_file_replaced_by_rename_with_the_same_time_and_size_is_read_again(tmp_path: Path) -> None:
    w, got, errors = _watcher(tmp_path)
    a = w.folder / "a.json"
    text = json.dumps({"version": 1, "objects": [{"id": "box-1", "label": "cardboard_box", "position": [1, 1, 0.2],
                                                  "size": [0.4, 0.4, 0.4]}]})
    a.write_text(text)
    _age(a)
    st = a.stat()
    w.poll()
    tmp = w.folder / ".a.json.tmp"
    tmp.write_text(text.replace("[1, 1, 0.2]", "[2, 1, 0.2]"))  # same size
    os.utime(tmp, ns=(st.st_atime_ns, st.st_mtime_ns))
    os.replace(tmp, a)
    w.poll()
    assert [n for n, _ in got] == ["a.json", "a.json"] and errors == []
