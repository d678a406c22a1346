"""The console's command line: options reach the robot link and the mission manager."""

from __future__ import annotations

from pathlib import Path

import pytest

from console.app import ConsoleApp
from console.cli import build_parser, main

DEV = Path(__file__).resolve().parents[1].parent / "shared" / "bench" / "dev"


def test_console_options_parse() -> None:
    args = build_parser().parse_args(["console", "--captures", "photos", "--failsafe-after", "1.5",
                                      "--failsafe-hold", "0", "--port", "0"])
    assert args.captures == Path("photos") and args.failsafe_after == 1.5 and args.failsafe_hold == 0.0
    with pytest.raises(SystemExit):
        build_parser().parse_args(["console", "--failsafe-after", "-1"])


def test_missing_captures_folder_is_a_clear_error(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    code = main(["console", "--captures", str(tmp_path / "nope"), "--session", str(tmp_path / "s")])
    assert code == 2
    assert "--captures" in capsys.readouterr().err


@pytest.mark.skipif(not DEV.is_dir(), reason="../shared/bench/dev (real photos) is not present")
def test_captures_folder_becomes_the_robots_camera() -> None:
    link = ConsoleApp._open_link("sim", DEV)
    link.connect()
    try:
        shot = link.capture()
    finally:
        link.close()
    assert shot.source == "captures-folder"
    assert shot.image.shape[:2] == (shot.intrinsics.height, shot.intrinsics.width)
