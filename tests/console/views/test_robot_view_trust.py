"""What the console shows of a robot whose telemetry cannot be trusted (issue 9), server side (no
browser: the viser GUI / scene handles are inspected): an unknown position hides the twin and says
"position unknown", a stale one greys it, readiness and the link's warnings are in the robot panel,
Execute and the position-bound vehicle commands are off with the reason; nothing non-finite reaches
``session.json`` or the MCAP recording; the camera panel clears when the first capture is undone.

The robot state is a :class:`console.link.base.RobotState` as the MAVLink link makes it, turned
into the session's snapshot by :func:`console.session.session_types.robot_snapshot` (what the console app
does with every state sample).
"""

from __future__ import annotations

import html
import json
import math
import time
from pathlib import Path
from typing import Any, Iterator

import numpy as np
import pytest
import viser
from mcap.reader import make_reader
from mcap_protobuf.decoder import DecoderFactory

from console.session import operator_state as rules
from console.views.capture_view import NO_CAPTURE, CaptureView
from console.link.base import Mode, RobotState
from console.views.mission_view import MissionView
from console.recording.recording import Recorder
from console.recording.replay import Recording
from console.views.robot_view import RobotView
from console.session.session import CaptureRecord, Detection, RobotSnapshot, Session, SessionError
from console.session.session_types import robot_snapshot
from console.session.vehicle_commands import VehicleCommands
from pipeline.camera.geometry import Intrinsics, Pose

START = (2.5, 0.7, 0.0)
NED_ORIGIN = (0.0, 0.0, 0.0)  # where the MAVLink link puts its placeholder before any position
UNKNOWN = "position unknown: no LOCAL_POSITION_NED yet (no position estimate?)"
NOT_READY = "no position estimate yet (no LOCAL_POSITION_NED); pre-arm checks failing (Need Position Estimate)"
WARNINGS = ("the vehicle's GCS failsafe is off (FS_GCS_ENABLE = 0): it will not act on a lost link",
            "vehicle rebooted (#1): EKF origin moved 3.20 m: the world frame no longer holds")


class _Runner:
    def execute(self, mission: object, command: str = "") -> None: ...

    def pause(self) -> None: ...

    def resume(self) -> None: ...

    def abort(self) -> None: ...


@pytest.fixture()
def server() -> Iterator[viser.ViserServer]:
    srv = viser.ViserServer(host="127.0.0.1", port=0, verbose=False)
    yield srv
    srv.stop()


def _state(position: tuple[float, float, float] = START, **kw: Any) -> RobotState:
    base: dict[str, Any] = dict(time=time.time(), position=position, mode=Mode.IDLE, landed=True)
    base.update(kw)
    return RobotState(**base)


def _known(position: tuple[float, float, float] = START, **kw: Any) -> RobotSnapshot:
    return robot_snapshot(_state(position, **kw))


def _unknown(**kw: Any) -> RobotSnapshot:
    return robot_snapshot(_state(NED_ORIGIN, position_valid=False, pose_age=math.inf, health=UNKNOWN,
                                 ready=False, readiness=NOT_READY, **kw))


def _stale(position: tuple[float, float, float] = START, age: float = 3.2, **kw: Any) -> RobotSnapshot:
    return robot_snapshot(_state(position, position_valid=False, pose_age=age, link_ok=False,
                                 health=f"stale: no valid position for {age:.1f} s", ready=False,
                                 readiness="position stale", **kw))


def _with_mission(tmp_path: Path, autosave: bool = False) -> Session:
    session = Session(tmp_path / "session", start=START, autosave=autosave)
    session.set_robot(_known())
    assert session.add_goal((2.5, 2.0, 0.0)).ok
    session.register()
    session.build_mission()
    return session


def test_robot_snapshot_carries_validity_readiness_and_warnings() -> None:
    snap = _unknown(warnings=WARNINGS)
    assert (snap.position_valid, snap.position_status, snap.ready) == (False, "unknown", False)
    assert math.isinf(snap.pose_age) and snap.readiness == NOT_READY and snap.warnings == WARNINGS
    assert _stale().position_status == "stale" and _known().position_status == "known"
    nan_age = robot_snapshot(_state(position_valid=False, pose_age=math.nan))
    assert nan_age.position_status == "unknown"  # a NaN age is not a fresh pose
    with pytest.raises(ValueError, match="pose_age"):
        RobotSnapshot(Pose.from_xyz_yaw(*START), pose_age=-1.0)


