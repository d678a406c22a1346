"""One camera reader: camera.toml and a photo's JSON (the benchmark / --captures form) through load_camera_file,
with the mount's sign conventions (pitch > 0 looks down, roll > 0: the camera's right side goes down)."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

from pipeline.camera.camera_file import load_camera_file, load_camera_toml, write_camera_toml
from pipeline.camera.geometry import CameraError, CameraMount, Intrinsics

K = [[700.0, 0.0, 600.0], [0.0, 700.0, 180.0], [0.0, 0.0, 1.0]]


def _photo_json(tmp_path: Path, **extra: object) -> Path:
    p = tmp_path / "000001.json"
    p.write_text(json.dumps({"image": "000001.png", "width": 1224, "height": 370, "K": K, **extra}, indent=1))
    return p


def test_a_photo_json_is_a_camera_file(tmp_path: Path) -> None:
    pitch, roll = math.radians(12.0), math.radians(-4.0)
    # gravity (world down) seen from a camera pitched down by `pitch` and rolled by `roll`
    g = CameraMount((0, 0, 0), pitch, 0.0, roll).pose.rotation.inv().apply((0.0, 0.0, -1.0))
    cfg = load_camera_file(_photo_json(tmp_path, gravity_cam=list(g), camera_height=1.65, dist=[0.1, -0.05, 0, 0]))
    assert (cfg.intrinsics.fx, cfg.intrinsics.cx, cfg.intrinsics.width) == (700.0, 600.0, 1224)
    assert cfg.intrinsics.dist == (0.1, -0.05, 0.0, 0.0)
    assert cfg.mount.position[2] == pytest.approx(1.65)
    assert (cfg.mount.pitch, cfg.mount.roll) == pytest.approx((pitch, roll))
    assert load_camera_toml is load_camera_file  # the former name reads both


def test_signs_of_pitch_and_roll() -> None:
    down = CameraMount((0, 0, 0), math.radians(20), 0.0, 0.0).pose.rotation.apply((0.0, 0.0, 1.0))
    assert down[2] < 0  # pitch > 0: the optical axis points below the horizon
    right = CameraMount((0, 0, 0), 0.0, 0.0, math.radians(20)).pose.rotation.apply((1.0, 0.0, 0.0))
    assert right[2] < 0 and right[1] < 0  # roll > 0: the camera's right side (robot -y) goes down


def test_without_gravity_the_default_mount_is_kept(tmp_path: Path) -> None:
    cfg = load_camera_file(_photo_json(tmp_path))
    assert cfg.mount == CameraMount()


@pytest.mark.parametrize("extra, message", [
    ({"K": [[1, 0], [0, 1]]}, "'K' must be a 3x3 list of numbers"),
    ({"gravity_cam": [0, 1, 0]}, "'gravity_cam' and 'camera_height' go together"),
    ({"gravity_cam": [0, 2, 0], "camera_height": 1.0}, "gravity_cam must be a unit vector"),
    ({"width": 0}, "'width' must be a whole number of pixels > 0"),
])
def test_bad_photo_json_names_the_file_and_key(tmp_path: Path, extra: dict, message: str) -> None:
    path = _photo_json(tmp_path, **extra)
    with pytest.raises(CameraError, match=message) as err:
        load_camera_file(path)
    assert str(err.value).startswith(str(path))


def test_camera_toml_still_reads_and_bad_json_is_named(tmp_path: Path) -> None:
    path = write_camera_toml(tmp_path / "camera.toml", Intrinsics(525, 525, 319.5, 239.5, 640, 480),
                             CameraMount((0.1, 0.0, 0.3), math.radians(10)))
    assert load_camera_file(path).mount.pitch == pytest.approx(math.radians(10))
    bad = tmp_path / "bad.json"
    bad.write_text('{"K": [')
    with pytest.raises(CameraError, match="is not valid JSON"):
        load_camera_file(bad)


def test_the_benchmark_photos_own_camera_json_reads(tmp_path: Path) -> None:
    dev = Path(__file__).resolve().parents[4] / "shared" / "bench" / "dev"
    files = sorted(dev.glob("*/000000.json"))
    if not files:
        pytest.skip(f"the development benchmark is not at {dev}")
    for f in files:
        cfg = load_camera_file(f)
        assert cfg.intrinsics.width > 0 and np.isfinite(cfg.mount.pitch)
