"""Every command that takes a file path refuses a bad one before it starts anything: a folder, an empty file, a
binary, another MorphoNavi file (an undo history, a search result, a session) and a missing file, each with the
option (or argument) named, exit status 2 and no traceback; another MorphoNavi file is named as what it is."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Callable

import pytest

from console.cli.morphonavi import main
from pipeline.file_kind import describe_file

HISTORY = {"kind": "morphonavi-history", "version": 1, "known_spaces": {}, "undo": [], "redo": []}
RESULT = {"found": False, "target": "robot dog", "target_id": None, "captures": 1, "reason": "x", "steps": []}
SESSION = {"version": 2, "kind": "morphonavi-session", "workspace": {"min": [0, 0, 0], "max": [5, 8, 3],
                                                                     "resolution": 0.25},
           "scene": {"version": 1, "objects": []}, "route": {}}
SCENE = {"version": 1, "objects": []}
PNG = Path(__file__).resolve().parents[3] / "docs" / "console.png"

BAD = {  # name: (file name, content or None for a folder / "" missing marker, words a file reader says)
    "folder": ("adir", None, "folder"),
    "empty": ("empty.json", b"", "is empty"),
    "binary": ("blob.bin", bytes(range(256)) * 4, ""),
    "history": ("history.json", json.dumps(HISTORY).encode(), "is a console undo history (morphonavi-history"),
    "result": ("result.json", json.dumps(RESULT).encode(), "is a search result"),
    "session": ("session.json", json.dumps(SESSION).encode(), "session"),
    "missing": ("nope.json", "", ""),
}

Argv = Callable[[Path, Path], list[str]]  # (bad path, tmp folder) -> argv
FILE_READERS: dict[str, tuple[str, str, Argv]] = {  # case: (command, option or "" for the argument, argv)
    "plan": ("plan", "", lambda p, t: ["plan", str(p), "--start", "1,1,0", "--goal", "2,2,0",
                                       "--out", str(t / "m.json")]),
    "plan --known-space": ("plan", "--known-space", lambda p, t: [
        "plan", str(t / "scene.json"), "--known-space", str(p), "--start", "1,1,0", "--goal", "2,2,0",
        "--out", str(t / "m.json")]),
    "describe": ("describe", "", lambda p, t: ["describe", str(p)]),
    "search --world": ("search", "--world", lambda p, t: ["search", "--target", "robot dog", "--world", str(p)]),
    "replay": ("replay", "", lambda p, t: ["replay", str(p), "--port", "0"]),
    "map": ("map", "", lambda p, t: ["map", str(p), "--out", str(t / "s.json")]),
    "calibrate": ("calibrate", "", lambda p, t: ["calibrate", str(p), "--out", str(t / "c.toml")]),
    "map --camera-file": ("map", "--camera-file", lambda p, t: ["map", str(PNG), "--camera-file", str(p),
                                                                 "--out", str(t / "s.json")]),
    "map --catalog": ("map", "--catalog", lambda p, t: ["map", str(PNG), "--catalog", str(p),
                                                         "--out", str(t / "s.json")]),
    "console --camera-file": ("console", "--camera-file", lambda p, t: ["console", "--camera", str(t / "none.mp4"),
                                                                         "--camera-file", str(p), "--session",
                                                                         str(t / "s"), "--port", "0"]),
    "console --world": ("console", "--world", lambda p, t: ["console", "--world", str(p),
                                                             "--session", str(t / "s"), "--port", "0"]),
}
FOLDER_READERS: dict[str, tuple[str, str, Argv]] = {  # options that want a folder: files refused, named
    "console --session": ("console", "--session", lambda p, t: ["console", "--session", str(p), "--port", "0"]),
    "console --captures": ("console", "--captures", lambda p, t: ["console", "--captures", str(p),
                                                                   "--session", str(t / "s"), "--port", "0"]),
    "mcp --session": ("mcp", "--session", lambda p, t: ["mcp", "--session", str(p)]),
}


TRUNCATED_JSON = b'{"version": 1, "objects": ['  # cut off after 27 characters
BROKEN_TOML = b"[intrinsics\nfx = 525.0\n"  # a table header without its ]
BAD_CONTENT: dict[str, tuple[str, bytes, str]] = {  # case: (file of the right extension, bad content, words said)
    "plan": ("scene.json", TRUNCATED_JSON, "not valid JSON (line 1, column 28): Expecting value"),
    "plan --known-space": ("known.json", TRUNCATED_JSON, "not valid JSON (line 1, column 28): Expecting value"),
    "describe": ("scene.json", TRUNCATED_JSON, "not valid JSON (line 1, column 28): Expecting value"),
    "search --world": ("room.world.json", TRUNCATED_JSON, "not valid JSON (line 1, column 28): Expecting value"),
    "console --world": ("room.world.json", TRUNCATED_JSON, "not valid JSON (line 1, column 28): Expecting value"),
    "replay": ("run.mcap", b"not a recording\n", "not an MCAP file"),
    "map": ("photo.png", b"not a photo\n", "not a readable image"),
    "calibrate": ("board.png", b"not a photo\n", "not a readable image"),
    "map --camera-file": ("camera.toml", BROKEN_TOML, "not valid TOML (line 1, column 12): Expected ']'"),
    "console --camera-file": ("camera.toml", BROKEN_TOML, "not valid TOML (line 1, column 12): Expected ']'"),
    "map --catalog": ("catalog.toml", BROKEN_TOML, "not valid TOML (line 1, column 12): Expected ']'"),
}


def _bad_file(tmp_path: Path, bad: str) -> Path:
    name, content, _ = BAD[bad]
    p = tmp_path / "in" / name
    p.parent.mkdir(exist_ok=True)
    if content is None:
        p.mkdir()
    elif content != "":
        p.write_bytes(content)
    (tmp_path / "scene.json").write_text(json.dumps(SCENE))
    return p


def _refused(capsys: pytest.CaptureFixture[str], argv: list[str], command: str) -> str:
    assert main(argv) == 2, argv
    err = capsys.readouterr().err
    assert err.startswith(f"morphonavi {command}: error: "), err
    assert "Traceback" not in err and "Errno" not in err and "codec" not in err, err
    return err


@pytest.mark.parametrize("bad", sorted(BAD))
@pytest.mark.parametrize("case", sorted(FILE_READERS))
def test_every_file_reader_refuses_every_bad_file_naming_it(tmp_path: Path, capsys: pytest.CaptureFixture[str],
                                                            case: str, bad: str) -> None:
    command, option, argv = FILE_READERS[case]
    p = _bad_file(tmp_path, bad)
    err = _refused(capsys, argv(p, tmp_path), command)
    named = f"{option} {p}" if option else str(p) if case != "calibrate" else p.name  # calibrate: photo's name
    assert named in err, err  # the argument the user gave, first
    if case == "map --camera-file" and bad == "missing":
        assert "camera file not found" in err
    said = BAD[bad][2]
    if bad == "folder":  # calibrate reads a folder's photos: an empty one has none
        assert "folder" in err or "directory" in err or err.startswith("morphonavi calibrate: error: no photos"), err
    elif said:
        assert said in err, err
    assert not (tmp_path / "m.json").exists() and not (tmp_path / "s.json").exists()


@pytest.mark.parametrize("bad", ["empty", "binary", "history", "result", "session", "missing"])
@pytest.mark.parametrize("case", sorted(FOLDER_READERS))
def test_every_folder_option_refuses_a_file_saying_what_it_is(tmp_path: Path, capsys: pytest.CaptureFixture[str],
                                                              case: str, bad: str) -> None:
    command, option, argv = FOLDER_READERS[case]
    p = _bad_file(tmp_path, bad)
    if bad == "missing" and case == "console --session":
        pytest.skip("a missing session folder is created: the console starts")
    err = _refused(capsys, argv(p, tmp_path), command)
    assert f"{option} {p}" in err, err
    if bad == "missing":
        assert "no such folder" in err
    elif bad in ("history", "result"):
        assert BAD[bad][2] in err and "not a folder" in err
    elif bad == "session":
        assert "session file" in err or "is a console session" in err
    else:
        assert "is a file, not a folder" in err


def test_plan_names_the_scene_argument_before_the_default_out(tmp_path: Path, capsys: pytest.CaptureFixture[str],
                                                              monkeypatch: pytest.MonkeyPatch) -> None:
    """`morphonavi plan FOLDER` run inside FOLDER: the folder is the error, not the default --out inside it."""
    monkeypatch.chdir(tmp_path)
    err = _refused(capsys, ["plan", str(tmp_path), "--start", "1,1,0", "--goal", "2,2,0"], "plan")
    assert err.startswith(f"morphonavi plan: error: {tmp_path}: is a folder, not a scene file"), err
    assert "--out" not in err


@pytest.mark.parametrize("data, kind", [(HISTORY, "history"), (RESULT, "search_result"), (SESSION, "session"),
                                        ({"format": "morphonavi.known_space", "version": 1}, "known_space"),
                                        ({"$schema": "https://json-schema.org/draft/2020-12/schema",
                                          "properties": {}}, "json_schema"),
                                        ({"rows": [], "records": [], "config": {}, "timing": None}, "search_bench"),
                                        (SCENE, "scene")])
def test_every_json_kind_the_product_writes_is_recognised(tmp_path: Path, data: dict, kind: str) -> None:
    p = tmp_path / "f.json"
    p.write_text(json.dumps(data))
    assert describe_file(p) == kind


def test_every_file_reader_has_a_bad_content_case() -> None:
    assert set(BAD_CONTENT) == set(FILE_READERS)


@pytest.mark.parametrize("case", sorted(BAD_CONTENT))
def test_every_file_reader_refuses_a_file_of_the_right_extension_with_bad_content_naming_it(
        tmp_path: Path, capsys: pytest.CaptureFixture[str], case: str) -> None:
    command, option, argv = FILE_READERS[case]
    name, content, said = BAD_CONTENT[case]
    p = tmp_path / "in" / name
    p.parent.mkdir()
    p.write_bytes(content)
    (tmp_path / "scene.json").write_text(json.dumps(SCENE))
    err = _refused(capsys, argv(p, tmp_path), command)
    named = f"{option} {p}" if option else str(p) if case != "calibrate" else p.name  # calibrate: photo's name
    assert f"{named}: {said}" in err, err  # the argument first, then what is wrong with it
    assert err.count(str(p.name)) == 1, err  # the file named once
    assert not (tmp_path / "m.json").exists() and not (tmp_path / "s.json").exists()


@pytest.mark.parametrize("name, content, said", [
    ("list.json", b"[1, 2]\n", "not valid TOML (line 1, column 3): Expected ']' at the end of a table declaration; "
                              "the file holds JSON, not TOML"),
    ("catalog.json", b'{"object": []}\n', "not valid TOML (line 1, column 1): Invalid statement; the file holds JSON, "
                                         "not TOML"),
    ("catalog.toml", b"version = 1\n[[object]]\nname = 3\n", "object[0].name: must be a snake_case string, got 3"),
    ("catalog.toml", b"colour = 'red'\n", "colour: unknown top-level key"),
    ("catalog.toml", b"version = [\n", "not valid TOML (at the end of the file): "),
])
def test_map_catalog_names_the_option_for_any_content_it_refuses(tmp_path: Path, capsys: pytest.CaptureFixture[str],
                                                                 name: str, content: bytes, said: str) -> None:
    p = tmp_path / name
    p.write_bytes(content)
    for command in ("map", "bench"):
        argv = ["map", str(PNG)] if command == "map" else ["bench", str(tmp_path), "--gt-boxes", "--no-models"]
        err = _refused(capsys, [*argv, "--catalog", str(p), "--out", str(tmp_path / "s.json")], command)
        assert err.startswith(f"morphonavi {command}: error: --catalog {p}: {said}"), err
        assert err.count(name) == 1, err


@pytest.mark.parametrize("option", ["--camera-file", "--camera"])  # --camera: map's old name, named as typed
@pytest.mark.parametrize("name, content, said", [
    ("camera.toml", b"[intrinsics]\nfx = 525.0\n", "intrinsics.fy: is required"),
    ("camera.toml", b"[colour]\n", "[colour]: unknown table"),
    ("camera.json", b'{"K": 3}', "'K' must be a 3x3 list of numbers"),
    ("camera.json", b'{"K": [', "not valid JSON (line 1, column 8): Expecting value"),
    ("nope.toml", None, "camera file not found"),
])
def test_map_camera_file_names_the_option_for_any_content_it_refuses(tmp_path: Path, capsys: pytest.CaptureFixture[str],
                                                                     option: str, name: str, content: bytes | None,
                                                                     said: str) -> None:
    p = tmp_path / name
    if content is not None:
        p.write_bytes(content)
    err = _refused(capsys, ["map", str(PNG), option, str(p), "--out", str(tmp_path / "s.json")], "map")
    assert err.startswith(f"morphonavi map: error: {option} {p}: {said}"), err
    assert err.count(name) == 1, err
    if option == "--camera-file":  # the console's live camera reads the same file, and says the same
        err = _refused(capsys, ["console", "--camera", str(tmp_path / "none.mp4"), "--camera-file", str(p),
                                "--session", str(tmp_path / "s"), "--port", "0"], "console")
        assert err.startswith(f"morphonavi console: error: --camera-file {p}: {said}"), err


def test_plan_known_space_names_the_option_for_bad_json_and_a_bad_field(tmp_path: Path,
                                                                        capsys: pytest.CaptureFixture[str]) -> None:
    (tmp_path / "scene.json").write_text(json.dumps(SCENE))
    p = tmp_path / "known.json"
    argv = ["plan", str(tmp_path / "scene.json"), "--known-space", str(p), "--start", "1,1,0", "--goal", "2,2,0",
            "--out", str(tmp_path / "m.json")]
    p.write_text('{"format": "morphonavi.known_space", "version": 1,\n "shape": [')
    err = _refused(capsys, argv, "plan")
    assert err.startswith(f"morphonavi plan: error: --known-space {p}: not valid JSON (line 2, column 12): "), err
    p.write_text(json.dumps({"format": "morphonavi.known_space", "version": 1}))
    err = _refused(capsys, argv, "plan")
    assert err.startswith(f"morphonavi plan: error: --known-space {p}: "), err
