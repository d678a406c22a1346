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


def test_mavlink_options_become_the_links_frame_and_ground_commands() -> None:
    import math

    from console.console_cmd import link_options

    args = build_parser().parse_args(["console", "--robot", "mavlink:udpin:127.0.0.1:0", "--ned-origin", "2.5,0.7,0",
                                      "--north-deg", "0", "--ground-command", "velocity"])
    cfg = link_options(args)["config"]
    assert cfg.ned.origin == (2.5, 0.7, 0.0) and cfg.ned.north_yaw == pytest.approx(0.0)
    assert cfg.ground.command == "velocity"
    # north = world +x: a point 1 m along +x from the origin is 1 m north
    assert cfg.ned.to_ned((3.5, 0.7, 0.0)) == pytest.approx((1.0, 0.0, 0.0))
    assert link_options(build_parser().parse_args(["console"])) == {}
    with pytest.raises(SystemExit):
        build_parser().parse_args(["console", "--ned-origin", "1,2"])
    assert math.isfinite(cfg.ned.north_yaw)
