"""The console's state logic without a browser: goals, candidate, register, mission, the map,
persistence and path sanitising, and the mapping job (the watched scene folder: test_scene_watch.py)."""

from __future__ import annotations

import json
import math
import os
import threading
from pathlib import Path

import numpy as np
import pytest

from console.link.base import CaptureResult
from console.session.mapping_job import MappingJob, Perception
from console.session.session import (
    GRID, NOTICE, ROUTE, SCENE, CaptureRecord, Detection, RobotSnapshot, Session, SessionError,
    merge_observations, ray_plane,
)
from pipeline.camera.geometry import CameraMount, Intrinsics, Pose, camera_pose_in_world
from pipeline.scene import Capture, Scene, SceneObject, Source
from planner.grid import CellState, Closed

START = (2.5, 0.7, 0.0)


def _line_of_boxes(y: float = 4.0, gap: bool = False) -> Scene:
    """The paper's obstacle line across the room (world frame), 1.2 m high."""
    objs, x, n = [], 0.0, 0
    end = 4.0 if gap else 5.0
    while x < end - 1e-9:
        objs.append(SceneObject(f"box-{n}", "cardboard_box", (x + 0.25, y, 0.6), (0.5, 1.2, 0.5)))
        x += 0.5
        n += 1
    return Scene(objects=tuple(objs))


@pytest.fixture()
def session(tmp_path: Path) -> Session:
    return Session(tmp_path / "session", start=START)


# --- picking -------------------------------------------------------------------------------------


def test_ray_plane_hits_floor_and_refuses_parallel_or_backward_rays() -> None:
    p = ray_plane((1.0, 2.0, 3.0), (0.0, 0.6, -0.8), 0.0)
    assert p == pytest.approx((1.0, 4.25, 0.0))
    assert ray_plane((1.0, 2.0, 3.0), (0.0, 1.0, 0.0), 0.0) is None  # parallel
    assert ray_plane((1.0, 2.0, 3.0), (0.0, 0.0, 1.0), 0.0) is None  # pointing away
    assert ray_plane((1.0, 2.0, 3.0), (0.0, 0.0, -1.0), 1.5) == pytest.approx((1.0, 2.0, 1.5))


def test_goal_from_ray_uses_goal_mode_and_rejects_clicks_outside(session: Session) -> None:
    g = session.goal_from_ray((2.0, -1.0, 5.0), (0.0, 0.6, -0.8))
    assert g == pytest.approx((2.0, 2.75, 0.0))
    session.set_goal_mode("altitude", 2.0)
    g = session.goal_from_ray((2.0, -1.0, 5.0), (0.0, 0.6, -0.8))
    assert g == pytest.approx((2.0, 1.25, 2.0))  # the ray meets the 2 m layer earlier
    with pytest.raises(SessionError, match="outside the workspace"):
        session.goal_from_ray((20.0, 20.0, 5.0), (0.0, 0.0, -1.0))
    with pytest.raises(SessionError, match="does not hit"):
        session.goal_from_ray((2.0, 2.0, 5.0), (0.0, 1.0, 0.0))
    with pytest.raises(SessionError, match="altitude must be between"):
        session.set_goal_mode("altitude", 7.0)
    with pytest.raises(SessionError, match="goal mode"):
        session.set_goal_mode("underground")


# --- goal -> candidate -> register -> mission ------------------------------------------------------


def test_fresh_session_is_unmapped_with_all_free_grid(session: Session) -> None:
    assert session.scene.objects == ()
    c = session.grid.counts()
    # free but for the band along the workspace's edge the robot keeps its size from (closed: EDGE)
    assert c["occupied"] == int(np.count_nonzero(session.grid.reason == Closed.EDGE)) > 0
    assert c["dangerous"] == 0 and c["free"] == 18 * 30 * 10
    r = session.route_snapshot()
    assert r.start == pytest.approx(START) and r.candidate is None and r.registered == ()


