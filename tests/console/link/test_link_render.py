"""The simulator's headless renderer: depth, instance masks, shading, proxy models, speed."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from console.link.render import RenderError, SceneRenderer
from console.link.world import DEFAULT_START, ROOM_MAX, ROOM_MIN, paper_room
from pipeline.camera.geometry import CameraMount, Intrinsics, Pose, backproject, camera_pose_in_world, project
from pipeline.scene import Scene, SceneObject

INTR = Intrinsics(400.0, 400.0, 159.5, 119.5, 320, 240)
CAM_HEIGHT = 0.5


def _camera_looking_north(x: float = 0.0, y: float = 0.0) -> Pose:
    """World <- camera for a robot at (x, y) facing +y with a level camera CAM_HEIGHT up."""
    robot = Pose.from_xyz_yaw(x, y, 0.0, math.pi / 2)
    return camera_pose_in_world(robot, CameraMount(position=(0.0, 0.0, CAM_HEIGHT)))


def _box(oid: str, centre: tuple[float, float, float], size=(1.0, 1.0, 1.0), yaw: float = 0.0) -> SceneObject:
    # a label without a catalog entry: drawn as an exact box
    return SceneObject(oid, "test_block_without_model", centre, size, yaw)


def test_depth_is_distance_along_the_optical_axis_to_the_box_face() -> None:
    # 1 m cube whose near face is 3 m ahead (world y = 3.0), centred on the optical axis
    scene = Scene(objects=(_box("b", (0.0, 3.5, CAM_HEIGHT)),))
    r = SceneRenderer(scene, room=None).render(_camera_looking_north(), INTR)
    assert r.rgb.shape == (240, 320, 3) and r.rgb.dtype == np.uint8
    assert r.depth.dtype == np.float32 and r.instances.dtype == np.int32
    # every pixel on the face has depth 3.0 (a plane perpendicular to the optical axis)
    face = r.instances == 0
    assert face.sum() > 1000
    assert np.allclose(r.depth[face], 3.0, atol=2e-3)
    # nothing else in the scene: misses are background with infinite depth and black pixels
    assert np.all(np.isinf(r.depth[~face])) and np.all(r.rgb[~face] == 0)
    assert r.object_ids == ("b",)


def test_instance_mask_matches_the_projected_box() -> None:
    scene = Scene(objects=(_box("b", (0.4, 4.5, 0.6), size=(0.8, 1.2, 0.6)),))
    cam = _camera_looking_north()
    r = SceneRenderer(scene, room=None).render(cam, INTR)
    w, h, l = 0.8, 1.2, 0.6  # at yaw 0 the length runs along world x, the width along world y
    corners = np.array([[0.4 + sx * l / 2, 4.5 + sy * w / 2, 0.6 + sz * h / 2]
                        for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)])
    uv = project(cam.inverse().apply(corners), INTR)
    vs, us = np.nonzero(r.instances == 0)
    # the mask spans the pixel centres inside the projected box (near face and the visible side)
    assert us.min() == pytest.approx(np.ceil(uv[:, 0].min()), abs=1)
    assert us.max() == pytest.approx(np.floor(uv[:, 0].max()), abs=1)
    assert vs.min() == pytest.approx(np.ceil(uv[:, 1].min()), abs=1)
    assert vs.max() == pytest.approx(np.floor(uv[:, 1].max()), abs=1)


def test_floor_depth_and_tiles_in_the_room() -> None:
    r = SceneRenderer(Scene(), room=((-5.0, -1.0, 0.0), (5.0, 20.0, 3.0))).render(_camera_looking_north(), INTR)
    assert np.all(r.instances == -1)
    # a level camera CAM_HEIGHT above the floor sees the floor at row v at depth h * fy / (v - cy)
    for v in (150, 200, 239):
        expected = CAM_HEIGHT * INTR.fy / (v - INTR.cy)
        assert r.depth[v, 160] == pytest.approx(expected, rel=1e-3)
    # the floor is tiled: brightness changes across a tile edge (x = 0 is an edge)
    row = r.rgb[220].astype(int).sum(axis=1)
    assert abs(row[150] - row[170]) > 20
    assert np.isfinite(r.depth).all()  # the room is closed


def test_faces_at_different_angles_are_shaded_differently() -> None:
    scene = Scene(objects=(_box("b", (0.0, 3.0, 0.5), yaw=math.radians(45)),))
    r = SceneRenderer(scene, room=None).render(_camera_looking_north(), INTR)
    mask = r.instances == 0
    vs, us = np.nonzero(mask)
    mid_v = int(np.median(vs))
    left = r.rgb[mid_v, int(np.percentile(us, 20))].astype(int)
    right = r.rgb[mid_v, int(np.percentile(us, 80))].astype(int)
    assert abs(left.sum() - right.sum()) > 15


def test_depth_back_projects_onto_the_true_objects_of_the_paper_room() -> None:
    world = paper_room()
    cam = camera_pose_in_world(DEFAULT_START, CameraMount())
    r = SceneRenderer(world, (ROOM_MIN, ROOM_MAX)).render(cam, INTR)
    seen = [i for i in np.unique(r.instances) if i >= 0]
    assert len(seen) >= 5
    for i in seen:
        obj = world.object(r.object_ids[i])
        vs, us = np.nonzero(r.instances == i)
        pts_cam = backproject(np.stack([us, vs], axis=1), r.depth[vs, us], INTR)
        pts = cam.apply(pts_cam)
        # into the object's box frame (x along the length, y along the width, z up)
        local = Rotation.from_euler("z", -obj.yaw).apply(pts - np.asarray(obj.position))
        w, h, l = obj.size
        inside = np.all(np.abs(local) <= np.array([l, w, h]) / 2 + 0.02, axis=1)
        assert inside.mean() > 0.97, f"{obj.id}: only {inside.mean():.0%} of its pixels lie on it"


def test_proxy_models_give_object_shaped_silhouettes() -> None:
    from pipeline.catalog import default_catalog

    entry = default_catalog().lookup("robot_dog")
    if entry is None or not entry.model_path.is_file():
        pytest.skip("robot_dog proxy model not generated")
    size = (0.28, 0.40, 0.645)
    dog = SceneObject("dog", "robot_dog", (0.0, 2.0, 0.2), size, 0.0)
    block = _box("block", (0.0, 2.0, 0.2), size)
    cam = _camera_looking_north()
    r_dog = SceneRenderer(Scene(objects=(dog,)), room=None).render(cam, INTR)
    r_box = SceneRenderer(Scene(objects=(block,)), room=None).render(cam, INTR)
    a_dog, a_box = int((r_dog.instances == 0).sum()), int((r_box.instances == 0).sum())
    assert 0.2 * a_box < a_dog < 0.9 * a_box  # legs and gaps, yet within the same box
    # the model's own colours are used (not one flat colour)
    colours = np.unique(r_dog.rgb[r_dog.instances == 0] // 16, axis=0)
    assert len(colours) >= 3


def test_a_repeated_render_of_the_paper_room_is_the_same_image() -> None:
    # speed is a benchmark's job (bench/pipeline_speed.py), never a timed unit test: here the ray cache the
    # first render fills must give the same image again
    renderer = SceneRenderer(paper_room(), (ROOM_MIN, ROOM_MAX))
    intr = Intrinsics(525.0, 525.0, 319.5, 239.5, 640, 480)
    cam = camera_pose_in_world(DEFAULT_START, CameraMount())
    first = renderer.render(cam, intr)  # fills the ray cache
    r = renderer.render(cam, intr)
    assert r.rgb.shape == (480, 640, 3)
    assert np.array_equal(r.rgb, first.rgb) and np.array_equal(r.depth, first.depth)


def test_objects_not_in_the_world_frame_are_refused() -> None:
    obj = SceneObject("c", "desk", (0.0, 0.0, 2.0), (1.0, 0.7, 0.6), frame="camera")
    with pytest.raises(RenderError, match="camera frame"):
        SceneRenderer(Scene(objects=(obj,)))
    with pytest.raises(RenderError, match="nothing to render"):
        SceneRenderer(Scene(), room=None)
