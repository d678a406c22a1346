"""A captures folder's photo without gravity: the camera pose comes from the photo's floor, not the robot's mount.

A street photo taken 1.6 m up, pitched 6 deg down, served by the console's ``--captures`` folder with no
``gravity_cam`` / ``camera_height``: the simulated robot's mount (level, 0.35 m up) is only a stand-in
(``CameraMount.assumed``), so the mapper fits pitch and height from the people standing on the floor.
"""

from __future__ import annotations

import json
import math
import re
from pathlib import Path

import cv2
import numpy as np
import pytest

from pipeline.camera.geometry import CameraMount, Intrinsics, project
from pipeline.catalog import default_catalog

W, H_IMG = 1280, 720
INTR = Intrinsics(900.0, 900.0, 640.0, 360.0, W, H_IMG)
PITCH_DEG, HEIGHT = 6.0, 1.6
PEOPLE = [(-2.0, 6.0), (1.5, 8.0), (0.0, 11.0), (3.0, 14.0), (-3.5, 17.0), (1.0, 21.0)]
"""(lateral [m], forward along the floor [m]) of each person."""


def _street(folder: Path, with_pose: bool) -> list[np.ndarray]:
    """Write one photo + JSON into ``folder``; returns the people's true centres (camera frame [m])."""
    p = math.radians(PITCH_DEG)
    g = np.array([0.0, math.cos(p), math.sin(p)])  # gravity down, camera frame
    fwd = np.array([0.0, -math.sin(p), math.cos(p)])
    right = np.array([1.0, 0.0, 0.0])
    w, h, l = default_catalog().lookup("person").size
    objects, centres = [], []
    for x, d in PEOPLE:
        c = HEIGHT * g + x * right + d * fwd - 0.5 * h * g
        corners = np.array([c + sx * 0.5 * w * right + sy * 0.5 * h * g + sz * 0.5 * l * fwd
                            for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)])
        uv = project(corners, INTR)
        box = [float(uv[:, 0].min()), float(uv[:, 1].min()), float(uv[:, 0].max()), float(uv[:, 1].max())]
        objects.append({"label": "person", "center_cam": c.tolist(), "size": [w, h, l], "yaw": 0.0, "bbox2d_gt": box})
        centres.append(c)
    cv2.imwrite(str(folder / "street.png"), np.full((H_IMG, W, 3), 110, np.uint8))
    meta = {"image": "street.png", "width": W, "height": H_IMG,
            "K": [[INTR.fx, 0, INTR.cx], [0, INTR.fy, INTR.cy], [0, 0, 1]], "objects": objects}
    if with_pose:
        meta.update(gravity_cam=g.tolist(), camera_height=HEIGHT)
    (folder / "street.json").write_text(json.dumps(meta))
    return centres


def _shot(folder: Path):
    from console.link.sim import SimRobot

    robot = SimRobot(captures=folder, manual_clock=True)
    robot.connect()
    try:
        return robot.capture()
    finally:
        robot.close()


def _map(shot, mount: CameraMount | None = None):
    from console.session.mapping_job import ground_truth_bundle_for
    from pipeline.mapper import Mapper

    with Mapper(ground_truth_bundle_for(shot), default_catalog()) as mapper:  # as the console's MappingJob calls it
        return mapper.run(shot.image, shot.intrinsics, mount or shot.mount, shot.robot_pose, capture_id="c")


def _rel_errors(result, centres: list[np.ndarray]) -> list[float]:
    out = []
    for o in result.objects:
        true = min(centres, key=lambda c: float(np.linalg.norm(c - o.center_cam)))
        out.append(float(np.linalg.norm(o.center_cam - true) / np.linalg.norm(true)))
    return out


def test_a_folder_photo_without_gravity_fits_its_pose_from_the_floor(tmp_path: Path) -> None:
    centres = _street(tmp_path, with_pose=False)
    shot = _shot(tmp_path)
    assert shot.mount.assumed  # the robot's mount is only a stand-in for this photo
    res = _map(shot)
    note = res.scene.captures[0].models["camera_pose"]
    assert note.startswith("camera pose not given"), note
    pitch = float(re.search(r"pitch (-?[\d.]+) \+-", note).group(1))
    height = float(re.search(r"camera ([\d.]+) \+- [\d.]+ m up", note).group(1))
    assert abs(pitch - PITCH_DEG) < 1.5 and abs(height - HEIGHT) < 0.25, note
    assert len(res.objects) == len(PEOPLE) and float(np.median(_rel_errors(res, centres))) < 0.05
    # in the world frame the people stand on the floor
    bottoms = [o.position[2] - o.size[1] / 2 for o in res.scene.objects]
    assert max(abs(b) for b in bottoms) < 0.3, bottoms

    # the robot's mount taken as this photo's pose (what the console did): level and 0.35 m up, the people
    # land far off the floor and the photo's floor check has to cry out
    wrong = _map(shot, CameraMount(shot.mount.position, shot.mount.pitch, shot.mount.yaw, shot.mount.roll))
    assert "camera_pose_warning" in wrong.scene.captures[0].models
    assert max(abs(o.position[2] - o.size[1] / 2) for o in wrong.scene.objects) > 0.5


def test_a_folder_photo_with_gravity_keeps_its_given_pose(tmp_path: Path) -> None:
    _street(tmp_path, with_pose=True)
    shot = _shot(tmp_path)
    assert not shot.mount.assumed
    assert shot.mount.position[2] == pytest.approx(HEIGHT) and math.degrees(shot.mount.pitch) == pytest.approx(PITCH_DEG)
    note = _map(shot).scene.captures[0].models["camera_pose"]
    assert note.startswith("camera pose given; the photo agrees"), note
