"""Frames and projection: camera -> robot -> world with known answers."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from pipeline.camera.geometry import (
    CameraError, CameraMount, Intrinsics, Pose, backproject, camera_pose_in_world,
    parse_pose, project, ray_directions,
)
from pipeline.camera.camera_file import load_camera_toml

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


# --- camera.toml: every value checked, the error names the key -------------------------------------

GOOD_INTR = "[intrinsics]\nfx = 600.0\nfy = 600.0\ncx = 320.0\ncy = 240.0\nwidth = 640\nheight = 480\n"


@pytest.mark.parametrize(
    ("intrinsics_extra", "mount", "match"),
    [
        ("dist = [nan, 0, 0, 0]\n", "", r"intrinsics\.dist\[0\]: must be finite, got nan"),
        ('dist = ["a", 0, 0, 0]\n', "", r"intrinsics\.dist\[0\]: must be a number, got 'a'"),
        ("dist = [0, 0, 0]\n", "", r"intrinsics\.dist: expected 0, 4, 5, 8, 12, 14 distortion coefficients, got 3"),
        ("dist = [0, 0, 1e9, 0]\n", "", r"intrinsics\.dist\[2\]: must be within -1000\.\.1000"),
        ("dist = 0.1\n", "", r"intrinsics\.dist: must be a list"),
        ("", "pitch_deg = nan\n", r"mount\.pitch_deg: must be finite, got nan"),
        ("", "pitch_deg = 1e9\n", r"mount\.pitch_deg: must be within -90\.\.90 deg, got 1e\+09"),
        ("", 'pitch_deg = "10"\n', r"mount\.pitch_deg: must be a number, got '10'"),
        ("", "yaw_deg = inf\n", r"mount\.yaw_deg: must be finite"),
        ("", "roll_deg = 400\n", r"mount\.roll_deg: must be within -180\.\.180 deg"),
        ("", "position = [1e308, 0, inf]\n", r"mount\.position\[0\]: must be within -10\.\.10 m, got 1e\+308"),
        ("", "position = [0, 0, inf]\n", r"mount\.position\[2\]: must be finite, got inf"),
        ("", 'position = ["a", 0, 0.3]\n', r"mount\.position\[0\]: must be a number, got 'a'"),
        ("", "position = [0, 0.3]\n", r"mount\.position: expected 3 numbers \[m\], got 2"),
        ("", "pitch = 10\n", r"mount\.pitch: unknown key"),
        ("focal = 3\n", "", r"intrinsics\.focal: unknown key"),
    ],
)
def test_camera_toml_bad_values_name_the_key(tmp_path: Path, intrinsics_extra: str, mount: str, match: str) -> None:
    p = tmp_path / "camera.toml"
    p.write_text(GOOD_INTR + intrinsics_extra + ("[mount]\n" + mount if mount else ""))
    with pytest.raises(CameraError, match=match) as err:
        load_camera_toml(p)
    assert str(p) in str(err.value)


@pytest.mark.parametrize(
    ("replace", "by", "match"),
    [
        ("fx = 600.0", "fx = nan", r"intrinsics\.fx: must be finite"),
        ("fx = 600.0", "fx = 1e9", r"intrinsics\.fx: 1e\+09 px gives a .* deg field of view over 640 px"),
        ("fy = 600.0", "fy = -2.0", r"intrinsics\.fy: must be > 0 px"),
        ("cx = 320.0", "cx = 700.0", r"intrinsics\.cx: must be within 0\.\.640 px"),
        ("cy = 240.0", 'cy = "a"', r"intrinsics\.cy: must be a number"),
        ("width = 640", "width = 640.5", r"intrinsics\.width: must be a whole number of pixels, got 640\.5"),
        ("height = 480", "height = 0", r"intrinsics\.height: must be within 1\.\.8000 px, got 0"),
        ("height = 480", "height = true", r"intrinsics\.height: must be a whole number"),
        ("width = 640\n", "", r"intrinsics\.width: is required"),
    ],
)
def test_camera_toml_bad_intrinsics_name_the_key(tmp_path: Path, replace: str, by: str, match: str) -> None:
    p = tmp_path / "camera.toml"
    assert replace in GOOD_INTR
    p.write_text(GOOD_INTR.replace(replace, by))
    with pytest.raises(CameraError, match=match):
        load_camera_toml(p)


def test_camera_toml_unknown_table_and_directory(tmp_path: Path) -> None:
    p = tmp_path / "camera.toml"
    p.write_text(GOOD_INTR + "[mounts]\npitch_deg = 3\n")
    with pytest.raises(CameraError, match=r"\[mounts\]: unknown table"):
        load_camera_toml(p)
    with pytest.raises(CameraError, match="is a directory"):
        load_camera_toml(tmp_path)


def test_camera_toml_round_trip_through_the_writer(tmp_path: Path) -> None:
    from pipeline.camera.camera_file import write_camera_toml

    intr = Intrinsics(612.5, 611.0, 318.2, 241.7, 640, 480, (-0.21, 0.05, 0.001, -0.002, 0.0))
    mount = CameraMount((0.1, 0.0, 1.2), math.radians(20.0), 0.0, 0.0)
    path = write_camera_toml(tmp_path / "cam.toml", intr, mount, {"rms_px": 0.31, "views": 12})
    cfg = load_camera_toml(path)
    assert cfg.intrinsics == intr
    assert cfg.mount.position == (0.1, 0.0, 1.2) and cfg.mount.pitch == pytest.approx(math.radians(20.0))
    assert not (tmp_path / "cam.toml.tmp").exists()


def test_image_size_mismatch_names_the_fields_and_the_likely_cause() -> None:
    intr = Intrinsics(1000.0, 1000.0, 640.0, 360.0, 1280, 720)
    with pytest.raises(CameraError, match=r"intrinsics\.width x intrinsics\.height: .*1280x720 .* 768x432 .*resized by 0\.6"):
        intr.check_image(768, 432)
    with pytest.raises(CameraError, match=r"rotated\? the intrinsics describe the upright image"):
        intr.check_image(720, 1280)


@pytest.mark.parametrize(
    ("text", "match"),
    [("", r"--pose: empty value"), ("1,b", r"--pose: value 2 \('b'\) is not a number"),
     ("1,2,3,4,5", r"--pose: expected 2 or 3 or 4 numbers"), ("1,nan", r"--pose: value 2 must be finite")],
)
def test_parse_pose_errors_name_the_option(text: str, match: str) -> None:
    with pytest.raises(CameraError, match=match):
        parse_pose(text, "--pose")


def test_parse_pose_takes_negative_numbers() -> None:
    p = parse_pose("-1,2,0,-90")
    assert np.allclose(p.translation, [-1, 2, 0]) and p.yaw == pytest.approx(-math.pi / 2)


def test_mount_from_gravity_and_height_puts_gravity_where_given() -> None:
    from pipeline.camera.geometry import mount_from_gravity_height

    rng = np.random.default_rng(4)
    for _ in range(20):
        g = rng.normal(size=3) * 0.4 + [0.0, 1.0, 0.3]
        g /= np.linalg.norm(g)
        mount = mount_from_gravity_height(g, 1.3)
        seen = mount.pose.rotation.inv().apply([0.0, 0.0, -1.0])
        assert np.allclose(seen, g, atol=1e-9) and mount.position[2] == 1.3 and mount.yaw == 0.0
