"""Every option of `morphonavi search` is checked where it enters, before the simulator starts: a bad value
exits with status 2 and one line naming the option as typed, never a traceback nor the code's field names."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import pytest

from console.cli.morphonavi import main

REPO = Path(__file__).resolve().parents[3]
WORLD = REPO / "examples" / "worlds" / "office.world.json"
SCENE = REPO / "examples" / "worlds" / "paper_room.scene.json"


def _bad(capsys: pytest.CaptureFixture[str], *argv: str) -> str:
    assert main(["search", *argv]) == 2
    cap = capsys.readouterr()
    assert cap.out == ""  # refused before anything ran
    err = cap.err.strip()
    assert "Traceback" not in err and "[Errno" not in err and len(err.splitlines()) == 1, err
    assert err.startswith("morphonavi search: error: "), err
    assert not re.search(r"(^|\s)(max_captures|max_time|min_battery|target|time_scale|SimConfig\.\w+):", err), err
    assert "argument --" not in err, err  # the option named once (not "argument --x: --x: ...")
    return err


@pytest.mark.parametrize("argv, words", [
    (["--time-scale", "0"], "--time-scale: must be a number within 0.1..50 (simulated seconds per wall-clock second), got 0"),
    (["--time-scale", "-1"], "--time-scale: must be a number within 0.1..50"),
    (["--time-scale", "nan"], "--time-scale: must be a number within 0.1..50"),
    (["--time-scale", "inf"], "--time-scale: must be a number within 0.1..50"),
    (["--time-scale", "fast"], "--time-scale: must be a number within 0.1..50 (simulated seconds per wall-clock second), got fast"),
    (["--max-captures", "0"], "--max-captures: must be a whole number within 1..200, got 0"),
    (["--max-captures", "2.5"], "--max-captures: must be a whole number within 1..200, got 2.5"),
    (["--max-captures", "x"], "--max-captures: must be a whole number within 1..200, got x"),
    (["--max-captures", "-3"], "--max-captures: must be a whole number within 1..200, got -3"),
    (["--max-time", "-5"], "--max-time: must be a number within 30..86400 s, got -5"),
    (["--max-time", "nan"], "--max-time: must be a number within 30..86400 s, got nan"),
    (["--max-time", "1e9"], "--max-time: must be a number within 30..86400 s"),
    (["--battery-reserve", "10"], "--battery-reserve: must be at least 25 % and below 100 %"),
    (["--battery-reserve", "100"], "--battery-reserve: must be at least 25 % and below 100 %"),
    (["--battery-reserve", "nan"], "--battery-reserve: must be at least 25 % and below 100 %"),
    (["--seed", "3"], "--seed: draws the perception noise: only with --perception noisy"),
    (["--seed", "-1", "--perception", "noisy"], "--seed: must be a whole number within 0..4294967295, got -1"),
    (["--seed", "1.5", "--perception", "noisy"], "--seed: must be a whole number within 0..4294967295, got 1.5"),
    (["--perception", "perfect"], "--perception: must be one of exact, noisy, got perfect"),
])
def test_each_bad_number_or_choice_is_refused_naming_its_option(capsys, argv, words) -> None:
    assert words in _bad(capsys, "--target", "robot dog", *argv)


@pytest.mark.parametrize("target, words", [
    ("unicorn", "--target: 'unicorn' is not an object the perception can name"),
    ("dog", "(did you mean 'robot dog'?)"),
    ("", "--target: must be 1..200 characters (what to find, e.g. 'robot dog'), got nothing"),
    ("x" * 300, "--target: must be 1..200 characters (what to find, e.g. 'robot dog'), got 300 characters"),
])
def test_a_target_the_perception_cannot_name_is_refused_with_what_it_can(capsys, target, words) -> None:
    err = _bad(capsys, "--target", target)
    assert words in err
    if target in ("unicorn", "dog"):
        assert "robot dog" in err and "office chair" in err and "assets/catalog.toml" in err


def test_world_and_out_are_checked_before_the_search(capsys, tmp_path: Path) -> None:
    t = ("--target", "robot dog")
    assert _bad(capsys, *t, "--world", str(tmp_path)).endswith(
        f"--world {tmp_path}: is a folder; give a world file such as examples/worlds/office.world.json")
    assert f"--world {tmp_path / 'nope.json'}: no such world file" in _bad(capsys, *t, "--world", str(tmp_path / "nope.json"))
    err = _bad(capsys, *t, "--world", str(SCENE))
    assert f"--world {SCENE} is a scene" in err and "not a simulator world file" in err
    junk = tmp_path / "junk.json"
    junk.write_text("{not json")
    assert f"--world {junk}: not valid JSON" in _bad(capsys, *t, "--world", str(junk))
    assert f"--out {tmp_path} is a directory; give a file name such as {tmp_path / 'result.json'}" in _bad(
        capsys, *t, "--out", str(tmp_path))
    assert "the folder" in _bad(capsys, *t, "--out", str(tmp_path / "missing" / "r.json"))
    err = _bad(capsys, *t, "--world", str(WORLD), "--out", str(WORLD))
    assert "--out" in err and "is the world file" in err
    if Path("/sys").is_dir():  # a folder nobody may create files in (root included)
        assert "--out /sys/r.json: cannot write: no permission to write in /sys" in _bad(capsys, *t, "--out", "/sys/r.json")
    assert not any(tmp_path.glob(".morphonavi-probe-*"))


def test_the_help_names_every_option_with_its_range(capsys) -> None:
    with pytest.raises(SystemExit) as ex:
        main(["search", "--help"])
    assert ex.value.code == 0
    out = " ".join(capsys.readouterr().out.split())
    for words in ("--max-captures N", "1..200", "--max-time S", "30..86400", "--battery-reserve PCT", "--time-scale X",
                  "0.1..50", "--seed N", "--perception {exact,noisy}", "--world FILE", "--out FILE"):
        assert words in out, words


def test_the_first_report_runs_as_a_command_without_a_traceback(tmp_path: Path) -> None:
    """`morphonavi search --time-scale 0` printed a traceback from the simulator's config."""
    proc = subprocess.run([sys.executable, "-m", "console.cli.morphonavi", "search", "--target", "robot dog",
                           "--time-scale", "0"], capture_output=True, text=True, timeout=300, cwd=REPO)
    assert proc.returncode == 2, proc.stderr
    assert "Traceback" not in proc.stderr and "--time-scale: must be a number within 0.1..50" in proc.stderr



