"""Frames and projection: camera -> robot -> world with known answers."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from pipeline.geometry import (
    CameraError, CameraMount, Intrinsics, Pose, backproject, camera_pose_in_world,
    load_camera_toml, parse_pose, project, ray_directions,
)

INTR = Intrinsics(500.0, 480.0, 320.0, 240.0, 640, 480)


def test_backproject_project_round_trip() -> None:
    rng = np.random.default_rng(0)
    uv = rng.uniform([0, 0], [640, 480], size=(50, 2))
    z = rng.uniform(0.5, 20, size=50)
    pts = backproject(uv, z, INTR)
    assert np.allclose(pts[:, 2], z)
    assert np.allclose(project(pts, INTR), uv)


def test_principal_ray_is_optical_axis() -> None:
    assert np.allclose(ray_directions([320.0, 240.0], INTR), [[0, 0, 1]])


def test_level_camera_looks_along_body_x() -> None:
    mount = CameraMount(position=(0.2, 0.0, 0.5))
    # a point 3 m ahead on the optical axis is 3 m ahead of the camera along body x
    p = mount.pose.apply([0.0, 0.0, 3.0])
    assert np.allclose(p, [3.2, 0.0, 0.5])
    # image right (+x optical) is body right (-y); image down (+y optical) is body down (-z)
    assert np.allclose(mount.pose.apply([1.0, 0.0, 0.0]) - mount.pose.apply([0, 0, 0]), [0, -1, 0])
    assert np.allclose(mount.pose.apply([0.0, 1.0, 0.0]) - mount.pose.apply([0, 0, 0]), [0, 0, -1])


def test_pitched_camera_looks_down() -> None:
    mount = CameraMount(position=(0, 0, 1.0), pitch=math.radians(30))
    d = mount.pose.rotation.apply([0, 0, 1.0])
    assert d[2] == pytest.approx(-0.5)
    assert d[0] == pytest.approx(math.sqrt(3) / 2)


def test_camera_to_world_with_robot_yaw() -> None:
    robot = Pose.from_xyz_yaw(2.0, 1.0, 0.0, math.pi / 2)  # facing world +y
    cam = camera_pose_in_world(robot, CameraMount(position=(0.0, 0.0, 0.4)))
    assert np.allclose(cam.apply([0, 0, 2.0]), [2.0, 3.0, 0.4])
    assert np.allclose(cam.inverse().apply(cam.apply([0.3, -0.2, 4.0])), [0.3, -0.2, 4.0])
    assert robot.yaw == pytest.approx(math.pi / 2)


@pytest.mark.parametrize(
    "kwargs, match",
    [
        (dict(fx=0.0), "focal"),
        (dict(fy=-5.0), "focal"),
        (dict(cx=900.0), "principal point"),
        (dict(cy=-1.0), "principal point"),
        (dict(width=0), "image size"),
        (dict(fx=float("nan")), "finite"),
    ],
)
def test_bad_intrinsics(kwargs, match) -> None:
    base = dict(fx=500.0, fy=500.0, cx=320.0, cy=240.0, width=640, height=480)
    base.update(kwargs)
    with pytest.raises(CameraError, match=match):
        Intrinsics(**base)


def test_camera_toml(tmp_path: Path) -> None:
    p = tmp_path / "camera.toml"
    p.write_text("[intrinsics]\nfx=600\nfy=600\ncx=320\ncy=240\nwidth=640\nheight=480\n"
                 "[mount]\nposition=[0.1,0,0.3]\npitch_deg=15\n")
    cfg = load_camera_toml(p)
    assert cfg.intrinsics.fx == 600 and cfg.mount.pitch == pytest.approx(math.radians(15))
    p.write_text("[intrinsics]\nfx=600\n")
    with pytest.raises(CameraError, match="intrinsics.fy"):
        load_camera_toml(p)
    p.write_text("not toml [")
    with pytest.raises(CameraError, match="not valid TOML"):
        load_camera_toml(p)


def test_parse_pose() -> None:
    p = parse_pose("1,2,0,90")
    assert np.allclose(p.translation, [1, 2, 0]) and p.yaw == pytest.approx(math.pi / 2)
    with pytest.raises(CameraError):
        parse_pose("1,b")


def test_distortion_undistorts() -> None:
    intr = Intrinsics(500.0, 500.0, 320.0, 240.0, 640, 480, dist=(-0.2, 0.05, 0.0, 0.0, 0.0))
    import cv2

    pt = np.array([[0.4, 0.3, 1.0]])
    uv, _ = cv2.projectPoints(pt, np.zeros(3), np.zeros(3), intr.K, np.array(intr.dist))
    back = backproject(uv.reshape(-1, 2), 1.0, intr)
    assert np.allclose(back, pt, atol=1e-4)