def test_unknown_position_hides_the_twin_says_so_and_turns_execute_off(server: viser.ViserServer,
                                                                      tmp_path: Path) -> None:
    session = _with_mission(tmp_path)
    robot = RobotView(server, session, "mavlink:test")
    missions = MissionView(server, session, _Runner())
    robot.show(session.robot, force=True)  # type: ignore[arg-type]
    assert robot.twin_shown == "known" and not missions._execute.disabled  # the same mission can run when known
    start_before = session.route_snapshot().start

    session.set_robot(_unknown())
    assert robot.twin_shown == "hidden"  # the NED origin placeholder is not drawn as the robot
    assert "position unknown" in robot.status and "no LOCAL_POSITION_NED yet" in robot.status
    assert robot.status.count("no LOCAL_POSITION_NED yet (no position") == 1  # health text not repeated
    view = session.operator_state()
    assert view.execute_blocker is not None and "position is unknown" in view.execute_blocker
    assert missions._execute.disabled and "Execute is off: the robot&#x27;s position is unknown" in missions._why.content
    assert session.route_snapshot().start == start_before  # the route did not follow the placeholder

    session.set_robot(_known())
    assert robot.twin_shown == "known" and "position unknown" not in robot.status
    assert session.operator_state().execute_blocker is None and not missions._execute.disabled


def test_readiness_is_shown_while_not_ready_and_blocks_execute(server: viser.ViserServer, tmp_path: Path) -> None:
    session = _with_mission(tmp_path)
    robot = RobotView(server, session, "mavlink:test")
    session.set_robot(_known(ready=False, readiness="EKF has no horizontal position"))
    assert "not ready to take off" in robot.status and "EKF has no horizontal position" in robot.status
    assert robot.twin_shown == "known"  # the pose itself is valid
    assert session.operator_state().execute_blocker == "the robot is not ready: EKF has no horizontal position"
    session.set_robot(_known())  # ready again: drawn at once (a change of readiness is not throttled)
    assert "not ready" not in robot.status and session.operator_state().execute_blocker is None


def test_warnings_are_listed_in_the_robot_panel(server: viser.ViserServer, tmp_path: Path) -> None:
    session = Session(tmp_path / "session", start=START, autosave=False)
    robot = RobotView(server, session, "mavlink:test")
    session.set_robot(_known(warnings=WARNINGS))
    for w in WARNINGS:
        assert html.escape(w) in robot.status
    session.set_robot(_known())
    assert not any(html.escape(w) in robot.status for w in WARNINGS)  # a cleared warning leaves the panel


def test_a_stale_pose_is_drawn_grey_at_the_last_pose_and_counts_as_link_loss(server: viser.ViserServer,
                                                                            tmp_path: Path) -> None:
    session = _with_mission(tmp_path)
    robot = RobotView(server, session, "mavlink:test")
    session.set_robot(_stale(position=(2.6, 0.7, 0.0), age=4.5))
    assert robot.twin_shown == "stale"
    assert np.allclose(robot._frame.position, (2.6, 0.7, 0.0))  # the last valid pose, marked stale
    assert "POSITION STALE" in robot._label.text
    assert "LINK LOST: position stale" in robot.status and "no valid position for 4.5 s" in robot.status
    assert "last valid pose (2.60, 0.70, 0.00)" in robot.status
    assert robot.status.count("no valid position for") == 1  # the health text is not repeated under it
    why = session.operator_state().execute_blocker
    assert why is not None and "link is lost" in why and "stale" in why


def test_position_bound_vehicle_commands_are_off_with_the_reason(server: viser.ViserServer, tmp_path: Path) -> None:
    session = Session(tmp_path / "session", start=START, autosave=False)
    robot = RobotView(server, session, "mavlink:test", VehicleCommands(session, None, None))
    session.set_robot(_known())  # on the ground, disarmed: the launch spot
    session.set_robot(_known((2.5, 1.5, 1.2), armed=True, landed=False, mode=Mode.HOLDING))
    cmds = session.operator_state().commands
    assert cmds["land"].enabled and cmds["return"].enabled
    assert not cmds["hold"].enabled and "nothing to hold" in cmds["hold"].reason  # hovering still

    session.set_robot(_unknown(armed=True, landed=False, mode=Mode.FLYING))  # the link's mode without a position in the air
    cmds = session.operator_state().commands
    assert cmds["hold"].shown and cmds["hold"].enabled  # Hold needs no position (BRAKE)
    for name in ("land", "return"):
        assert cmds[name].shown and not cmds[name].enabled and "position is unknown" in cmds[name].reason
    assert robot._buttons["land"].disabled and "position is unknown" in robot._why_not.content

    session.set_robot(_stale((2.5, 1.5, 1.2), armed=True, landed=False, mode=Mode.HOLDING))
    cmds = session.operator_state().commands
    assert all(not cmds[n].enabled and "stale" in cmds[n].reason for n in ("hold", "land", "return"))

    ground = _known((3.5, 0.7, 0.0), armed=True, ready=False, readiness="pre-arm checks failing (Need 3D Fix)")
    launch = (2.5, 0.7, 0.0)
    ret = rules.vehicle_commands(ground, session.run, session.workspace, launch)["return"]
    assert not ret.enabled and ret.reason == "the robot is not ready: pre-arm checks failing (Need 3D Fix)"


def _strict(text: str) -> Any:
    def refuse(name: str) -> Any:
        raise AssertionError(f"non-finite JSON value {name}")
    return json.loads(text, parse_constant=refuse)


