"""Every file kind given to every reader: each command says what it found and which command reads it,
never reads another kind as an empty scene, and never shows an errno."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from console.cli.morphonavi import main
from pipeline.file_kind import MCAP_MAGIC, describe_file, kind_of_json

SESSION = {"version": 2, "kind": "morphonavi-session", "saved": 0, "frame": "world",
           "workspace": {"min": [0, 0, 0], "max": [5, 8, 3], "resolution": 0.25}, "margin": 0.35,
           "scene": {"version": 1, "objects": [{"id": "a", "label": "chair", "position": [1, 1, 0.4],
                                                "size": [0.5, 0.8, 0.5]}]},
           "route": {}, "mission": None, "settings": {}, "last_capture": None}
MISSION = {"version": 1, "id": "ab12", "created": 0, "frame": "world", "bounds": {"min": [0, 0, 0], "max": [5, 8, 3]},
           "segments": [{"kind": "walk", "waypoints": [[0, 0, 0], [1, 0, 0]]}]}
GRAPH = {"schema": "morphonavi.scene_graph", "version": 2, "frame": "world", "robot": None, "objects": [],
         "relations": [], "groups": [], "uncertainties": []}
DATASET = {"image": "000001.png", "width": 640, "height": 480, "K": [[500, 0, 320], [0, 500, 240], [0, 0, 1]],
           "objects": []}
INDEX = [{"source": "x", "json": "a/000001.json", "image": "a/000001.png"}]
REPORT = {"dataset": "dev", "mode": "gt", "models": {}, "summary": {}, "samples": []}
SCENE = {"version": 1, "objects": [{"id": "box-1", "label": "cardboard_box", "position": [2.5, 4.0, 0.3],
                                    "size": [0.5, 0.6, 0.5]}]}

KINDS = {  # file name, content, the words the readers use for it
    "session": ("session.json", json.dumps(SESSION), "is a console session"),
    "mission": ("mission.json", json.dumps(MISSION), "is a mission"),
    "scene_graph": ("graph.json", json.dumps(GRAPH), "is a scene graph"),
    "dataset_camera": ("000001.json", json.dumps(DATASET), "is a dataset photo's camera JSON"),
    "dataset_index": ("index.json", json.dumps(INDEX), "is a dataset index"),
    "bench_report": ("report.json", json.dumps(REPORT), "is a bench report"),
    "world": ("room.world.json", json.dumps({"morphonavi_world": 1, "name": "x", "scene": "paper_room.scene.json"}),
              "is a simulator world file"),
    "recording": ("run.mcap", MCAP_MAGIC + b"\x00" * 64, "is a recording (MCAP)"),
    "camera_toml": ("camera.toml", "[intrinsics]\nfx = 500.0\nfy = 500.0\n", "is a camera file"),
    "catalog": ("catalog.toml", "version = 1\n[[object]]\nname = \"chair\"\n", "is an object catalog"),
    "photo": ("photo.png", b"\x89PNG\r\n\x1a\n" + b"\x00" * 64, "is a photo"),
}


def _write(tmp_path: Path, kind: str) -> tuple[Path, str]:
    name, content, said = KINDS[kind]
    p = tmp_path / name
    p.write_bytes(content if isinstance(content, bytes) else content.encode())
    return p, said


@pytest.mark.parametrize("kind", sorted(KINDS))
def test_every_kind_is_recognised(tmp_path: Path, kind: str) -> None:
    p, _ = _write(tmp_path, kind)
    assert describe_file(p) == kind
    assert kind_of_json(SCENE) == "scene" and kind_of_json({"version": 1}) == "scene"


@pytest.mark.parametrize("command", ["plan", "describe"])
@pytest.mark.parametrize("kind", sorted(KINDS))
def test_plan_and_describe_name_every_other_kind(tmp_path: Path, capsys: pytest.CaptureFixture[str], command: str,
                                                 kind: str) -> None:
    p, said = _write(tmp_path, kind)
    out = tmp_path / "m.json"
    argv = ["plan", str(p), "--start", "2.5,0.7,0", "--goal", "2.5,5.7,0", "--out", str(out)] \
        if command == "plan" else ["describe", str(p)]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"morphonavi {command}: error: {p} {said}") and ", not a scene" in err
    assert "Errno" not in err and "Traceback" not in err and not out.exists()


def test_the_session_says_which_command_opens_it(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    p, _ = _write(tmp_path, "session")
    assert main(["plan", str(p), "--start", "2.5,0.7,0", "--goal", "2.5,5.7,0", "--out", str(tmp_path / "m.json")]) == 2
    assert "open it with `morphonavi console --session DIR`" in capsys.readouterr().err
    p, _ = _write(tmp_path, "scene_graph")
    assert main(["describe", str(p)]) == 2
    err = capsys.readouterr().err
    assert "give describe or plan the scene file it was made from" in err and "version" not in err


def test_json_of_no_kind_says_what_a_scene_has(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    p = tmp_path / "x.json"
    p.write_text(json.dumps({"hello": 1, "world": 2}))
    assert main(["describe", str(p)]) == 2
    err = capsys.readouterr().err
    assert "is not a scene: it is JSON of no MorphoNavi kind (keys: hello, world)" in err



def test_console_session_and_scene_given_files(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    session_file, _ = _write(tmp_path, "session")
    assert main(["console", "--session", str(session_file), "--no-record"]) == 2
    err = capsys.readouterr().err
    assert f"--session {session_file}: is the console's session file; give the folder holding it: " \
           f"--session {tmp_path}" in err
    scene = tmp_path / "scene.json"
    scene.write_text(json.dumps(SCENE))
    assert main(["console", "--session", str(tmp_path / "s"), "--scene", str(scene), "--no-record"]) == 2
    err = capsys.readouterr().err
    assert f"--scene {scene}: is a scene, not a folder" in err and "copy it into the watched folder" in err
    assert "Errno" not in err and not (tmp_path / "s").exists()  # refused before anything started
    assert main(["console", "--session", str(tmp_path / "same"), "--scene", str(tmp_path / "same"), "--no-record"]) == 2
    assert "the same folder" in capsys.readouterr().err
    assert main(["console", "--session", str(scene / "sub"), "--no-record"]) == 2
    assert f"{scene} is a file, not a folder" in capsys.readouterr().err


@pytest.mark.parametrize("kind", ["session", "mission", "recording", "photo", "catalog", "scene_graph"])
def test_map_camera_names_the_kind(tmp_path: Path, capsys: pytest.CaptureFixture[str], kind: str) -> None:
    p, said = _write(tmp_path, kind)
    assert main(["map", str(tmp_path / "photo.jpg"), "--camera", str(p), "--out", str(tmp_path / "s.json")]) == 2
    err = capsys.readouterr().err
    assert f"--camera {p} {said}" in err and "not a camera file (camera.toml): " in err and "Traceback" not in err