def test_goal_candidate_register_mission_flow(session: Session) -> None:
    events: list[str] = []
    session.subscribe(lambda topic, _p: events.append(topic))
    res = session.add_goal((2.5, 3.0, 0.0))
    assert res.ok, res.message
    assert ROUTE in events
    r = session.route_snapshot()
    assert r.candidate is not None and r.candidate[0] == pytest.approx((2.625, 0.625, 0.0))
    assert r.candidate[-1][:2] == pytest.approx((2.625, 3.125))
    assert session.register().startswith("segment 1 registered")
    r = session.route_snapshot()
    assert r.candidate is None and len(r.registered) == 1
    # the next candidate starts at the last registered node
    assert session.add_goal((4.0, 3.0, 0.0)).ok
    r = session.route_snapshot()
    assert r.candidate[0] == pytest.approx(r.registered[0][-1])
    session.register()
    mission = session.build_mission()
    assert mission.kinds() == ["walk"]
    assert mission.segments[0].end[:2] == pytest.approx((4.125, 3.125))
    assert session.mission is mission
    assert session.undo() == "last segment removed, 1 left"
    assert session.mission is None  # the path changed: the mission is stale
    session.clear_route()
    assert session.route_snapshot().registered == ()


def test_register_and_build_without_path_are_refused(session: Session) -> None:
    with pytest.raises(SessionError, match="no candidate"):
        session.register()
    with pytest.raises(SessionError, match="register at least one"):
        session.build_mission()
    with pytest.raises(SessionError, match="nothing to undo"):
        session.undo()


def test_unreachable_goals_say_why_and_keep_the_route(session: Session) -> None:
    session.spawn(_line_of_boxes())
    assert session.add_goal((2.5, 2.0, 0.0)).ok
    before = session.route_snapshot().candidate.copy()
    res = session.add_goal((2.6, 4.0, 0.6))
    assert not res.ok and "inside an obstacle" in res.message and "box-" in res.message
    res = session.add_goal((9.0, 1.0, 0.0))
    assert not res.ok and "outside the workspace" in res.message
    res = session.add_goal((float("nan"), 1.0, 0.0))
    assert not res.ok and "finite" in res.message
    np.testing.assert_allclose(session.route_snapshot().candidate, before)


def test_paper_room_line_forces_flight_over_the_boxes(session: Session) -> None:
    rep = session.spawn(_line_of_boxes(), origin="test")
    assert len(rep.added) == 10
    c = session.grid.counts()
    assert c["occupied"] > 0 and c["dangerous"] > 0
    assert session.add_goal((2.5, 5.7, 0.0)).ok
    session.register()
    assert session.build_mission().kinds() == ["walk", "takeoff", "fly", "land", "walk"]


def test_spawn_replans_the_candidate_around_new_objects(session: Session) -> None:
    assert session.add_goal((2.5, 6.0, 0.0)).ok
    straight = session.route_snapshot().candidate
    assert np.all(straight[:, 2] == 0.0)  # walking on an empty floor
    rep = session.spawn(_line_of_boxes())
    assert "candidate replanned" in rep.notes
    replanned = session.route_snapshot().candidate
    assert replanned[:, 2].max() > 1.2  # now it flies over the line


def test_spawn_drops_registered_segments_that_cross_new_obstacles(session: Session) -> None:
    assert session.add_goal((2.5, 6.0, 0.0)).ok
    session.register()
    rep = session.spawn(_line_of_boxes())
    assert any("crosses obstacles and was removed" in n for n in rep.notes)
    assert session.route_snapshot().registered == ()


# --- the map ------------------------------------------------------------------------------------------


