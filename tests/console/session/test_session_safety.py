"""Edits never silently lose work (issue 8, item 9): implausible objects are refused naming the
field, oversized watched files are refused unread, parsing never holds the session lock, and
spawn / move / delete / capture / load can be undone, a lost registered segment being announced."""

from __future__ import annotations

import json
import os
import threading
import time
from pathlib import Path

import numpy as np
import pytest

from console.session.history import History, SceneState
from console.session.scene_watch import SceneWatcher, objects_to_world
from console.session.session import NOTICE, CaptureRecord, Detection, RunStatus, Session, SessionError
from pipeline.camera.geometry import Intrinsics, Pose
from pipeline.scene import Scene, SceneError, SceneObject, check_plausible

START = (2.5, 0.7, 0.0)


def _boxes(y: float = 4.0) -> Scene:
    """The paper's obstacle line across the room (world frame), 1.2 m high."""
    return Scene(objects=tuple(SceneObject(f"box-{n}", "cardboard_box", (0.25 + 0.5 * n, y, 0.6), (0.5, 1.2, 0.5))
                               for n in range(10)))


def _scene_file(path: Path, objects: list[dict], age: float = 2.0) -> None:
    path.write_text(json.dumps({"version": 1, "objects": objects}))
    t = time.time() - age
    os.utime(path, (t, t))


def _obj(oid: str, position: list[float], size: list[float]) -> dict:
    return {"id": oid, "label": "cardboard_box", "position": position, "size": size}


class _Notices:
    def __init__(self, session: Session) -> None:
        self.items: list = []
        session.subscribe(lambda topic, payload: self.items.append(payload) if topic == NOTICE else None)

    def titled(self, title: str) -> list:
        return [n for n in self.items if n.title == title]


@pytest.fixture()
def planned(tmp_path: Path) -> Session:
    """A session with the box line, one registered segment flown over it and a built mission."""
    s = Session(tmp_path / "session", start=START)
    s.spawn(_boxes())
    assert s.add_goal((2.5, 6.0, 0.0)).ok
    s.register()
    s.build_mission()
    return s


def _watch(session: Session, folder: Path, errors: list[str], **kw) -> SceneWatcher:
    """The console's wiring of the watched folder (console.app: spawn, or a notice naming the file)."""
    def on_scene(scene: Scene, name: str) -> None:
        session.spawn(objects_to_world(scene), origin=f"file {name}")

    def on_error(name: str, message: str) -> None:
        errors.append(f"{name}: {message}")
        session.notify("Scene file ignored", f"{name}: {message}", "error")

    return SceneWatcher(folder, on_scene, on_error, interval=0.05, settle=0.0, **kw)


# --- plausibility ------------------------------------------------------------------------------


def test_plausibility_names_the_field_and_the_limit() -> None:
    huge = Scene(objects=(SceneObject("a", "box", (1, 1, 0.5), (1e9, 1e9, 1e9)),))
    with pytest.raises(SceneError, match=r"^objects\[0\]\.size\[0\]: 1e\+09 m is implausible \(max 50 m\)"):
        check_plausible(huge)
    with pytest.raises(SceneError, match=r"objects\[0\]\.size\[0\].*max 9\.9 m, the workspace diagonal"):
        check_plausible(huge, (0, 0, 0), (5, 8, 3))
    far = Scene(objects=(SceneObject("a", "box", (1, 1, 0.5), (1, 1, 1)), SceneObject("b", "box", (1, 400, 0.5), (1, 1, 1))))
    with pytest.raises(SceneError, match=r"objects\[1\]\.position\[1\]: 400 m is far outside the workspace"):
        check_plausible(far, (0, 0, 0), (5, 8, 3))
    check_plausible(_boxes(), (0, 0, 0), (5, 8, 3))  # a real room passes
    # a wall of the room's full length and an object just past the walls are still plausible
    check_plausible(Scene(objects=(SceneObject("wall", "wall", (2.5, 8.2, 1.5), (0.2, 3.0, 8.0)),)), (0, 0, 0), (5, 8, 3))


