"""`morphonavi plan` / `describe` name a bad option once, as typed: not "argument --start: --start: ..." and not
the planner's field ("resolution must be > 0 m", "cost weight ground ...")."""

from __future__ import annotations

from pathlib import Path

import pytest

from console.cli.morphonavi import main

SCENE = Path(__file__).resolve().parents[3] / "examples" / "worlds" / "paper_room.scene.json"


@pytest.mark.parametrize("argv, words", [
    (["--start", "x", "--goal", "2,2,0"], "argument --start: value 1 ('x') is not a number; expected 'x,y,z in metres'"),
    (["--start", "1,2", "--goal", "2,2,0"], "argument --start: expected 3 numbers 'x,y,z in metres', got 2 in '1,2'"),
    (["--start", "1,1,0", "--goal", "2,2"], "argument --goal: expected 3 numbers"),
    (["--start", "1,1,0", "--bounds", "5,0,0,0,8,3"], "argument --bounds: every minimum must be below its maximum"),
    (["--start", "1,1,0", "--resolution", "0"], "argument --resolution: must be a number > 0 [m], got 0"),
    (["--start", "1,1,0", "--resolution", "nan"], "argument --resolution: must be a number > 0 [m], got nan"),
    (["--start", "1,1,0", "--w-ground", "-1"], "argument --w-ground: must be a number > 0, got -1"),
    (["--start", "1,1,0", "--w-danger", "inf"], "argument --w-danger: must be a number > 0, got inf"),
])
def test_plan_names_each_bad_option_once(capsys, tmp_path: Path, argv, words) -> None:
    with pytest.raises(SystemExit) as ex:
        main(["plan", str(SCENE), "--out", str(tmp_path / "m.json"), *argv])
    assert ex.value.code == 2
    err = capsys.readouterr().err
    assert words in err and "Traceback" not in err, err
    option = words.split()[1].rstrip(":")
    assert err.count(f"{option}:") == 1, err  # named once
    assert not (tmp_path / "m.json").exists()


def test_plan_refuses_a_cell_larger_than_the_room(capsys, tmp_path: Path) -> None:
    """One cell wider than the workspace's smallest side would put the start's cell centre outside the room
    (--resolution 100 planned from (50, 50, 0))."""
    try:
        code = main(["plan", str(SCENE), "--out", str(tmp_path / "m.json"), "--start", "1,1,0", "--goal", "3,3,0",
                     "--resolution", "100"])
    except SystemExit as ex:
        code = ex.code
    assert code == 2
    err = capsys.readouterr().err
    assert ("--bounds / --resolution: resolution must be at most twice the workspace's smallest side (3 m), so a "
            "cell's centre lies inside it, got 100 m") in err
    assert "Traceback" not in err and not (tmp_path / "m.json").exists()
