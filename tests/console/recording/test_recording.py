"""The mission log: a short console session on the simulated robot (capture, plan, execute) is
recorded as MCAP with Foxglove's well-known schemas, and read back with the ``mcap`` reader.

Also: an unwritable folder or a full disk gives one notice and never stops the console.
"""

from __future__ import annotations

import json
import math
import resource
import signal
import subprocess
import time
from pathlib import Path
from typing import Any

import pytest
from mcap.reader import make_reader
from mcap_protobuf.decoder import DecoderFactory

from console.app import ConsoleApp, ConsoleConfig, wait_until
from console.session.mapping_job import JOB_NAME
from console.recording.recording import Recorder
from console.session.session import NOTICE, ROBOT, RobotSnapshot, Session
from pipeline.camera.geometry import Pose
from pipeline.scene import Scene, SceneObject

FOXGLOVE_SCHEMAS = {
    "/robot/pose": "foxglove.PoseInFrame", "/tf": "foxglove.FrameTransform", "/camera/image": "foxglove.CompressedImage",
    "/camera/calibration": "foxglove.CameraCalibration", "/camera/depth": "foxglove.CompressedImage",
    "/map/objects": "foxglove.SceneUpdate", "/map/grid": "foxglove.SceneUpdate", "/paths": "foxglove.SceneUpdate",
    "/log": "foxglove.Log",
}
JSON_SCHEMAS = {
    "/robot/state": "morphonavi.RobotState", "/morphonavi/capture": "morphonavi.Capture",
    "/mission/progress": "morphonavi.MissionProgress", "/morphonavi/scene": "morphonavi.Scene",
    "/morphonavi/route": "morphonavi.Route", "/morphonavi/mission": "morphonavi.Mission",
    "/morphonavi/session": "morphonavi.Session", "/map/known_space": "morphonavi.KnownSpace",
}
GOALS = [(x, y, 0.0) for y in (2.4, 2.0, 1.6) for x in (2.5, 1.5, 3.5, 1.0, 4.0)]


def run_short_mission(tmp_path: Path) -> tuple[Path, list[RobotSnapshot], Any]:
    """Console on the simulated robot: capture & map, plan to a free spot, execute; the recording's file.

    Returns the MCAP path, every robot snapshot the session announced, and the session (stopped).
    """
    from console.link.sim import SimConfig, SimRobot

    robot = SimRobot(config=SimConfig(time_scale=12.0))
    app = ConsoleApp(ConsoleConfig(robot="sim", session_dir=tmp_path / "session", scene_dir=tmp_path / "scenes",
                                   port=0, fresh=True), link=robot)
    app.start()
    snaps: list[RobotSnapshot] = []
    try:
        session = app.session
        assert session is not None and app.mapping is not None and app.runner is not None
        session.subscribe(lambda t, p: snaps.append(p) if t == ROBOT else None)
        assert wait_until(lambda: session.robot is not None, 60), "the simulated robot never reported"
        assert app.mapping.start()
        assert wait_until(lambda: session.job.name == JOB_NAME and not session.job.running and session.job.fraction == 1.0, 300), session.job
        assert session.capture is not None and len(session.scene.objects) >= 5
        for goal in GOALS:
            if session.add_goal(goal).ok:
                break
        else:
            pytest.fail("no reachable goal in front of the robot")
        session.register()
        mission = session.build_mission()
        app.runner.execute(mission)
        assert wait_until(lambda: session.run.state == "done", 180), session.run
        session.notify("Test", "mission flown", "success")
    finally:
        app.stop()
    files = sorted((tmp_path / "session" / "recordings").glob("*.mcap"))
    assert len(files) == 1, files  # one file per console run
    return files[0], snaps, session


