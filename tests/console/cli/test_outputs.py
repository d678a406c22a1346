"""The one output rule: outputs never overwrite inputs, atomic writes keep the user's file mode."""

from __future__ import annotations

import os
import stat
from pathlib import Path

import pytest

from console.cli.outputs import InputFolder, OutputError, check_folders_apart, check_output, write_output
from pipeline.scene import Scene, SceneObject, save_scene, write_text_atomic


def _mode(p: Path) -> int:
    return stat.S_IMODE(p.stat().st_mode)


@pytest.mark.parametrize("umask", [0o022, 0o002, 0o077])
def test_atomic_write_honours_umask(tmp_path: Path, umask: int) -> None:
    old = os.umask(umask)
    try:
        out = write_text_atomic(tmp_path / "a.json", "{}\n")
        scene = save_scene(Scene((SceneObject("a", "chair", (1.0, 1.0, 0.4), (0.5, 0.8, 0.5)),)), tmp_path / "s.json")
    finally:
        os.umask(old)
    assert _mode(out) == 0o666 & ~umask
    assert _mode(scene) == 0o666 & ~umask
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".")]  # no temporary file left


def test_atomic_write_keeps_the_mode_of_the_replaced_file(tmp_path: Path) -> None:
    p = tmp_path / "shared.json"
    p.write_text("old")
    p.chmod(0o664)
    old = os.umask(0o077)
    try:
        write_text_atomic(p, "new")
    finally:
        os.umask(old)
    assert p.read_text() == "new" and _mode(p) == 0o664


def test_output_that_is_an_input_is_refused_naming_both(tmp_path: Path) -> None:
    scene = tmp_path / "scene.json"
    scene.write_text("{}")
    with pytest.raises(OutputError) as e:
        check_output(scene, [("scene", scene)])
    assert f"--out {scene}: is the scene {scene}" in str(e.value) and "overwrite" in str(e.value)
    link = tmp_path / "link.json"
    link.symlink_to(scene)
    with pytest.raises(OutputError, match="is the scene"):
        check_output(link, [("scene", scene)])
    hard = tmp_path / "hard.json"
    os.link(scene, hard)
    with pytest.raises(OutputError, match="is the scene"):
        check_output(hard, [("scene", scene)])
    assert check_output(tmp_path / "other.json", [("scene", scene)]) == tmp_path / "other.json"


def test_output_inside_an_input_folder_of_its_kind_is_refused(tmp_path: Path) -> None:
    photos = tmp_path / "photos"
    photos.mkdir()
    folder = InputFolder("photo", photos, (".png", ".jpg"))
    with pytest.raises(OutputError) as e:
        check_output(photos / "board_09.png", [folder])  # a new file: read as a photo next time
    assert "inside the photo folder" in str(e.value) and str(photos) in str(e.value)
    assert check_output(photos / "camera.toml", [folder]) == photos / "camera.toml"  # not a photo: fine


def test_output_folder_and_missing_parent_in_words(tmp_path: Path) -> None:
    with pytest.raises(OutputError, match="is a directory; give a file name such as"):
        check_output(tmp_path, [], example="mission.json")
    with pytest.raises(OutputError, match="does not exist"):
        check_output(tmp_path / "no" / "m.json", [])
    f = tmp_path / "file"
    f.write_text("x")
    with pytest.raises(OutputError, match="is a file, not a folder"):
        check_output(f / "m.json", [])


@pytest.mark.skipif(os.geteuid() == 0, reason="root writes into read-only folders")
def test_write_error_is_in_words(tmp_path: Path) -> None:
    ro = tmp_path / "ro"
    ro.mkdir()
    ro.chmod(0o555)
    try:
        with pytest.raises(OutputError) as e:
            write_output(ro / "m.json", "{}")
    finally:
        ro.chmod(0o755)
    assert "no permission to write in" in str(e.value) and "Errno" not in str(e.value)


def test_session_and_watched_folder_apart(tmp_path: Path) -> None:
    with pytest.raises(OutputError, match="--session .* and --scene"):
        check_folders_apart([("--session", tmp_path / "s"), ("--scene", tmp_path / "s")])
    with pytest.raises(OutputError):
        check_folders_apart([("--session", tmp_path), ("--scene", tmp_path / "inner")])
    check_folders_apart([("--session", tmp_path / "a"), ("--scene", tmp_path / "b")])


@pytest.mark.parametrize("code,said", [(13, "no permission to write in"), (30, "is on a read-only file system"),
                                       (28, "the disk is full")])
def test_write_errors_are_in_words_even_as_root(tmp_path: Path, monkeypatch: pytest.MonkeyPatch, code: int,
                                                said: str) -> None:
    import pipeline.scene

    def fail(path: Path, text: str) -> Path:
        raise OSError(code, os.strerror(code), str(path))

    monkeypatch.setattr(pipeline.scene, "write_text_atomic", fail)
    with pytest.raises(OutputError) as e:
        write_output(tmp_path / "m.json", "{}")
    assert str(e.value).startswith(f"--out {tmp_path / 'm.json'}: cannot write: ") and said in str(e.value)
    assert "Errno" not in str(e.value)
