"""The console's command line: options reach the robot link and the mission manager."""

from __future__ import annotations

import time
from pathlib import Path

import pytest

from console.app import ConsoleApp
from console.cli.morphonavi import build_parser, main

DEV = Path(__file__).resolve().parents[3].parent / "shared" / "bench" / "dev"


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

    from console.cli.console_cmd import link_options

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


def test_autopilot_status_messages_reach_the_operator(tmp_path: Path) -> None:
    """A MAVLink vehicle's STATUSTEXT lines show in the robot panel; warnings and worse pop up once."""
    from pymavlink import mavutil

    from console.app import ConsoleConfig, wait_until
    from console.link.mavlink import MavlinkConfig
    from console.views.robot_view import status_text
    from console.session.session import NOTICE
    from mav_emulator import ArduCopterEmulator, free_udp_port

    sev = mavutil.mavlink
    port = free_udp_port()
    cfg = ConsoleConfig(robot=f"mavlink:udpin:127.0.0.1:{port}", session_dir=tmp_path / "s", port=0, fresh=True,
                        link_options={"config": MavlinkConfig(heartbeat_timeout=1.0)})
    app = ConsoleApp(cfg).start()
    try:
        session = app.session
        notices = []
        session.subscribe(lambda t, p: notices.append(p) if t == NOTICE else None)
        with ArduCopterEmulator(port) as emu:
            assert wait_until(lambda: session.robot is not None and session.robot.healthy, 60)
            emu.say("EKF3 IMU0 is using GPS", sev.MAV_SEVERITY_INFO)
            emu.say("Crash: Disarming", sev.MAV_SEVERITY_CRITICAL)
            assert wait_until(lambda: [t for _, t in session.robot.messages][-2:] ==
                              ["INFO: EKF3 IMU0 is using GPS", "CRITICAL: Crash: Disarming"], 30), session.robot
            panel = status_text(session.robot, "mavlink")
            assert "CRITICAL: Crash: Disarming" in panel and "INFO: EKF3 IMU0 is using GPS" in panel
            assert wait_until(lambda: any(n.body == "CRITICAL: Crash: Disarming" for n in notices), 30), notices
            time.sleep(0.5)  # more state samples carrying the same messages: no repeated pop-up
            told = [n.body for n in notices if n.title == "Robot says"]
            assert told == ["CRITICAL: Crash: Disarming"]
    finally:
        app.stop()


def test_live_camera_options(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    import cv2
    import numpy as np

    from console.cli.console_cmd import link_options, photo_source

    video = tmp_path / "v.avi"
    writer = cv2.VideoWriter(str(video), cv2.VideoWriter_fourcc(*"MJPG"), 20.0, (160, 120))
    for i in range(10):
        writer.write(np.full((120, 160, 3), 10 * i, np.uint8))
    writer.release()
    cam = tmp_path / "camera.toml"
    cam.write_text("[intrinsics]\nfx = 150.0\nfy = 150.0\ncx = 80.0\ncy = 60.0\nwidth = 160\nheight = 120\n"
                   "[mount]\nposition = [0.1, 0.0, 0.8]\npitch_deg = 10.0\n")
    args = build_parser().parse_args(["console", "--camera", str(video), "--camera-file", str(cam)])
    source = photo_source(args)
    try:
        assert source is not None and source.next(timeout=20).image.shape == (120, 160, 3)
        assert photo_source(args) is source  # opened once
    finally:
        source.close()
    args = build_parser().parse_args(["console", "--robot", "mavlink:udpin:127.0.0.1:0", "--camera", str(video),
                                      "--camera-file", str(cam)])
    opts = link_options(args)
    try:
        assert callable(opts["camera"]) and opts["mount"].position == (0.1, 0.0, 0.8)
        assert photo_source(args) is None
    finally:
        opts["camera"].close()
    for argv, message in (
        (["--camera", str(video)], "--camera needs --camera-file"),
        (["--camera-file", str(cam)], "--camera-file is for a live camera"),
        (["--camera", str(video), "--camera-file", str(tmp_path / "nope.toml")], "camera file not found"),
        (["--camera", "ftp://x", "--camera-file", str(cam)], "unsupported scheme"),
        (["--camera", str(video), "--camera-file", str(cam), "--captures", str(tmp_path)], "give one camera"),
    ):
        assert main(["console", *argv, "--session", str(tmp_path / "s")]) == 2
        assert message in capsys.readouterr().err


def test_the_console_shows_the_live_camera_preview(tmp_path: Path) -> None:
    import cv2
    import numpy as np

    from console.app import ConsoleConfig, wait_until
    from console.link.camera_source import CameraSource
    from pipeline.camera.geometry import CameraConfig, Intrinsics

    video = tmp_path / "v.avi"
    writer = cv2.VideoWriter(str(video), cv2.VideoWriter_fourcc(*"MJPG"), 20.0, (160, 120))
    for i in range(20):
        writer.write(np.full((120, 160, 3), 10 * i, np.uint8))
    writer.release()
    source = CameraSource(str(video), CameraConfig(Intrinsics(150.0, 150.0, 80.0, 60.0, 160, 120))).start()
    app = ConsoleApp(ConsoleConfig(session_dir=tmp_path / "s", port=0, fresh=True, captures=source)).start()  # type: ignore[arg-type]
    try:
        preview = app.views["camera_preview"]
        assert wait_until(lambda: "live, last frame" in preview._status.content, 30), preview._status.content
        assert wait_until(lambda: app.session is not None and app.link.connected, 30)
        assert app.link.capture().image.shape == (120, 160, 3)
    finally:
        app.stop()
        source.close()


def test_a_captures_folder_with_a_resized_photo_stops_the_console_at_start(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    import json

    import cv2
    import numpy as np

    photos = tmp_path / "photos"
    photos.mkdir()
    cv2.imwrite(str(photos / "small.jpg"), np.full((318, 438, 3), 100, np.uint8))  # 60 % of 730 x 530
    (photos / "small.json").write_text(json.dumps({"K": [[584.0, 0, 365.0], [0, 584.0, 265.0], [0, 0, 1]]}))
    code = main(["console", "--captures", str(photos), "--session", str(tmp_path / "s"), "--port", "0"])
    err = capsys.readouterr().err
    assert code == 2 and "small.json: 'width' is required" in err and "Traceback" not in err


def test_a_console_stopped_while_its_models_load_exits_cleanly(tmp_path: Path) -> None:
    """Stopping the console while the background model loading runs waits for it: the process exits 0
    (an interpreter exiting under onnxruntime's session build aborts with 'terminate called ...')."""
    import subprocess
    import sys

    from mav_emulator import free_udp_port

    code = (
        "import sys; from pathlib import Path; from console.app import ConsoleApp, ConsoleConfig\n"
        f"cfg = ConsoleConfig(robot='mavlink:udpin:127.0.0.1:{free_udp_port()}', session_dir=Path(sys.argv[1]),"
        " port=0, fresh=True)\n"
        "app = ConsoleApp(cfg).start()\n"
        "print('before', app.preload.state, flush=True)\n"
        "app.stop()\n"
        "print('after', app.preload.state, flush=True)\n"
    )
    proc = subprocess.run([sys.executable, "-c", code, str(tmp_path / "s")], capture_output=True, text=True,
                          timeout=600, cwd=Path(__file__).resolve().parents[3])
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert "terminate called" not in proc.stderr
    states = dict(line.split() for line in proc.stdout.splitlines() if line.startswith(("before ", "after ")))
    assert states["after"] in ("ready", "failed"), states  # stop() waited for the loading to end