def test_watched_file_with_a_1e9_m_object_is_refused_and_changes_nothing(planned: Session, tmp_path: Path) -> None:
    s = planned
    notices = _Notices(s)
    on_disk = (s.folder / "session.json").read_bytes()
    counts, objects, mission = s.grid.counts(), s.scene.objects, s.mission
    registered = [seg.copy() for seg in s.route_snapshot().registered]
    errors: list[str] = []
    scenes = tmp_path / "scenes"
    scenes.mkdir()
    _scene_file(scenes / "huge.json", [_obj("huge", [2.5, 4.0, 0.5], [1e9, 1e9, 1e9])])
    assert _watch(s, scenes, errors).poll() == ["huge.json"]

    assert len(errors) == 1 and "objects[0].size[0]" in errors[0] and "implausible" in errors[0]
    assert [n.level for n in notices.titled("Scene file ignored")] == ["error"]
    assert not notices.titled("Route segments removed")
    assert s.scene.objects == objects and s.grid.counts() == counts  # no grid fill
    assert s.mission is mission
    got = s.route_snapshot().registered
    assert len(got) == len(registered) and all(np.array_equal(a, b) for a, b in zip(got, registered))
    assert (s.folder / "session.json").read_bytes() == on_disk  # nothing autosaved
    assert s.undo_label == "spawn"  # the refused file left no undo step either (the last is the fixture's)


def test_watched_file_far_outside_the_workspace_is_refused(planned: Session, tmp_path: Path) -> None:
    errors: list[str] = []
    scenes = tmp_path / "scenes"
    scenes.mkdir()
    _scene_file(scenes / "far.json", [_obj("ok", [1.0, 1.0, 0.5], [1, 1, 1]), _obj("far", [1.0, 1.0, -300.0], [1, 1, 1])])
    _watch(planned, scenes, errors).poll()
    assert len(errors) == 1 and "objects[1].position[2]: -300 m is far outside the workspace" in errors[0]
    assert "ok" not in {o.id for o in planned.scene.objects}  # the whole file is refused


def test_spawn_and_typed_move_refuse_implausible_values(planned: Session) -> None:
    before = planned.scene
    with pytest.raises(SessionError, match=r"refused from capture c1: objects\[0\]\.size\[2\]: 80 m is implausible"):
        planned.spawn(Scene(objects=(SceneObject("x", "box", (1, 1, 0.5), (1, 1, 80)),)), origin="capture c1")
    with pytest.raises(SessionError, match="far outside the workspace"):
        planned.move_object("box-3", (1e6, 4.0, 0.6))
    assert planned.scene is before and planned.mission is not None


def test_oversized_watched_file_is_refused_unread_with_a_notice(planned: Session, tmp_path: Path) -> None:
    """The 58 MB / 330 000-object file of the issue: refused from its size, the session untouched."""
    scenes = tmp_path / "scenes"
    scenes.mkdir()
    one = json.dumps(_obj("box-000000", [2.0, 2.0, 0.5], [0.5, 0.5, 0.5]))
    with open(scenes / "big.json", "w") as fh:
        fh.write('{"version": 1, "objects": [')
        fh.write(",".join(one.replace("000000", f"{i:06d}") for i in range(330_000)))
        fh.write("]}")
    assert (scenes / "big.json").stat().st_size > 30e6
    t = time.time() - 2
    os.utime(scenes / "big.json", (t, t))
    notices = _Notices(planned)
    errors: list[str] = []
    before = planned.scene
    _watch(planned, scenes, errors).poll()
    assert len(errors) == 1 and "MB limit for a scene file: not read" in errors[0]
    assert notices.titled("Scene file ignored") and planned.scene is before and planned.mission is not None


def test_watched_file_with_too_many_objects_is_refused(planned: Session, tmp_path: Path) -> None:
    scenes = tmp_path / "scenes"
    scenes.mkdir()
    _scene_file(scenes / "many.json", [_obj(f"b{i}", [1.0, 1.0 + 0.01 * i, 0.5], [0.1, 0.1, 0.1]) for i in range(60)])
    errors: list[str] = []
    before = planned.scene
    _watch(planned, scenes, errors, max_objects=50).poll()
    assert errors == ["many.json: objects: 60 objects is over the limit of 50 for one scene file: nothing was added"]
    assert planned.scene is before


def test_watched_files_are_parsed_without_the_session_lock(planned: Session, tmp_path: Path) -> None:
    """While another thread holds the session's lock, the watcher still reads and checks a file."""
    scenes = tmp_path / "scenes"
    scenes.mkdir()
    _scene_file(scenes / "chair.json", [_obj("chair", [1.0, 2.0, 0.4], [0.5, 0.8, 0.5])])
    parsed = threading.Event()

    def on_scene(scene: Scene, name: str) -> None:
        parsed.set()  # the file was read and validated; only the spawn needs the lock
        planned.spawn(scene, origin=f"file {name}")

    watcher = SceneWatcher(scenes, on_scene, lambda n, m: None, settle=0.0)
    with planned._lock:
        worker = threading.Thread(target=watcher.poll, daemon=True)
        worker.start()
        assert parsed.wait(30.0)
        assert "chair" not in {o.id for o in planned.scene.objects}  # the spawn waits for the lock
    worker.join(30.0)
    assert "chair" in {o.id for o in planned.scene.objects}


