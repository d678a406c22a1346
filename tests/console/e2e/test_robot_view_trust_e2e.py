"""End to end (no browser): the console on the MAVLink emulator shows what it can trust of the
vehicle's telemetry (issue 9). Before the EKF has a position the robot panel says "position
unknown", hides the twin, lists why the vehicle is not ready and the link's warnings, and Execute is
off with the reason; once positions flow the twin is drawn; when they stop (heartbeats go on) the
twin turns grey at the last pose and the panel says the position is stale.
"""

from __future__ import annotations

import html
from pathlib import Path

from console.app import ConsoleApp, ConsoleConfig, wait_until
from console.link.mavlink import MavlinkConfig
from mav_emulator import ArduCopterEmulator, free_udp_port
from pipeline.scene import Scene, SceneObject

CRATE = SceneObject("crate-1", "cardboard_box", (4.3, 7.0, 0.25), (0.5, 0.5, 0.5))
"""The operator's hand-made map (a scene file, taken as fully known): before any capture the console's
own empty map is space no capture has seen, where no goal is planned."""


def test_the_console_shows_an_unknown_then_known_then_stale_position(tmp_path: Path) -> None:
    port = free_udp_port()
    cfg = ConsoleConfig(robot=f"mavlink:udpin:127.0.0.1:{port}", session_dir=tmp_path / "s", port=0, fresh=True,
                        link_options={"config": MavlinkConfig(heartbeat_timeout=2.0, pose_timeout=1.0)})
    app = ConsoleApp(cfg).start()
    emu = ArduCopterEmulator(port)
    emu.ekf_ready = False  # no LOCAL_POSITION_NED, pre-arm fails with "Need Position Estimate"
    emu.params["FS_GCS_ENABLE"] = 0.0  # the link warns: the vehicle's own GCS failsafe is off
    try:
        session, robot = app.session, app.views["robot"]
        assert session is not None
        with emu:
            assert wait_until(lambda: session.robot is not None and session.robot.position_status == "unknown"
                              and not session.robot.ready and session.robot.warnings, 60), session.robot
            assert wait_until(lambda: "position unknown" in robot.status and "not ready to take off" in robot.status
                              and "FS_GCS_ENABLE is 0" in robot.status, 60), robot.status
            assert robot.twin_shown == "hidden"
            assert "no position estimate" in robot.status
            session.spawn(Scene(objects=(CRATE,)), origin="file room.json")
            assert session.add_goal((2.5, 2.0, 0.0)).ok
            session.register()
            session.build_mission()
            why = session.operator_state().execute_blocker
            assert why is not None and "position is unknown" in why

            emu.ekf_ready = True  # positions flow
            assert wait_until(lambda: robot.twin_shown == "known" and "position unknown" not in robot.status, 60), \
                robot.status
            assert wait_until(lambda: session.robot is not None and session.robot.ready, 60), session.robot
            assert html.escape("FS_GCS_ENABLE is 0") in robot.status  # a standing warning stays listed

            emu.telemetry_enabled = False  # streams stop, heartbeats go on
            assert wait_until(lambda: robot.twin_shown == "stale", 60), robot.status
            assert wait_until(lambda: "LINK LOST: position stale" in robot.status and "last valid pose" in robot.status
                              and "POSITION STALE" in robot._label.text, 60), robot.status
            why = session.operator_state().execute_blocker
            assert why is not None and "stale" in why
    finally:
        if app.preload is not None:  # a model still loading in a daemon thread aborts the interpreter at exit
            app.preload.join(120)
        app.stop()