def test_merge_updates_resightings_and_adds_new_objects() -> None:
    base = Scene(objects=(
        SceneObject("chair-1", "office_chair", (1.0, 2.0, 0.5), (0.6, 1.0, 0.6), source=Source("c1", "fused")),
        SceneObject("desk-1", "desk", (3.0, 2.0, 0.4), (0.7, 0.75, 1.4), source=Source(None, "manual")),
    ))
    seen = Scene(objects=(
        SceneObject("a", "office_chair", (1.2, 2.1, 0.5), (0.6, 1.0, 0.6), source=Source("c2", "fused")),
        SceneObject("b", "desk", (3.1, 2.0, 0.4), (0.7, 0.75, 1.4), source=Source("c2", "fused")),
        SceneObject("c", "office_chair", (4.0, 7.0, 0.5), (0.6, 1.0, 0.6), source=Source("c2", "fused")),
    ), captures=(Capture("c2"),))
    merged, added, updated = merge_observations(base, seen)
    assert updated == ["chair-1"]
    # two equally good views (no camera known): the map holds their mean (pipeline.mapping.map_fusion)
    assert merged.object("chair-1").position == pytest.approx((1.1, 2.05, 0.5))
    assert merged.object("desk-1").position == (3.0, 2.0, 0.4)  # manual placement is kept
    assert sorted(added) == ["c"]  # the desk seen again is recorded on the pinned desk, not duplicated
    assert [(h.capture, h.used) for h in merged.object("desk-1").history][-1] == ("c2", False)
    assert [c.id for c in merged.captures] == ["c2"]


def test_delete_and_move_rebuild_the_grid(session: Session) -> None:
    session.spawn(Scene(objects=(SceneObject("cab", "office_cabinet", (1.0, 6.0, 0.9), (0.8, 1.8, 0.4)),)))
    ws = session.workspace
    assert session.grid.state_at(ws.cell_of((1.0, 6.0, 0.1))) is CellState.OCCUPIED
    session.move_object("cab", (4.0, 6.0, 0.9), math.pi / 2)
    assert session.grid.state_at(ws.cell_of((1.0, 6.0, 0.1))) is CellState.FREE
    assert session.grid.state_at(ws.cell_of((4.0, 6.0, 0.1))) is CellState.OCCUPIED
    moved = session.scene.object("cab")
    assert moved.yaw == pytest.approx(math.pi / 2) and moved.source.method == "manual"
    with pytest.raises(SessionError, match="far outside"):
        session.move_object("cab", (40.0, 6.0, 0.9))
    session.select("cab")
    assert session.selected is not None
    session.delete_object("cab")
    assert session.scene.objects == () and session.selected is None
    assert session.grid.counts()["occupied"] == int(np.count_nonzero(session.grid.reason == Closed.EDGE))
    with pytest.raises(SessionError, match="no object"):
        session.delete_object("cab")


def test_listeners_see_every_change_and_a_broken_listener_is_isolated(session: Session) -> None:
    seen: list[str] = []
    session.subscribe(lambda t, p: (_ for _ in ()).throw(RuntimeError("view bug")))
    unsubscribe = session.subscribe(lambda t, p: seen.append(t))
    session.spawn(_line_of_boxes())
    assert {SCENE, GRID, ROUTE} <= set(seen)
    session.notify("hello", "world")
    assert seen[-1] == NOTICE
    unsubscribe()
    session.discard()
    assert seen[-1] == NOTICE