# --- undo --------------------------------------------------------------------------------------


def test_undo_spawn_move_and_delete_in_reverse_order(tmp_path: Path) -> None:
    s = Session(tmp_path / "s", start=START)
    empty = s.grid.counts()
    with pytest.raises(SessionError, match="nothing to undo"):
        s.undo_edit()
    s.spawn(_boxes(), origin="file room.json")
    full = s.grid.counts()
    s.move_object("box-2", (1.25, 2.0, 0.6))
    s.delete_object("box-7")
    assert s.undo_label == "delete box-7"
    assert s.undo_edit() == "undone: delete box-7"
    assert "box-7" in {o.id for o in s.scene.objects}
    assert s.undo_edit() == "undone: move box-2"
    assert s.scene.object("box-2").position == (1.25, 4.0, 0.6) and s.grid.counts() == full
    assert s.undo_edit() == "undone: spawn from file room.json"
    assert s.scene.objects == () and s.grid.counts() == empty
    assert s.undo_label is None
    # the undone state is what is saved
    assert json.loads((s.folder / "session.json").read_text())["scene"]["objects"] == []


def test_a_change_that_removes_registered_segments_says_so_and_undo_brings_them_back(tmp_path: Path) -> None:
    s = Session(tmp_path / "s", start=START)
    assert s.add_goal((2.5, 3.0, 0.0)).ok
    s.register()
    assert s.add_goal((2.5, 6.0, 0.0)).ok
    s.register()
    mission = s.build_mission()
    before = [seg.copy() for seg in s.route_snapshot().registered]
    notices = _Notices(s)
    wall = Scene(objects=(SceneObject("wall", "wall", (2.5, 4.5, 1.5), (0.3, 3.0, 5.0)),))
    report = s.spawn(wall, origin="file wall.json")
    assert any("removed" in n for n in report.notes)
    lost = notices.titled("Route segments removed")
    assert len(lost) == 1 and lost[0].level == "warning"
    assert "spawn from file wall.json: registered segment 2 (to (2.62, 6.12, 0.00))" in lost[0].body
    assert "the mission was retired" in lost[0].body and "Undo" in lost[0].body
    assert len(s.route_snapshot().registered) == 1 and s.mission is None

    assert s.undo_edit() == "undone: spawn from file wall.json"
    got = s.route_snapshot().registered
    assert len(got) == 2 and all(np.array_equal(a, b) for a, b in zip(got, before))
    assert s.mission is mission and s.scene.objects == ()


def _capture(cap_id: str) -> CaptureRecord:
    return CaptureRecord(
        id=cap_id, image=np.zeros((24, 32, 3), np.uint8), intrinsics=Intrinsics(30.0, 30.0, 16.0, 12.0, 32, 24),
        camera_pose=Pose((2.5, 0.8, 0.35), (0.0, 0.0, 0.0, 1.0)), robot_pose=Pose.from_xyz_yaw(2.5, 0.7, 0.0),
        detections=(Detection("cardboard_box", 0.9, (1.0, 1.0, 9.0, 9.0), "box-0"),), depth=None,
        backend="test", timings={},
    )


def test_undo_a_capture_removes_its_objects_and_brings_back_the_previous_photo(tmp_path: Path) -> None:
    """A capture is one undo step: the photo shown and the objects it spawned (as the mapping job does it)."""
    s = Session(tmp_path / "s", start=START)
    s.set_capture(_capture("cap-1"))
    s.spawn(Scene(objects=_boxes().objects[:3]), origin="capture cap-1")
    s.set_capture(_capture("cap-2"))
    s.spawn(Scene(objects=_boxes().objects[3:6]), origin="capture cap-2")
    assert s.undo_label == "capture cap-2" and len(s.scene.objects) == 6
    assert s.undo_edit() == "undone: capture cap-2"
    assert [o.id for o in s.scene.objects] == ["box-0", "box-1", "box-2"]
    assert s.capture is not None and s.capture.id == "cap-1"
    assert json.loads((s.folder / "session.json").read_text())["last_capture"]["id"] == "cap-1"
    assert s.undo_edit() == "undone: capture cap-1"
    assert s.scene.objects == () and s.capture is None


