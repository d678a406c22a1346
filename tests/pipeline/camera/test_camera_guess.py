"""Uncalibrated photos: the assumed camera (stated FOV, EXIF 35 mm focal length, or a typical lens), flagged."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from pipeline.camera.camera_guess import assumed_camera
from pipeline.camera.geometry import CameraError
from pipeline.camera.image_io import read_image


def test_exif_focal_length_gives_the_focal_in_pixels(tmp_path: Path) -> None:
    exif = Image.Exif()
    exif.get_ifd(0x8769)[0xA405] = 26  # a phone's main camera: 26 mm equivalent
    path = tmp_path / "phone.jpg"
    Image.new("RGB", (4000, 3000)).save(path, "JPEG", exif=exif)
    loaded = read_image(path)
    assert loaded.focal_35mm == 26.0
    cam = assumed_camera(4000, 3000, focal_35mm=loaded.focal_35mm)
    assert cam.intrinsics.fx == pytest.approx(26 * 5000 / 43.27)  # 3004 px
    assert 65 < math.degrees(cam.intrinsics.hfov) < 70 and cam.rel_sigma == 0.05
    assert (cam.intrinsics.cx, cam.intrinsics.cy) == (2000.0, 1500.0)
    assert "EXIF 35 mm equivalent focal length 26 mm" in cam.warning and "+-5%" in cam.warning


def test_stated_fov_and_the_default_lens() -> None:
    cam = assumed_camera(640, 480, hfov_deg=90.0, focal_35mm=26.0)  # a stated FOV wins
    assert cam.intrinsics.fx == pytest.approx(320.0) and cam.rel_sigma == 0.10
    default = assumed_camera(640, 480)
    assert math.degrees(default.intrinsics.hfov) == pytest.approx(65.0) and default.rel_sigma == 0.30
    assert "ASSUMED" in default.warning and "morphonavi calibrate" in default.warning
    for bad in (0.0, 180.0, float("nan")):
        with pytest.raises(CameraError, match="--fov: the horizontal field of view must be within 1..179 deg"):
            assumed_camera(640, 480, hfov_deg=bad)


def test_map_without_a_camera_file_flags_the_assumed_intrinsics(tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                                                 capsys: pytest.CaptureFixture[str]) -> None:
    import console.cli.map_bench_cmd as cc
    from console.cli.morphonavi import main
    from pipeline.models.ground_truth import ground_truth_bundle

    monkeypatch.setattr(cc, "load_mapping_models",
                        lambda *a, **k: ground_truth_bundle([(280.0, 200.0, 360.0, 330.0)], ["office_chair"]))
    photo = tmp_path / "photo.png"
    Image.fromarray(np.full((480, 640, 3), 120, np.uint8)).save(photo)
    out = tmp_path / "scene.json"
    assert main(["map", str(photo), "--fov", "70", "--out", str(out)]) == 0, capsys.readouterr().err
    printed = capsys.readouterr().out
    assert "warning: no camera file: intrinsics ASSUMED from the stated field of view 70 deg" in printed
    cap = json.loads(out.read_text())["captures"][0]
    assert cap["models"]["intrinsics"] == "assumed from the stated field of view 70 deg, +-10%"
    assert cap["intrinsics"]["fx"] == pytest.approx(320.0 / math.tan(math.radians(35.0)), rel=1e-4)
    assert main(["map", str(photo), "--fov", "70", "--camera", str(tmp_path / "c.toml"), "--out", str(out)]) == 2
    assert "--fov is for photos without a camera file" in capsys.readouterr().err
