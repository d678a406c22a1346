"""The watched scene folder (console/session/scene_watch.py): each scene file spawned once per change, bad
files reported once, files the handler is not ready for retried, robot- and camera-frame objects
moved into the world frame."""

from __future__ import annotations

import math
import os
import time
from pathlib import Path

import pytest

from console.session.scene_watch import FrameError, NotReady, SceneWatcher, objects_to_world
from pipeline.camera.geometry import CameraMount, Pose, camera_pose_in_world
from pipeline.scene import Capture, Scene, SceneObject, Source, save_scene


def _line_of_boxes(y: float = 4.0) -> Scene:
    """The paper's obstacle line across the room (world frame), 1.2 m high."""
    objs, x, n = [], 0.0, 0
    while x < 5.0 - 1e-9:
        objs.append(SceneObject(f"box-{n}", "cardboard_box", (x + 0.25, y, 0.6), (0.5, 1.2, 0.5)))
        x += 0.5
        n += 1
    return Scene(objects=tuple(objs))


def _write_scene(path: Path, scene: Scene, age: float = 1.0) -> None:
    save_scene(scene, path)
    t = time.time() - age
    os.utime(path, (t, t))


def test_scene_folder_spawns_each_file_once_per_modification(tmp_path: Path) -> None:
    got: list[tuple[str, int]] = []
    errors: list[tuple[str, str]] = []
    w = SceneWatcher(tmp_path / "inbox", lambda s, n: got.append((n, len(s.objects))),
                     lambda n, e: errors.append((n, e)), settle=0.2)
    _write_scene(w.folder / "a.json", _line_of_boxes())
    (w.folder / "notes.txt").write_text("ignored")
    assert w.poll() == ["a.json"] and got == [("a.json", 10)]
    assert w.poll() == [] and len(got) == 1  # unchanged: not again
    _write_scene(w.folder / "a.json", Scene(objects=_line_of_boxes().objects[:3]), age=0.5)
    w.poll()
    assert got[-1] == ("a.json", 3)
    (w.folder / "bad.json").write_text('{"version": 1, "objects": [{"id": "x", "label": "box", '
                                       '"position": [1, 2], "size": [1, 1, 1]}]}')
    old = time.time() - 1
    os.utime(w.folder / "bad.json", (old, old))
    w.poll()
    assert errors and errors[0][0] == "bad.json" and "objects[0].position" in errors[0][1]
    w.poll()
    assert len(errors) == 1  # reported once, ignored until it changes
    # a file still being written (modified just now) waits for the next pass
    _write_scene(w.folder / "fresh.json", _line_of_boxes(), age=0.0)
    assert "fresh.json" not in w.poll()


def test_scene_folder_retries_a_file_its_handler_is_not_ready_for(tmp_path: Path) -> None:
    ready = {"robot": False}
    got: list[str] = []

    def on_scene(scene: Scene, name: str) -> None:
        if not ready["robot"]:
            raise NotReady
        got.append(name)

    w = SceneWatcher(tmp_path / "inbox", on_scene, lambda n, e: pytest.fail(e))
    _write_scene(w.folder / "robot_frame.json", _line_of_boxes())
    assert w.poll() == [] and got == []
    ready["robot"] = True
    assert w.poll() == ["robot_frame.json"] and got == ["robot_frame.json"]


def test_scene_folder_ignores_existing_files_when_asked(tmp_path: Path) -> None:
    folder = tmp_path / "inbox"
    folder.mkdir()
    _write_scene(folder / "old.json", _line_of_boxes())
    got: list[str] = []
    w = SceneWatcher(folder, lambda s, n: got.append(n), lambda n, e: None, spawn_existing=False)
    assert w.poll() == [] and got == []


def test_robot_and_camera_frame_objects_move_into_the_world() -> None:
    robot = Pose.from_xyz_yaw(2.0, 3.0, 0.0, math.pi / 2)
    mount = CameraMount(position=(0.1, 0.0, 0.4), pitch=0.0)
    scene = Scene(objects=(
        SceneObject("r", "box", (1.0, 0.0, 0.5), (0.4, 0.4, 0.8), yaw=0.0, frame="robot", source=Source(capture="k")),
        SceneObject("c", "box", (0.0, 0.1, 2.0), (0.4, 0.4, 0.8), yaw=math.pi / 2, frame="camera",
                    source=Source(capture="k")),
    ), captures=(Capture("k", robot_pose={"x": 2.0, "y": 3.0, "z": 0.0, "yaw": math.pi / 2}),))
    world = objects_to_world(scene, None, mount)
    r, c = world.object("r"), world.object("c")
    assert r.frame == "world" and r.position == pytest.approx((2.0, 4.0, 0.5))
    assert r.yaw == pytest.approx(math.pi / 2)
    cam = camera_pose_in_world(robot, mount)
    assert c.position == pytest.approx(tuple(cam.apply((0.0, 0.1, 2.0))))
    assert c.position == pytest.approx((2.0, 3.0 + 0.1 + 2.0, 0.3))
    # camera-frame yaw of 90 degrees = length axis along the optical axis = robot forward = world +y
    assert c.yaw == pytest.approx(math.pi / 2)
    assert c.source.positions["camera"] == (0.0, 0.1, 2.0)
    # without a capture pose, the robot's current pose is used
    lone = Scene(objects=(SceneObject("q", "box", (1.0, 0.0, 0.5), (1, 1, 1), frame="robot"),))
    assert objects_to_world(lone, robot, mount).object("q").position == pytest.approx((2.0, 4.0, 0.5))
    with pytest.raises(FrameError, match="robot's pose is unknown"):
        objects_to_world(Scene(objects=(SceneObject("q", "box", (1.0, 0.0, 0.5), (1, 1, 1), frame="robot"),)))
