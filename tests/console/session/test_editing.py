"""Editing at session level: Save as over a snapshot and Delete ask first, Redo beside Undo, the undo
and redo history and capture ids across a restart, the route start that follows the robot during every
run, top-view altitude clicks under the cursor, and zero-length goals refused with the reason.

Live parts run the real stack (the simulated robot, the mission manager, the vehicle commands) and wait
on state, never on time.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

from console.session.capture_files import highest_capture_number, numbered_capture_id
from console.session.goal_rules import RUN_START_STEP
from console.session.history import HISTORY_DEPTH
from console.session.history_file import HISTORY_FILE
from console.session.session import ROUTE, CaptureRecord, Detection, RobotSnapshot, RunStatus, Session, SessionError
from console.session.session_store import ConfirmNeeded
from console.views.picking import click_goal, looks_down
from pipeline.camera.geometry import Intrinsics, Pose
from pipeline.scene import Scene, SceneObject
from tests.console.session.test_operator_state import Stack, _boxes, wait_for

START = (2.5, 0.7, 0.0)


def _box(oid: str, x: float, y: float) -> SceneObject:
    return SceneObject(oid, "cardboard_box", (x, y, 0.3), (0.5, 0.5, 0.6))


def _capture(cap_id: str, shade: int = 0) -> CaptureRecord:
    return CaptureRecord(
        id=cap_id, image=np.full((24, 32, 3), shade, np.uint8), intrinsics=Intrinsics(30.0, 30.0, 16.0, 12.0, 32, 24),
        camera_pose=Pose((2.5, 0.8, 0.35), (0.0, 0.0, 0.0, 1.0)), robot_pose=Pose.from_xyz_yaw(2.5, 0.7, 0.0),
        detections=(Detection("cardboard_box", 0.9, (1.0, 1.0, 9.0, 9.0), "a"),), depth=None, backend="test", timings={},
    )


@pytest.fixture()
def session(tmp_path: Path) -> Session:
    return Session(tmp_path / "s", start=START)


# --- Save as and Delete ask first ---------------------------------------------------------------------
def test_save_as_over_a_named_snapshot_asks_before_overwriting(session: Session) -> None:
    session.spawn(Scene(objects=(_box("a", 1.0, 2.0),)))
    path = session.save("before-flight")
    kept = path.read_text()
    session.spawn(Scene(objects=(_box("b", 3.0, 2.0),)))
    with pytest.raises(ConfirmNeeded) as asked:
        session.save("before-flight")
    assert asked.value.question == "Overwrite 'before-flight'?" and asked.value.confirm == "Save over it"
    assert "saving over it replaces it" in asked.value.detail
    assert path.read_text() == kept  # nothing written until the operator agrees
    assert session.save("before-flight", overwrite=True) == path
    assert {o["id"] for o in json.loads(path.read_text())["scene"]["objects"]} == {"a", "b"}
    assert session.save("other") == session.folder / "other.json"  # a new name does not ask
    with pytest.raises(SessionError, match="holds the undo history"):
        session.save("history", overwrite=True)


def test_delete_asks_first_and_keeps_the_session_itself(session: Session) -> None:
    path = session.save("before-flight")
    with pytest.raises(ConfirmNeeded) as asked:
        session.delete_save("before-flight")
    assert asked.value.question == "Delete 'before-flight'?" and asked.value.confirm == "Delete"
    assert "cannot be undone" in asked.value.detail and path.exists()
    assert session.delete_save("before-flight", confirmed=True) == "before-flight.json"
    assert not path.exists() and "before-flight.json" not in session.list_saves()
    with pytest.raises(SessionError, match="no saved session 'before-flight.json'"):
        session.delete_save("before-flight", confirmed=True)
    session.save()  # session.json
    with pytest.raises(SessionError, match="is the session itself"):
        session.delete_save("session", confirmed=True)
    (session.folder / "room.json").write_text(json.dumps({"version": 1, "objects": []}))  # a scene file
    with pytest.raises(SessionError, match="room.json") as refused:
        session.delete_save("room", confirmed=True)
    assert "not deleted" not in str(refused.value) and (session.folder / "room.json").exists()
    assert HISTORY_FILE not in session.list_saves()


# --- Redo, and the history across a restart -----------------------------------------------------------
def test_redo_puts_back_what_undo_took_and_a_new_edit_clears_it(session: Session) -> None:
    session.spawn(Scene(objects=(_box("a", 1.0, 2.0), _box("b", 3.0, 2.0))), origin="file room.json")
    session.move_object("a", (1.5, 2.5, 0.3))
    assert session.redo_label is None
    with pytest.raises(SessionError, match="nothing to redo"):
        session.redo_edit()
    assert session.undo_edit() == "undone: move a"
    assert session.scene.object("a").position == pytest.approx((1.0, 2.0, 0.3))
    assert session.redo_label == "move a" and session.undo_label == "spawn from file room.json"
    assert session.redo_edit() == "redone: move a"
    assert session.scene.object("a").position == pytest.approx((1.5, 2.5, 0.3))
    assert session.redo_label is None and session.undo_label == "move a"
    session.undo_edit()
    session.undo_edit()  # back to the empty map: two steps to redo
    assert session.scene.objects == () and session.redo_label == "spawn from file room.json"
    session.redo_edit()
    assert {o.id for o in session.scene.objects} == {"a", "b"} and session.redo_label == "move a"
    session.delete_object("b")  # a new edit: the undone move cannot come back any more
    assert session.redo_label is None
    with pytest.raises(SessionError, match="nothing to redo"):
        session.redo_edit()
    session.set_run(RunStatus("paused", 0, 0.5))
    with pytest.raises(SessionError, match="mission is under way"):
        session.undo_edit()


def test_undo_and_redo_survive_a_restart_with_the_capture_shown(tmp_path: Path) -> None:
    first = Session(tmp_path / "s", start=START)
    first.set_capture(_capture("cap-0001", 40))
    first.spawn(Scene(objects=(_box("a", 1.0, 2.0),)), origin="capture cap-0001")
    first.set_capture(_capture("cap-0002", 200))
    first.spawn(Scene(objects=(_box("b", 3.0, 2.0),)), origin="capture cap-0002")
    first.move_object("a", (1.5, 2.5, 0.3))
    assert first.undo_edit() == "undone: move a"
    assert (first.folder / HISTORY_FILE).exists()

    again = Session(tmp_path / "s", start=START)  # the console restarted
    assert again.restore_last() is not None and again.restore_problems == ()
    assert again.undo_label == "capture cap-0002" and again.redo_label == "move a"
    assert again.redo_edit() == "redone: move a"
    assert again.scene.object("a").position == pytest.approx((1.5, 2.5, 0.3))
    again.undo_edit()
    assert again.undo_edit() == "undone: capture cap-0002"  # the photo before it is shown again, from its files
    assert {o.id for o in again.scene.objects} == {"a"}
    assert again.capture is not None and again.capture.id == "cap-0001" and int(again.capture.image.mean()) == 40
    assert again.undo_edit() == "undone: capture cap-0001"
    assert again.scene.objects == () and again.capture is None
    assert again.redo_edit() == "redone: capture cap-0001" and again.capture.id == "cap-0001"  # type: ignore[union-attr]


def test_the_saved_history_is_bounded_and_a_bad_file_starts_it_empty_with_the_reason(tmp_path: Path) -> None:
    s = Session(tmp_path / "s", start=START)
    s.spawn(Scene(objects=(_box("a", 1.0, 2.0),)))
    for i in range(HISTORY_DEPTH + 5):
        s.move_object("a", (1.0 + 0.05 * (i % 7), 2.0, 0.3))
    saved = json.loads((s.folder / HISTORY_FILE).read_text())
    assert len(saved["undo"]) == HISTORY_DEPTH and saved["redo"] == []
    assert saved["known_spaces"] == {}  # no capture: no known space in any state
    (s.folder / HISTORY_FILE).write_text('{"kind": "morphonavi-history", "version": 1, "undo": [{"label": "x"}], "redo": []}')
    again = Session(tmp_path / "s", start=START)
    again.restore_last()
    assert again.undo_label is None and any("undo[0].state: is required" in p for p in again.restore_problems)
    assert len(again.scene.objects) == 1  # the map itself is restored
    (s.folder / HISTORY_FILE).write_text("not json")
    third = Session(tmp_path / "s", start=START)
    third.restore_last()
    assert third.undo_label is None and any("could not be read" in p for p in third.restore_problems)


# --- capture ids ----------------------------------------------------------------------------------------
def test_capture_ids_continue_after_a_restart(tmp_path: Path) -> None:
    s = Session(tmp_path / "s", start=START)
    assert s.next_capture_id("render-0001", "sim-render") == "cap-0001"
    s.set_capture(_capture("cap-0001"))
    assert s.next_capture_id("camera", "mavlink") == "cap-0002"
    s.set_capture(_capture("cap-0002"))
    again = Session(tmp_path / "s", start=START)
    again.restore_last()
    assert again.next_capture_id("render-0001", "sim-render") == "cap-0003"  # the simulator's counter restarted
    assert again.next_capture_id("IMG 0412.jpg", "captures-folder") == "cap-0004-IMG_0412"
    assert highest_capture_number(tmp_path / "s", ["cap-0123-x", "cap-render-0001-ab12"]) == 123
    with pytest.raises(ValueError, match="capture number"):
        numbered_capture_id(0)


def test_a_mapped_capture_after_a_restart_gets_a_new_id(tmp_path: Path) -> None:
    from console.link.sim import SimConfig, SimRobot
    from console.session.mapping_job import GROUND_TRUTH_LABEL, MapperPerceiver, MappingJob, ground_truth_bundle_for

    ids = []
    for _ in range(2):  # the console twice on the same folder; the simulator's renders restart at 0001
        s = Session(tmp_path / "s", start=START)
        s.restore_last()
        robot = SimRobot(config=SimConfig(time_scale=4.0))
        robot.connect()
        try:
            job = MappingJob(s, robot.capture, MapperPerceiver(GROUND_TRUTH_LABEL, ground_truth_bundle_for))
            assert job.run(), s.job.error
        finally:
            robot.close()
        ids.append(s.capture.id)  # type: ignore[union-attr]
    assert ids == ["cap-0001", "cap-0002"]
    saved = json.loads((tmp_path / "s" / HISTORY_FILE).read_text())
    assert len(saved["known_spaces"]) == 1  # the state before the second capture: the first one's known space
    assert s.known_space is not None and s.undo_edit() == "undone: capture cap-0002"
    assert s.capture.id == "cap-0001" and s.known_space is not None  # type: ignore[union-attr]  # from the file
    assert s.undo_edit() == "undone: capture cap-0001" and s.known_space is None and s.scene.objects == ()
    assert s.redo_edit() == "redone: capture cap-0001" and s.known_space is not None


# --- the route start follows the robot during every run ---------------------------------------------------
def _hover(x: float, y: float, z: float, mode: str = "holding") -> RobotSnapshot:
    return RobotSnapshot(Pose.from_xyz_yaw(x, y, z), mode=mode, armed=True, landed=False)


@pytest.mark.parametrize("state", ["running", "paused", "failsafe"])
def test_the_route_start_follows_the_robot_while_a_run_is_under_way(session: Session, state: str) -> None:
    routes = []
    session.subscribe(lambda t, _p: routes.append(t) if t == ROUTE else None)
    session.set_robot(_hover(2.5, 3.0, 1.5))
    assert session.route_snapshot().start == pytest.approx((2.5, 3.0, 1.5))  # at rest: the route's own start
    session.set_run(RunStatus(state, 0, 0.2))
    session.set_robot(_hover(2.0, 2.0, 1.2, mode="flying"))
    assert session.route_snapshot().start == pytest.approx((2.0, 2.0, 1.2))
    n = len(routes)
    session.set_robot(_hover(2.0 + RUN_START_STEP / 2, 2.0, 1.2, mode="flying"))  # less than a step: no redraw
    assert len(routes) == n and session.route_snapshot().start == pytest.approx((2.0, 2.0, 1.2))
    session.set_robot(_hover(1.0, 1.5, 0.0, mode="landing"))
    assert session.route_snapshot().start == pytest.approx((1.0, 1.5, 0.0)) and len(routes) == n + 1
    session.set_run(RunStatus("aborted", 0, 0.5))
    assert session.route_snapshot().start == pytest.approx((2.5, 3.0, 1.5))  # the route's own (re-planned at rest)


def test_a_paused_return_shows_the_route_start_at_the_robot(tmp_path: Path) -> None:
    stack = Stack(tmp_path / "s", _boxes())
    try:
        s = stack.session
        stack.plan((2.5, 5.7, 0.0))
        stack.runner.execute(s.build_mission())
        wait_for(lambda: stack.pos[1] > 4.6 and stack.pos[2] > 1.0, what="flying over the line of boxes")
        stack.runner.abort()
        wait_for(lambda: s.run.state == "aborted" and s.operator_state().commands["return"].enabled, what="hovering")
        hover = stack.pos
        wait_for(lambda: math.dist(s.route_snapshot().start, hover) < 0.05, what="route start at the hover point")
        stack.commands.run("return")
        wait_for(lambda: s.run.state == "running" and math.dist(stack.pos, hover) > 0.6, what="the return under way")
        stack.runner.pause()
        wait_for(lambda: s.run.state == "paused", what="paused")
        wait_for(lambda: s.robot is not None and s.robot.mode not in ("flying", "walking"), what="holding")
        here = stack.pos
        wait_for(lambda: math.dist(s.route_snapshot().start, here) <= RUN_START_STEP, what="route start at the robot")
        assert s.operator_state().running == "Return" and math.dist(here, hover) > 0.6
        assert math.dist(s.route_snapshot().start, hover) > 0.6 - RUN_START_STEP  # not the old hover point
    finally:
        stack.close()


# --- goals: top-view altitude clicks, zero-length goals ----------------------------------------------------
def test_a_top_view_altitude_click_lands_on_the_floor_point_under_the_cursor(session: Session) -> None:
    eye = (2.5, 3.9, 9.0)  # a top view above the room
    floor_point = np.array([1.0, 6.0, 0.0])
    ray = floor_point - eye
    assert looks_down(eye, (2.5, 4.0, 0.0)) and not looks_down((2.5, -3.0, 3.0), (2.5, 4.0, 0.0))
    session.set_goal_mode("altitude", 2.0)
    top = session.goal_from_ray(eye, ray, top_down=True)
    assert top == pytest.approx((1.0, 6.0, 2.0))
    side = session.goal_from_ray(eye, ray)  # from the side: where the ray meets the altitude layer
    assert side[2] == pytest.approx(2.0) and math.dist(side[:2], floor_point[:2]) > 0.5
    assert click_goal(eye, ray, 0.0, session.workspace, top_down=True) == pytest.approx((1.0, 6.0, 0.0))


def test_a_goal_at_the_robots_own_position_is_refused_with_the_reason(session: Session) -> None:
    res = session.add_goal((2.52, 0.7, 0.0))
    assert not res.ok and res.message.startswith("goal is where the robot already is (0.02 m)")
    assert session.route_snapshot().candidate is None
    with pytest.raises(SessionError, match="register at least one path segment"):
        session.build_mission()  # no 0 m mission
    above = session.add_goal((2.5, 0.7, 1.5))  # straight up is a take-off, not zero length
    assert above.ok, above.message
    session.discard()
    ok = session.add_goal((2.5, 2.0, 0.0))
    assert ok.ok and session.register()
    end = session.route_snapshot().goals[-1]
    again = session.add_goal(end)
    assert not again.ok and again.message.startswith("goal is where the route already ends (0.00 m)")
