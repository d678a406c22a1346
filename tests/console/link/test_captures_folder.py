"""The console's --captures folder: the same image convention as `morphonavi map`, refused bad inputs."""

from __future__ import annotations

import dataclasses
import json
import logging
import math
from pathlib import Path

import cv2
import numpy as np
import pytest
from PIL import Image

from console.link.captures import CapturesError, CapturesFolder
from pipeline.camera.geometry import CameraMount, mount_from_gravity_height


def _photo(folder: Path, stem: str, w: int, h: int, meta: dict | None = None, *, orientation: int | None = None,
           write_size: bool = True) -> Path:
    rgb = np.zeros((h, w, 3), np.uint8)
    rgb[:20, :30] = 255  # marks the stored top-left corner
    path = folder / f"{stem}.jpg"
    kw = {}
    if orientation is not None:
        exif = Image.Exif()
        exif[0x0112] = orientation
        kw["exif"] = exif
    Image.fromarray(rgb).save(path, "JPEG", quality=95, **kw)
    up_w, up_h = (h, w) if orientation in (5, 6, 7, 8) else (w, h)
    m = {"image": path.name, "K": [[0.8 * up_w, 0, up_w / 2], [0, 0.8 * up_w, up_h / 2], [0, 0, 1]]}
    if write_size:
        m.update(width=up_w, height=up_h)
    m.update(meta or {})
    (folder / f"{stem}.json").write_text(json.dumps(m))
    return path


def test_a_sideways_phone_photo_is_served_upright_and_said_so(tmp_path: Path, caplog: pytest.LogCaptureFixture) -> None:
    _photo(tmp_path, "phone", 730, 530, orientation=6)
    with caplog.at_level(logging.INFO, logger="console.link.captures"):
        photo = CapturesFolder(tmp_path).next()
    assert photo.image.shape == (730, 530, 3)  # the same grid `morphonavi map` uses
    assert (photo.intrinsics.width, photo.intrinsics.height) == (530, 730)
    assert photo.image[5, -5].min() > 200  # the stored top-left corner, turned clockwise: top-right
    assert photo.note is not None and "EXIF orientation 6 applied" in photo.note
    assert any("EXIF orientation 6 applied" in r.getMessage() for r in caplog.records)


def test_intrinsics_of_the_stored_sideways_grid_are_refused_at_open(tmp_path: Path) -> None:
    _photo(tmp_path, "phone", 730, 530, orientation=6, meta={"width": 730, "height": 530,
                                                           "K": [[584, 0, 365], [0, 584, 265], [0, 0, 1]]})
    with pytest.raises(CapturesError, match=r"phone\.json: intrinsics\.width x intrinsics\.height: .*730x530 .*530x730"
                                            r".*rotated\? the intrinsics describe the upright image"):
        CapturesFolder(tmp_path)


def test_a_resized_photo_with_only_K_is_refused_naming_the_fields(tmp_path: Path) -> None:
    _photo(tmp_path, "small", 438, 318, write_size=False,
           meta={"K": [[584.0, 0, 365.0], [0, 584.0, 265.0], [0, 0, 1]]})  # the full-size (730 x 530) camera
    with pytest.raises(CapturesError, match=r"small\.json: 'width' is required: 'width' and 'height' give the image "
                                            r"size K is for \(this image is 438x318"):
        CapturesFolder(tmp_path)


def test_a_resized_photo_with_its_full_size_is_refused_as_resized(tmp_path: Path) -> None:
    _photo(tmp_path, "small", 438, 318, meta={"width": 730, "height": 530,
                                            "K": [[584.0, 0, 365.0], [0, 584.0, 265.0], [0, 0, 1]]})
    with pytest.raises(CapturesError, match=r"730x530 image but the image is 438x318 \(resized by 0\.6"):
        CapturesFolder(tmp_path)


