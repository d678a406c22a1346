"""A camera whose pose the user did not give is fitted from the photo, never taken as level: the camera
readers say whether the mount was given, the mapper fits pitch, roll and height without it, and `map`
says so (tilted simulator render: 1.2 m up, 30 deg down; the ScanNet dev photo with its gravity removed)."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

from console.cli.morphonavi import main
from pipeline.camera.camera_file import load_camera_toml
from pipeline.camera.photo_camera import camera_config_from_photo_json
from pipeline.camera.pose_check import floor_check

SHARED = Path(__file__).resolve().parents[3].parent / "shared"
MODELS = SHARED / "models"
SCANNET = SHARED / "bench" / "dev" / "scannet" / "scene0000_00_00000.jpg"
INTR = "[intrinsics]\nfx = 260.0\nfy = 260.0\ncx = 160.0\ncy = 120.0\nwidth = 320\nheight = 240\n"


def test_the_camera_readers_say_whether_the_mount_was_given(tmp_path: Path) -> None:
    bare, full = tmp_path / "bare.toml", tmp_path / "full.toml"
    bare.write_text(INTR)
    full.write_text(INTR + "[mount]\nposition = [0.1, 0.0, 1.0]\npitch_deg = 15.0\n")
    assert load_camera_toml(bare).mount_given is False and load_camera_toml(full).mount_given is True
    meta = {"width": 320, "height": 240, "K": [[260.0, 0, 160.0], [0, 260.0, 120.0], [0, 0, 1]]}
    assert camera_config_from_photo_json(meta, "p.json").mount_given is False
    tilted = {**meta, "gravity_cam": [0.0, math.cos(0.3), math.sin(0.3)], "camera_height": 1.1}
    cfg = camera_config_from_photo_json(tilted, "p.json")
    assert cfg.mount_given is True and cfg.mount.pitch == pytest.approx(0.3, abs=1e-6)


def test_without_a_given_pose_the_mapper_fits_the_tilted_camera_instead_of_taking_it_level(sim_shot, gt_map) -> None:
    from console.link.sim import DEFAULT_MOUNT
    from pipeline.camera.geometry import CameraMount

    high = CameraMount((0.15, 0.0, 1.2), math.radians(30.0))
    shot = sim_shot(mount=high)
    scenes = {name: gt_map(shot, mount, pose_given=given).scene
              for name, mount, given in (("true", high, True), ("level", DEFAULT_MOUNT, True),
                                         ("fitted", DEFAULT_MOUNT, False))}
    assert floor_check(scenes["level"])  # taken as level: objects off the floor, warned
    assert floor_check(scenes["fitted"]) == []  # fitted from the photo: they stand on the floor
    true = {o.id: np.asarray(o.position) for o in scenes["true"].objects}

    def err(scene) -> float:
        return float(np.median([np.linalg.norm(np.asarray(o.position) - true[o.id]) for o in scene.objects
                                if o.id in true]))

    assert err(scenes["fitted"]) < 0.25 < err(scenes["level"]), (err(scenes["fitted"]), err(scenes["level"]))


@pytest.mark.skipif(not all((MODELS / n).is_dir() for n in ("yolox_nano", "mobilesam", "fastdepth", "oidv4_ssd")),
                    reason=f"real offline models not in {MODELS}")
@pytest.mark.skipif(not SCANNET.is_file(), reason=f"dev photo {SCANNET} not there")
def test_map_says_the_pose_is_fitted_when_the_camera_file_gives_none(tmp_path: Path,
                                                                       capsys: pytest.CaptureFixture[str]) -> None:
    meta = json.loads(SCANNET.with_suffix(".json").read_text())
    for key in ("gravity_cam", "camera_height"):
        meta.pop(key, None)
    cam = tmp_path / "camera.json"
    cam.write_text(json.dumps(meta))
    out = tmp_path / "scene.json"
    code = main(["map", str(SCANNET), "--camera-file", str(cam), "--out", str(out), "--model-dir", str(MODELS)])
    err = capsys.readouterr().err
    assert code == 0 and out.is_file() and "Traceback" not in err
    assert "pitch, roll and height are not given" in err and "fitted from the photo's floor" in err