def test_the_console_reads_world_the_same_way(capsys, tmp_path: Path) -> None:
    """`morphonavi console --world` shares the reader (console/cli/world_option.py)."""
    for world, words in ((tmp_path, f"--world {tmp_path}: is a folder; give a world file such as "
                                    "examples/worlds/office.world.json"),
                         (SCENE, f"--world {SCENE} is a scene")):
        assert main(["console", "--world", str(world), "--session", str(tmp_path / "s")]) == 2
        err = capsys.readouterr().err
        assert words in err and "Errno" not in err and "Traceback" not in err, err
    assert not (tmp_path / "s").exists()  # refused before the console started


def test_out_may_not_be_the_scene_file_the_world_reads(capsys, tmp_path: Path) -> None:
    """A copy of the paper's world beside its scene file: --out pointing at that scene file would write the result
    over the hidden room (the next run then fails to read the world)."""
    import shutil

    src = REPO / "examples" / "worlds"
    for name in ("paper_room.world.json", "paper_room.scene.json"):
        shutil.copy(src / name, tmp_path / name)
    scene = tmp_path / "paper_room.scene.json"
    before = scene.read_bytes()
    err = _bad(capsys, "--target", "robot dog", "--world", str(tmp_path / "paper_room.world.json"), "--out", str(scene))
    assert "--out" in err and "is the world's scene file" in err, err
    assert scene.read_bytes() == before