def test_no_non_finite_value_reaches_session_json_or_the_recording(tmp_path: Path) -> None:
    session = _with_mission(tmp_path, autosave=True)
    rec = Recorder(session, folder=tmp_path / "rec", pose_hz=1000.0, state_hz=1000.0).start()
    session.set_robot(_unknown(warnings=WARNINGS))
    session.add_goal((3.0, 2.0, 0.0))  # an edit while the position is unknown: session.json is written
    session.register()
    session.set_robot(_stale(age=3.2))
    session.set_robot(_known())
    rec.close()
    saved = _strict((tmp_path / "session" / "session.json").read_text())
    assert saved["route"]  # the session really was written
    files = sorted((tmp_path / "rec").glob("*.mcap"))
    assert files
    states, poses = [], []
    decoders = DecoderFactory()
    for path in files:
        with open(path, "rb") as f:
            for schema, channel, message in make_reader(f).iter_messages(log_time_order=True):
                if channel.message_encoding == "json":
                    d = _strict(message.data.decode("utf-8"))
                    if channel.topic == "/robot/state":
                        states.append(d)
                elif channel.topic == "/robot/pose":
                    p = decoders.decoder_for("protobuf", schema)(message.data).pose.position
                    poses.append((p.x, p.y, p.z))
    unknown = [s for s in states if not s["position_valid"] and s["pose_age"] is None]
    stale = [s for s in states if not s["position_valid"] and s["pose_age"] is not None]
    assert unknown and unknown[0]["warnings"] == list(WARNINGS) and unknown[0]["readiness"] == NOT_READY
    assert stale and stale[0]["pose_age"] == pytest.approx(3.2)
    assert states[-1]["position_valid"] and states[-1]["ready"]
    assert poses and poses[0] == pytest.approx(START)  # the robot as the recording began
    assert all(math.dist(p, NED_ORIGIN) > 1.0 for p in poses), poses  # never the placeholder as a pose

    replayed = Recording(files[0])  # read back: the unknown state is unknown again (null -> inf)
    seen = [replayed.state_at(ns).robot for ns in replayed.times("/robot/state")]
    assert [r.position_status for r in seen if r is not None][:4] == ["known", "unknown", "stale", "known"]
    back = next(r for r in seen if r is not None and r.position_status == "unknown")
    assert math.isinf(back.pose_age) and back.warnings == WARNINGS and back.readiness == NOT_READY


def _capture(cid: str) -> CaptureRecord:
    img = np.zeros((48, 64, 3), np.uint8)
    img[10:20, 10:30] = (200, 50, 50)
    return CaptureRecord(
        id=cid, image=img, intrinsics=Intrinsics(50.0, 50.0, 32.0, 24.0, 64, 48),
        camera_pose=Pose((2.5, 0.8, 0.35), (0.0, 0.0, 0.0, 1.0)), robot_pose=Pose.from_xyz_yaw(*START),
        detections=(Detection("office_chair", 0.9, (10.0, 10.0, 30.0, 20.0)),), depth=np.full((48, 64), 3.0, np.float32),
        backend="test backend", timings={"total": 0.5})


def test_undoing_the_first_capture_clears_the_camera_panel(server: viser.ViserServer, tmp_path: Path) -> None:
    session = Session(tmp_path / "session", start=START, autosave=False)
    view = CaptureView(server, session)
    session.set_capture(_capture("cap-1"))
    assert view.shown == "cap-1" and view.has_frustum and "cap-1" in view._caption.content
    session.set_capture(_capture("cap-2"))
    assert view.shown == "cap-2"

    session.undo_edit()  # back to the first capture: it is shown again
    assert session.capture is not None and session.capture.id == "cap-1"
    assert view.shown == "cap-1" and view.has_frustum

    session.undo_edit()  # before any capture: the panel empties itself
    assert session.capture is None
    assert view.shown is None and not view.has_frustum
    assert view._caption.content == NO_CAPTURE


def test_a_placeholder_pose_is_never_the_launch_spot_or_the_route_start(tmp_path: Path) -> None:
    session = Session(tmp_path / "session", start=START, autosave=False)
    session.set_robot(_unknown())  # disarmed on the ground at the placeholder (NED origin)
    assert session.operator_state().launch is None
    assert session.route_snapshot().start == pytest.approx(START)
    assert rules.robot_origin(session.robot, session.workspace) is None  # type: ignore[arg-type]
    session.set_robot(_stale((3.0, 1.0, 0.0)))
    assert session.operator_state().launch is None and session.route_snapshot().start == pytest.approx(START)
    session.set_robot(_known((3.0, 1.0, 0.0)))  # known: the route follows, the launch spot is set
    assert session.operator_state().launch == pytest.approx((3.0, 1.0, 0.0))
    assert session.route_snapshot().start == pytest.approx((3.0, 1.0, 0.0))
    session.set_robot(_unknown())
    with pytest.raises(SessionError, match="position is unknown.*cannot plan from it"):
        session.replan_from_robot()
