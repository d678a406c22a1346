"""The robot line says what the vehicle's own state says: while its motors spool up (not armed yet) a
take-off reads ``arming``, never ``taking off · disarmed``; once armed it reads ``taking off · armed``."""

from __future__ import annotations

import re

from console.link.sim import SimConfig, SimRobot
from console.session.session_types import robot_snapshot
from console.views.robot_view import activity_text, status_text
from planner.mission import MissionSegment, SegmentKind
from pipeline.scene import Scene


def _words(line: str) -> str:
    return re.sub(r"<[^>]+>", "", line)


def test_a_take_off_reads_arming_until_the_vehicle_is_armed() -> None:
    robot = SimRobot(world=Scene(), config=SimConfig(spool_time=0.5), room=None, manual_clock=True)
    robot.connect()
    try:
        robot.run_segment(MissionSegment(SegmentKind.TAKEOFF, ((2.5, 0.7, 0.0), (2.5, 0.7, 1.0))))
        seen: list[tuple[str, bool, str]] = []
        for _ in range(200):  # manual clock: 0.02 s a step, the take-off is over well before 4 s
            robot.step(0.02)
            snap = robot_snapshot(robot.latest_state())
            line = _words(status_text(snap, "sim", ()))
            seen.append((snap.mode, snap.armed, line))
            if snap.mode == "taking_off" and snap.armed:
                break
        spooling = [line for mode, armed, line in seen if mode == "taking_off" and not armed]
        climbing = [line for mode, armed, line in seen if mode == "taking_off" and armed]
        assert spooling and climbing, seen
        assert all("· arming · disarmed ·" in line and "taking off" not in line for line in spooling), spooling
        assert "· taking off · armed ·" in climbing[-1], climbing[-1]
    finally:
        robot.close()


def test_activity_words_follow_the_mode_otherwise() -> None:
    from console.session.session import RobotSnapshot
    from pipeline.camera.geometry import Pose

    pose = Pose.from_xyz_yaw(1.0, 1.0, 0.0)
    assert activity_text(RobotSnapshot(pose=pose, mode="taking_off", armed=False)) == "arming"
    assert activity_text(RobotSnapshot(pose=pose, mode="taking_off", armed=True)) == "taking off"
    assert activity_text(RobotSnapshot(pose=pose, mode="idle", armed=False)) == "idle"
    assert activity_text(RobotSnapshot(pose=pose, mode="landing", armed=True)) == "landing"