def read_all(path: Path) -> tuple[Any, list[tuple[str, str, int, Any]]]:
    """The summary and every message as ``(topic, schema name, log time [ns], decoded)`` in file order."""
    out = []
    with open(path, "rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        summary = reader.get_summary()
        for schema, channel, message in reader.iter_messages(log_time_order=False):
            if channel.message_encoding == "json":
                decoded = json.loads(message.data)
            else:
                decoded = DecoderFactory().decoder_for("protobuf", schema)(message.data)
            out.append((channel.topic, schema.name, message.log_time, decoded))
    return summary, out


@pytest.fixture(scope="module")
def recorded(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, list[RobotSnapshot], Any]:
    return run_short_mission(tmp_path_factory.mktemp("rec"))


def test_a_short_mission_is_recorded_with_foxglove_schemas(recorded: Any) -> None:
    path, snaps, session = recorded
    summary, msgs = read_all(path)
    schemas = {ch.topic: summary.schemas[ch.schema_id].name for ch in summary.channels.values()}
    assert schemas == {**FOXGLOVE_SCHEMAS, **JSON_SCHEMAS}
    counts = {summary.channels[cid].topic: n for cid, n in summary.statistics.channel_message_counts.items()}
    assert counts == {t: sum(1 for m in msgs if m[0] == t) for t in schemas}  # the statistics agree with the data
    # one capture: one photo, its calibration, its depth and metadata
    assert counts["/camera/image"] == counts["/camera/calibration"] == counts["/camera/depth"] == 1
    assert counts["/morphonavi/capture"] == 1
    # the map: the empty start, then the capture's spawn
    assert counts["/map/objects"] >= 2 and counts["/morphonavi/scene"] == counts["/map/objects"]
    assert counts["/map/grid"] >= 2
    # robot pose downsampled from the sim's stream, never more than announced
    assert 5 <= counts["/robot/pose"] <= len(snaps) and counts["/tf"] == counts["/robot/pose"] + 1  # + camera tf
    # time order: log times never go back in file order (the messages of one change share its time)
    times = [m[2] for m in msgs]
    assert all(a <= b for a, b in zip(times, times[1:])) and times[-1] > times[0]

    photo = next(m[3] for m in msgs if m[0] == "/camera/image")
    assert photo.format == "jpeg" and bytes(photo.data[:2]) == b"\xff\xd8"
    calib = next(m[3] for m in msgs if m[0] == "/camera/calibration")
    intr = session.capture.intrinsics
    assert (calib.width, calib.height) == (intr.width, intr.height) and calib.K[0] == pytest.approx(intr.fx)

    last_map = [m[3] for m in msgs if m[0] == "/map/objects"][-1]
    ids = {e.id for e in last_map.entities}
    assert ids == {f"object/{o.id}" for o in session.scene.objects}
    ent = next(e for e in last_map.entities if e.id == f"object/{session.scene.objects[0].id}")
    w, h, l = session.scene.objects[0].size
    assert (ent.cubes[0].size.x, ent.cubes[0].size.y, ent.cubes[0].size.z) == pytest.approx((l, w, h))
    assert ent.texts[0].text.startswith(session.scene.objects[0].label)
    assert ent.models and bytes(ent.models[0].data[:4]) == b"glTF"  # the proxy model, embedded

    grid = [m[3] for m in msgs if m[0] == "/map/grid"][-1]
    occupied = next(e for e in grid.entities if e.id == "grid/occupied")
    assert len(occupied.cubes) == session.grid.counts()["occupied"] > 0

    paths = [m[3] for m in msgs if m[0] == "/paths"]
    assert any(e.id == "paths/mission" and e.lines for p in paths for e in p.entities)
    assert any(e.id == "paths/registered" and e.lines for p in paths for e in p.entities)
    progress = [m[3]["state"] for m in msgs if m[0] == "/mission/progress"]
    assert "running" in progress and progress[-1] == "done"
    logs = [m[3].message for m in msgs if m[0] == "/log"]
    assert any(t.startswith("capture ") for t in logs) and any("mission" in t and "built" in t for t in logs)
    assert any(t == "Test: mission flown" for t in logs)


def test_a_recorded_pose_is_the_sessions_pose_at_that_time(recorded: Any) -> None:
    path, snaps, _ = recorded
    _, msgs = read_all(path)
    by_stamp = {round(s.stamp * 1e9): s for s in snaps}
    first = min(by_stamp)  # the test listens from just after the console started
    poses = [m for m in msgs if m[0] == "/robot/pose" and m[3].timestamp.ToNanoseconds() >= first]
    assert len(poses) >= 5
    for _, _, _, pose in poses:
        snap = by_stamp[pose.timestamp.ToNanoseconds()]  # each one the session announced, as announced
        p = pose.pose.position
        assert (p.x, p.y, p.z) == pytest.approx(snap.pose.translation, abs=1e-9)
        q = pose.pose.orientation
        assert (q.x, q.y, q.z, q.w) == pytest.approx(snap.pose.quaternion, abs=1e-9)
    # the robot walked: the recorded track spans the walk
    xs = [(p[3].pose.position.x, p[3].pose.position.y) for p in poses]
    assert math.dist(xs[0], xs[-1]) > 0.5
    states = [m[3] for m in msgs if m[0] == "/robot/state" and round(m[3]["stamp"] * 1e9) >= first]
    assert states and all(tuple(s["translation"]) == by_stamp[round(s["stamp"] * 1e9)].pose.translation for s in states)


def _session_with_notices(tmp_path: Path) -> tuple[Session, list[Any]]:
    session = Session(tmp_path / "session", autosave=False)
    notices: list[Any] = []
    session.subscribe(lambda t, p: notices.append(p) if t == NOTICE else None)
    return session, notices


def _churn(session: Session, n: int = 30) -> None:
    for i in range(n):
        session.set_robot(RobotSnapshot(pose=Pose.from_xyz_yaw(2.5, 0.7 + 0.01 * i), stamp=time.time(), mode=f"m{i % 3}"))
    session.spawn(Scene(objects=(SceneObject("a", "office_chair", (2.0, 3.0, 0.5), (0.6, 1.0, 0.6)),)), "test")
    session.notify("still", "working")


def test_an_unwritable_folder_gives_one_notice_and_the_session_goes_on(tmp_path: Path) -> None:
    blocker = tmp_path / "a_file"
    blocker.write_text("not a folder")
    session, notices = _session_with_notices(tmp_path)
    rec = Recorder(session, folder=blocker / "recordings").start()
    _churn(session)
    assert wait_until(lambda: rec.failed is not None, 60)
    _churn(session)
    rec.close()
    stopped = [n for n in notices if n.title == "Recording stopped"]
    assert len(stopped) == 1 and "a_file" in stopped[0].body, notices
    assert len(session.scene.objects) == 1 and any(n.title == "still" for n in notices)


def test_an_immutable_folder_gives_one_notice(tmp_path: Path) -> None:
    folder = tmp_path / "locked"
    folder.mkdir()
    if subprocess.run(["chattr", "+i", str(folder)], capture_output=True).returncode != 0:
        pytest.skip("chattr +i is not supported on this file system")
    try:
        session, notices = _session_with_notices(tmp_path)
        rec = Recorder(session, folder=folder).start()
        _churn(session)
        assert wait_until(lambda: rec.failed is not None, 60)
        rec.close()
        stopped = [n for n in notices if n.title == "Recording stopped"]
        assert len(stopped) == 1 and "locked" in stopped[0].body
        assert list(folder.iterdir()) == []
    finally:
        subprocess.run(["chattr", "-i", str(folder)], check=True)


def test_a_full_disk_gives_one_notice(tmp_path: Path) -> None:
    """A file-size limit (RLIMIT_FSIZE) makes writes fail with EFBIG, as a full disk fails them with ENOSPC."""
    session, notices = _session_with_notices(tmp_path)
    rec = Recorder(session, folder=tmp_path / "rec").start()
    old_handler = signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
    soft, hard = resource.getrlimit(resource.RLIMIT_FSIZE)
    resource.setrlimit(resource.RLIMIT_FSIZE, (4096, hard))
    try:
        big = tuple(SceneObject(f"o{i}", "cardboard box", (0.5 + (i % 8) * 0.5, 2.0 + (i // 8) * 0.5, 0.2), (0.3, 0.3, 0.3))
                    for i in range(40))
        session.spawn(Scene(objects=big), "test")  # proxy models and grid cells: well over 4 kB
        for _ in range(3):
            _churn(session)
        rec.close()  # finishing the file writes the rest: fails too
    finally:
        resource.setrlimit(resource.RLIMIT_FSIZE, (soft, hard))
        signal.signal(signal.SIGXFSZ, old_handler)
    assert rec.failed is not None and "cannot" in rec.failed
    stopped = [n for n in notices if n.title == "Recording stopped"]
    assert len(stopped) == 1, notices
    assert len(session.scene.objects) == 41



def test_a_large_recording_is_split_into_parts_that_each_open_on_their_own(tmp_path: Path) -> None:
    from console.recording.replay import Recording, ReplayError

    session, notices = _session_with_notices(tmp_path)
    rec = Recorder(session, folder=tmp_path / "rec", max_bytes=60_000).start()
    for k in range(6):  # each map carries the proxy models: tens of kB per change
        objs = tuple(SceneObject(f"o{i}", "office_chair", (0.5 + (i % 8) * 0.5, 2.0 + (i // 8) * 0.6 + 0.01 * k, 0.5),
                                 (0.6, 1.0, 0.6)) for i in range(16))
        session.spawn(Scene(objects=objs), f"batch {k}")
        _churn(session, 10)
    rec.close()
    assert rec.failed is None and not [n for n in notices if n.title == "Recording stopped"]
    parts = rec.paths  # in the order they were written: name.mcap, name-002.mcap, ...
    assert len(parts) >= 2 and sorted(parts) == sorted((tmp_path / "rec").glob("*.mcap"))
    assert parts[1].name == parts[0].name.replace(".mcap", "-002.mcap")
    last_scene = session.scene
    for n, part in enumerate(parts):
        assert part.stat().st_size < 60_000 + 2 * (1 << 16)  # rotated close to the limit
        r = Recording(part)  # each part holds the session info and the state as it was when it began
        assert r.info is not None and r.info.workspace == session.workspace
        first = r.state_at(r.start)
        assert len(first.scene.objects) == (0 if n == 0 else 16)
    end = Recording(parts[-1]).state_at(Recording(parts[-1]).end)
    assert [o.position for o in end.scene.objects] == [o.position for o in last_scene.objects]
    # the parts in order read as one timeline
    whole, second = Recording(parts), Recording(parts[1])
    assert (whole.start, whole.end) == (Recording(parts[0]).start, Recording(parts[-1]).end)
    assert whole.state_at(second.start).scene == second.state_at(second.start).scene
    assert whole.state_at(whole.end).scene.objects == end.scene.objects
    assert whole.count("/robot/state") == sum(Recording(p).count("/robot/state") for p in parts)
    with pytest.raises(ReplayError, match="missing.mcap: no such file"):
        Recording([parts[0], tmp_path / "missing.mcap"])


def test_no_record_turns_the_recording_off(tmp_path: Path) -> None:
    from console.cli.morphonavi import build_parser

    parser = build_parser()
    assert parser.parse_args(["console"]).record is True
    assert parser.parse_args(["console", "--no-record"]).record is False
    app = ConsoleApp(ConsoleConfig(session_dir=tmp_path / "session", scene_dir=tmp_path / "scenes", port=0, fresh=True,
                                   record=False)).start()
    try:
        assert app.recorder is None and app.session is not None
        assert wait_until(lambda: app.session.robot is not None, 30)
    finally:
        app.stop()
    assert not (tmp_path / "session" / "recordings").exists()


def test_the_live_view_serves_the_topics_over_the_foxglove_websocket_protocol(tmp_path: Path) -> None:
    import base64
    import struct

    from mcap.records import Schema
    from websockets.sync.client import connect

    from console.cli.morphonavi import main

    assert main(["console", "--no-record", "--foxglove-ws", "0", "--session", str(tmp_path / "x")]) == 2
    app = ConsoleApp(ConsoleConfig(session_dir=tmp_path / "session", scene_dir=tmp_path / "scenes", port=0, fresh=True,
                                   foxglove_port=0)).start()
    snaps: list[RobotSnapshot] = []
    try:
        session = app.session
        assert session is not None and app.recorder is not None and app.recorder.live is not None
        session.subscribe(lambda t, p: snaps.append(p) if t == ROBOT else None)
        session.spawn(Scene(objects=(SceneObject("a", "office_chair", (2.0, 3.0, 0.5), (0.6, 1.0, 0.6)),)), "test")
        port = app.recorder.live.port
        with connect(f"ws://127.0.0.1:{port}", subprotocols=["foxglove.sdk.v1"], open_timeout=20) as ws:
            channels: dict[str, Any] = {}
            while "/map/objects" not in channels or "/robot/pose" not in channels:
                msg = json.loads(ws.recv(timeout=20))
                if msg["op"] == "advertise":
                    channels.update({c["topic"]: c for c in msg["channels"]})
            assert channels["/robot/pose"]["schemaName"] == "foxglove.PoseInFrame"
            assert channels["/map/objects"]["schemaName"] == "foxglove.SceneUpdate"
            ws.send(json.dumps({"op": "subscribe", "subscriptions": [
                {"id": 1, "channelId": channels["/map/objects"]["id"]}, {"id": 2, "channelId": channels["/robot/pose"]["id"]}]}))
            decoders = {sub: DecoderFactory().decoder_for("protobuf", Schema(
                id=sub, name=channels[t]["schemaName"], encoding="protobuf", data=base64.b64decode(channels[t]["schema"])))
                for sub, t in ((1, "/map/objects"), (2, "/robot/pose"))}
            got: dict[int, Any] = {}
            while len(got) < 2:
                frame = ws.recv(timeout=20)
                if isinstance(frame, bytes) and frame[0] == 1:  # message data: op, subscription, time, payload
                    sub = struct.unpack_from("<I", frame, 1)[0]
                    got[sub] = decoders[sub](frame[13:])
        # the map as it is (sent at once on subscribing), a robot pose the session announced
        assert [e.id for e in got[1].entities] == ["object/a"]
        pose = got[2]
        match = [s for s in snaps if round(s.stamp * 1e9) == pose.timestamp.ToNanoseconds()]
        assert match and match[0].pose.translation == pytest.approx(
            (pose.pose.position.x, pose.pose.position.y, pose.pose.position.z), abs=1e-9)
    finally:
        app.stop()


def test_the_json_channels_carry_typed_schemas_their_messages_follow(recorded: Any) -> None:
    """Foxglove reads the fields of a JSON channel from its jsonschema: every one is typed, and validates its data."""
    from jsonschema import Draft202012Validator

    path, _, _ = recorded
    summary, msgs = read_all(path)
    json_channels = [ch for ch in summary.channels.values() if ch.message_encoding == "json"]
    assert {ch.topic for ch in json_channels} == set(JSON_SCHEMAS)
    for ch in json_channels:
        schema = summary.schemas[ch.schema_id]
        assert schema.encoding == "jsonschema"
        body = json.loads(schema.data)
        assert body.get("properties"), (ch.topic, body)  # typed fields, not {"type": "object"}
        validator = Draft202012Validator(body)
        for topic, _, _, data in msgs:
            if topic == ch.topic:
                assert not list(validator.iter_errors(data)), (topic, data)
    robot = json.loads(next(summary.schemas[c.schema_id] for c in json_channels if c.topic == "/robot/state").data)
    assert robot["properties"]["battery"]["type"] == ["number", "null"]