def test_concurrent_operators_do_not_corrupt_the_route(session: Session) -> None:
    errors: list[BaseException] = []

    def operator(x: float) -> None:
        try:
            for _ in range(5):
                session.add_goal((x, 5.0, 0.0))
                try:
                    session.register()
                except SessionError:
                    pass  # the other operator registered it first
        except BaseException as exc:  # pragma: no cover - reported below
            errors.append(exc)

    threads = [threading.Thread(target=operator, args=(x,)) for x in (1.0, 4.0)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert not errors
    segs = session.route_snapshot().registered
    for a, b in zip(segs, segs[1:]):  # every segment starts where the previous one ended
        assert b[0] == pytest.approx(a[-1])


def test_route_start_follows_the_robot_until_a_path_is_registered(session: Session) -> None:
    session.set_robot(RobotSnapshot(Pose.from_xyz_yaw(1.0, 1.0, 0.0, 0.3)))
    assert session.route_snapshot().start == pytest.approx((1.0, 1.0, 0.0))
    assert session.add_goal((1.0, 3.0, 0.0)).ok
    session.register()
    session.set_robot(RobotSnapshot(Pose.from_xyz_yaw(3.0, 1.0, 0.0)))
    assert session.route_snapshot().start == pytest.approx((1.0, 1.0, 0.0))
    session.set_robot(RobotSnapshot(Pose.from_xyz_yaw(3.0, 1.0, 1.5)))  # hovering: the start is its air cell
    session.clear_route()
    assert session.route_snapshot().start == pytest.approx((3.0, 1.0, 1.5))


# --- persistence and path sanitising ---------------------------------------------------------------


def _capture_record() -> CaptureRecord:
    img = np.zeros((48, 64, 3), np.uint8)
    img[10:20, 10:30] = (200, 50, 50)
    depth = np.full((48, 64), 3.25, np.float32)
    return CaptureRecord(
        id="cap-1", image=img, intrinsics=Intrinsics(50.0, 50.0, 32.0, 24.0, 64, 48),
        camera_pose=Pose((2.5, 0.8, 0.35), (0.0, 0.0, 0.0, 1.0)), robot_pose=Pose.from_xyz_yaw(2.5, 0.7, 0.0),
        detections=(Detection("office_chair", 0.9, (10.0, 10.0, 30.0, 20.0), "chair-1"),), depth=depth,
        backend="test backend", timings={"total": 0.5},
    )


def test_restart_restores_scene_route_mission_settings_and_capture(tmp_path: Path) -> None:
    folder = tmp_path / "s"
    a = Session(folder, start=START)
    a.spawn(_line_of_boxes())
    a.set_goal_mode("altitude", 2.0)
    a.set_goal_mode("ground")
    assert a.add_goal((2.5, 5.7, 0.0)).ok
    a.register()
    assert a.add_goal((1.0, 6.5, 0.0)).ok  # a pending candidate is replanned on restore
    mission = a.build_mission()
    a.set_capture(_capture_record())
    assert (folder / "session.json").exists()

    b = Session(folder, start=(0.5, 0.5, 0.0))
    notes = b.restore_last()
    assert notes is not None
    assert [o.id for o in b.scene.objects] == [o.id for o in a.scene.objects]
    assert b.grid.counts() == a.grid.counts()
    rb = b.route_snapshot()
    assert len(rb.registered) == 1 and rb.start == pytest.approx(START)
    np.testing.assert_allclose(rb.registered[0], a.route_snapshot().registered[0])
    assert rb.candidate_goal == pytest.approx((1.0, 6.5, 0.0))
    assert b.mission is not None and b.mission.kinds() == mission.kinds()
    assert b.settings.altitude == 2.0 and b.settings.goal_mode == "ground"
    cap = b.capture
    assert cap is not None and cap.id == "cap-1" and cap.image.shape == (48, 64, 3)
    assert cap.detections[0].label == "office_chair" and cap.backend == "test backend"
    assert cap.depth is not None and np.nanmedian(cap.depth) == pytest.approx(3.25)


def test_named_save_and_load(session: Session) -> None:
    session.spawn(_line_of_boxes())
    path = session.save("before drop")
    assert path == session.folder / "before drop.json"
    session.delete_object("box-0")
    assert len(session.scene.objects) == 9
    session.load("before drop")
    assert len(session.scene.objects) == 10
    assert "before drop.json" in session.list_saves()
    with pytest.raises(SessionError, match="no saved session"):
        session.load("never saved")


@pytest.mark.parametrize("name", [
    "../outside", "../../etc/passwd", "/etc/passwd", "~/.bashrc", "a/../../b", "sub/../../x",
    "", "   ", "C:\\windows\\x", "bad\\name", "x\0y", "a" * 200, "..", ".", ".hidden", "sub/.session.json.tmp",
])
def test_names_typed_in_the_ui_cannot_escape_the_session_folder(session: Session, name: str) -> None:
    with pytest.raises(SessionError):
        session.resolve_name(name)
    with pytest.raises(SessionError):
        session.save(name)


def test_symlink_out_of_the_session_folder_is_refused(session: Session, tmp_path: Path) -> None:
    outside = tmp_path / "elsewhere"
    outside.mkdir()
    os.symlink(outside, session.folder / "link")
    with pytest.raises(SessionError, match="outside the session folder"):
        session.save("link/stolen")
    assert not (outside / "stolen.json").exists()
    assert session.resolve_name("runs/monday") == session.folder / "runs" / "monday.json"


def test_malformed_session_file_is_refused_and_state_kept(session: Session) -> None:
    session.spawn(_line_of_boxes())
    (session.folder / "broken.json").write_text("{not json")
    with pytest.raises(SessionError, match="not valid JSON"):
        session.load("broken")
    good = session.to_dict()
    good["scene"]["objects"][0]["size"][1] = -1.0
    (session.folder / "badfield.json").write_text(json.dumps(good))
    with pytest.raises(SessionError, match=r"scene\.objects\[0\]\.size\[1\]"):
        session.load("badfield")
    (session.folder / "other.json").write_text(json.dumps({"hello": 1}))
    with pytest.raises(SessionError, match="not a MorphoNavi session"):
        session.load("other")
    assert len(session.scene.objects) == 10


# --- the mapping job --------------------------------------------------------------------------------------


class _FakePerceiver:
    label = "fake boxes"

    def perceive(self, shot: CaptureResult, capture_id: str, progress) -> Perception:
        progress(0.5, "detecting")
        scene = _line_of_boxes()
        dets = tuple(Detection(o.label, 0.8, (1.0, 1.0, 5.0, 5.0), o.id) for o in scene.objects)
        return Perception(scene, dets, None, {"total": 0.01})  # no depth model: the boxes bound the rays


def _shot() -> CaptureResult:
    robot = Pose.from_xyz_yaw(*START)
    return CaptureResult(np.zeros((48, 64, 3), np.uint8), Intrinsics(50.0, 50.0, 32.0, 24.0, 64, 48),
                         camera_pose_in_world(robot, CameraMount()), robot)


def test_mapping_job_spawns_objects_and_reports_progress(session: Session) -> None:
    jobs, notices = [], []
    session.subscribe(lambda t, p: jobs.append(p) if t == "job" else notices.append(p) if t == NOTICE else None)
    assert session.add_goal((2.5, 5.7, 0.0)).ok
    job = MappingJob(session, _shot, _FakePerceiver())
    assert job.start()
    assert job.wait(10.0)
    assert len(session.scene.objects) == 10
    assert session.capture is not None and session.capture.backend == "fake boxes"
    assert len(session.capture.detections) == 10
    fractions = [j.fraction for j in jobs]
    assert fractions == sorted(fractions) and jobs[-1].fraction == 1.0 and not jobs[-1].running
    assert any("detecting" in j.message for j in jobs)
    # the goal behind the new line is floor no capture has seen (the line hides it): the candidate is
    # dropped, and the operator is told why and where to look from
    assert session.route_snapshot().candidate is None
    assert any(n.title == "Route" and "candidate dropped" in n.body and "not seen yet" in n.body for n in notices)


def test_mapping_job_failure_is_reported_not_raised(session: Session) -> None:
    notices = []
    session.subscribe(lambda t, p: notices.append(p) if t == NOTICE else None)

    def broken() -> CaptureResult:
        raise TimeoutError("no answer from the robot within 5 s")

    assert MappingJob(session, broken, _FakePerceiver()).run() is False
    assert session.job.error is not None and "no answer from the robot" in session.job.error
    assert notices[-1].level == "error"
    assert session.scene.objects == ()


def test_merge_keeps_stacked_boxes_and_ignores_ids_of_other_captures() -> None:
    """Regression: stacked boxes share x, y (match in 3D); every capture numbers ids from 1."""
    from pipeline.scene import Capture, Scene, SceneObject, Source

    from console.session.session import merge_observations

    def box(oid: str, cap: str, x: float, z: float, bbox=(100.0, 100.0, 200.0, 200.0)) -> SceneObject:
        return SceneObject(oid, "cardboard_box", (x, 4.0, z), (0.45, 0.4, 0.45),
                           source=Source(capture=cap, method="depth", bbox=bbox))

    cam = {"width": 640.0, "height": 480.0}
    first = Scene(objects=(box("cardboard_box-1", "c1", 1.0, 0.2), box("cardboard_box-2", "c1", 1.0, 0.6)),
                  captures=(Capture("c1", intrinsics=cam),))
    scene, added, _ = merge_observations(Scene(), first)
    assert len(added) == 2
    # the second photo sees only the top box, and calls it "cardboard_box-1"
    second = Scene(objects=(box("cardboard_box-1", "c2", 1.02, 0.62),), captures=(Capture("c2", intrinsics=cam),))
    scene, added, updated = merge_observations(scene, second)
    zs = sorted(o.position[2] for o in scene.objects)
    assert added == [] and len(scene.objects) == 2
    # the top box: the mean of its two views (0.61 m) puts its bottom 0.01 m above the box below (top at 0.40 m),
    # within the support tolerance: it is set on that box exactly
    assert zs[0] == pytest.approx(0.2) and zs[1] == pytest.approx(0.6)
    # a view cut by the image border does not replace an uncut one
    third = Scene(objects=(box("x", "c3", 1.3, 0.25, bbox=(0.0, 100.0, 50.0, 200.0)),),
                  captures=(Capture("c3", intrinsics=cam),))
    scene, _, updated = merge_observations(scene, third)
    assert len(scene.objects) == 2 and updated
    assert min(o.position[0] for o in scene.objects) == pytest.approx(1.0, abs=0.04)  # weighs 1/9


def test_merge_does_not_let_a_new_id_hit_an_object_replaced_in_the_same_merge() -> None:
    """Regression (sim loop): a re-sighting takes over an old object's id and capture; a later
    object of the same photo that happens to share that id must not overwrite it (the box would
    vanish from the map and the planner would walk into it)."""
    def box(oid: str, cap: str, x: float) -> SceneObject:
        return SceneObject(oid, "cardboard_box", (x, 4.0, 0.2), (0.45, 0.4, 0.45),
                           source=Source(capture=cap, method="depth"))

    first = Scene(objects=(box("cardboard_box-10", "c1", 2.5), box("cardboard_box-16", "c1", 3.4)),
                  captures=(Capture("c1"),))
    scene, _, _ = merge_observations(Scene(), first)
    # the second photo numbers the box at x = 2.5 "cardboard_box-3" and the one at x = 3.4
    # "cardboard_box-10"; both are re-sightings, in this order
    second = Scene(objects=(box("cardboard_box-3", "c2", 2.52), box("cardboard_box-10", "c2", 3.38)),
                   captures=(Capture("c2"),))
    scene, added, updated = merge_observations(scene, second)
    assert added == [] and sorted(updated) == ["cardboard_box-10", "cardboard_box-16"]
    xs = sorted(o.position[0] for o in scene.objects)
    assert xs == pytest.approx([2.51, 3.39])  # two equally good views each
    # loading the same file again still replaces by id (each object once)
    again, added, updated = merge_observations(scene, second)
    assert added == [] and len(again.objects) == 2
    assert sorted(o.position[0] for o in again.objects) == pytest.approx([2.51, 3.39])  # a capture counts once