def test_a_corrupt_jpeg_is_refused_with_a_clear_error(tmp_path: Path) -> None:
    rng = np.random.default_rng(1)
    path = _photo(tmp_path, "bad", 320, 240)
    img = cv2.GaussianBlur((rng.random((240, 320, 3)) * 255).astype(np.uint8), (0, 0), 3)
    data = bytearray(cv2.imencode(".jpg", img)[1].tobytes())
    for i in range(data.find(b"\xff\xda") + 200, len(data) - 2, 1000):
        data[i] ^= 0xFF
    path.write_bytes(bytes(data))
    folder = CapturesFolder(tmp_path)  # the header is fine: the data is checked when decoded
    with pytest.raises(CapturesError, match=r"bad\.jpg: corrupt JPEG data"):
        folder.next()


def test_json_nested_too_deeply_is_a_named_error(tmp_path: Path) -> None:
    _photo(tmp_path, "a", 64, 48)
    (tmp_path / "index.json").write_text("[" * 100_000 + "]" * 100_000)
    with pytest.raises(CapturesError, match=r"index\.json: JSON nested too deeply"):
        CapturesFolder(tmp_path)


@pytest.mark.parametrize(("extra", "match"), [
    ({"gravity_cam": [0, 1, 0]}, "go together"),
    ({"gravity_cam": [0, 2, 0], "camera_height": 1.2}, "unit vector"),
    ({"gravity_cam": [0, 1, "a"], "camera_height": 1.2}, "gravity_cam: expected 3 finite numbers"),
    ({"gravity_cam": [0, 1, 0], "camera_height": float("nan")}, "camera_height must be a number within 0..10 m"),
    ({"dist": ["a"]}, "'dist' must be a list of numbers"),
    ({"width": 64.5}, "'width' must be a whole number"),
])
def test_bad_per_photo_values_are_refused(tmp_path: Path, extra: dict, match: str) -> None:
    _photo(tmp_path, "a", 64, 48, meta=extra)
    with pytest.raises(CapturesError, match=match):
        CapturesFolder(tmp_path)


def test_per_photo_gravity_and_height_give_the_cameras_mount(tmp_path: Path) -> None:
    pitch, roll = math.radians(25.0), math.radians(-4.0)
    truth = CameraMount((0.0, 0.0, 1.2), pitch, 0.0, roll)
    g = truth.pose.rotation.inv().apply([0.0, 0.0, -1.0])  # gravity seen from the camera
    _photo(tmp_path, "a", 64, 48, meta={"gravity_cam": list(g), "camera_height": 1.2})
    photo = CapturesFolder(tmp_path).next()
    assert photo.mount is not None
    assert photo.mount.position[2] == pytest.approx(1.2)
    assert photo.mount.pitch == pytest.approx(pitch) and photo.mount.roll == pytest.approx(roll)
    back = photo.mount.pose.rotation.inv().apply([0.0, 0.0, -1.0])
    assert np.allclose(back, g, atol=1e-9)
    level = mount_from_gravity_height((0.0, 1.0, 0.0), 0.35)
    assert level.pitch == pytest.approx(0.0) and level.roll == pytest.approx(0.0)


def test_the_console_uses_the_photos_own_camera_pose(tmp_path: Path) -> None:
    """A real photo taken from 1.2 m with a downward tilt is placed with that pose, not the robot's mount."""
    from console.link.sim import SimRobot

    truth = CameraMount((0.0, 0.0, 1.2), math.radians(30.0), 0.0, 0.0)
    g = truth.pose.rotation.inv().apply([0.0, 0.0, -1.0])
    _photo(tmp_path, "a", 64, 48, meta={"gravity_cam": list(g), "camera_height": 1.2})
    _photo(tmp_path, "b", 64, 48)  # no pose of its own: the robot's mount, as a stand-in the mapper re-fits
    robot = SimRobot(captures=tmp_path, manual_clock=True)
    robot.connect()
    try:
        a, b = robot.capture(), robot.capture()
    finally:
        robot.close()
    assert a.camera_pose.translation[2] == pytest.approx(1.2)
    forward = a.camera_pose.rotation.apply([0.0, 0.0, 1.0])  # the optical axis in the world
    assert math.degrees(math.asin(-forward[2])) == pytest.approx(30.0, abs=1e-6)
    assert b.mount == dataclasses.replace(robot.mount, assumed=True) and not a.mount.assumed
    assert b.camera_pose.translation[2] == pytest.approx(robot.mount.position[2])