def test_undo_of_a_load_and_refusal_while_a_mission_runs(planned: Session) -> None:
    planned.save("room")
    planned.delete_object("box-1")
    planned.load("room")
    assert "box-1" in {o.id for o in planned.scene.objects}
    assert planned.undo_edit() == "undone: load room.json"
    assert "box-1" not in {o.id for o in planned.scene.objects}
    planned.set_run(RunStatus(state="running"))
    with pytest.raises(SessionError, match="mission is under way"):
        planned.undo_edit()
    assert "box-1" not in {o.id for o in planned.scene.objects}


def test_history_is_bounded_and_a_capture_with_its_spawn_is_one_step() -> None:
    h = History(depth=3)
    state = SceneState("x", Scene(), None, {}, None, None, None)  # type: ignore[arg-type]
    for i in range(5):
        assert h.push(SceneState(f"e{i}", state.scene, None, {}, None, None, None))  # type: ignore[arg-type]
    assert len(h) == 3 and h.peek().label == "e4"  # type: ignore[union-attr]
    assert h.push(SceneState("capture c", Scene(), None, {}, None, None, None, key="capture:c"))  # type: ignore[arg-type]
    assert not h.push(SceneState("spawn", Scene(), None, {}, None, None, None, key="capture:c"))  # type: ignore[arg-type]
    assert [h.pop().label for _ in range(3)] == ["capture c", "e4", "e3"]  # type: ignore[union-attr]
    assert h.pop() is None
    with pytest.raises(ValueError):
        History(depth=0)


def test_a_capture_with_an_implausible_object_is_refused_before_anything_changes(planned: Session) -> None:
    from console.link.base import CaptureResult
    from console.session.mapping_job import MappingJob, Perception
    from pipeline.camera.geometry import CameraMount, camera_pose_in_world

    class Huge:
        label = "huge"

        def perceive(self, shot, capture_id, progress):  # type: ignore[no-untyped-def]
            scene = Scene(objects=(SceneObject("wall", "wall", (2.5, 2.0, 1.0), (0.2, 2.0, 900.0)),))
            return Perception(scene, (), None, {})

    def shot() -> CaptureResult:
        robot = Pose.from_xyz_yaw(*START)
        return CaptureResult(np.zeros((24, 32, 3), np.uint8), Intrinsics(30.0, 30.0, 16.0, 12.0, 32, 24),
                             camera_pose_in_world(robot, CameraMount()), robot)

    notices = _Notices(planned)
    before = planned.scene
    assert MappingJob(planned, shot, Huge()).run() is False
    err = planned.job.error or ""
    assert "refused" in err and "objects[0].size[2]: 900 m is implausible" in err and "internal error" not in err
    assert notices.titled("Capture & map failed")
    assert planned.scene is before and planned.capture is None and planned.mission is not None


def test_the_undo_button_names_the_step_and_undoes_it(tmp_path: Path) -> None:
    import viser

    from console.views.objects_view import ObjectsView
    from console.views.redo_view import RedoView

    server = viser.ViserServer(host="127.0.0.1", port=0, verbose=False)
    try:
        s = Session(tmp_path / "s", start=START)
        view = ObjectsView(server, s)
        keys = RedoView(server, s, view._undo)  # owns the Undo button's label, state and click
        assert view._undo.disabled
        s.spawn(_boxes(), origin="file room.json")
        s.delete_object("box-4")
        assert not view._undo.disabled and view._undo.label == "Undo delete box-4"

        told: list[str] = []

        class Tab:
            def add_notification(self, title: str, body: str, **_kw: object) -> None:
                told.append(f"{title}: {body}")

        class Click:
            client = Tab()

        keys.undo(Click().client)
        assert "box-4" in {o.id for o in s.scene.objects} and view._undo.label == "Undo spawn from file room.json"
        keys.undo(Click().client)
        assert s.scene.objects == () and view._undo.disabled and view.drawn_ids() == []
        keys.undo(Click().client)  # nothing left: refused and said to the tab
        assert s.scene.objects == ()
        assert told == ["Undone: delete box-4", "Undone: spawn from file room.json",
                        "Cannot undo: nothing to undo: no map edit left in the history (the last 20 are kept)"]
    finally:
        server.stop()
