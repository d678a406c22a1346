"""Hovering captures with the exact pose give no false "Check the camera pose" warning.

A level camera 1-2.5 m up sees the floor only far away, or sees a line of boxes' faces and tops: the
floor check took the points of one image row (which lie on a plane through the camera centre whatever
the scene) for a floor tilted 14 deg, and box tops for the floor. A camera truly pitched 10 deg but
told level is still named.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from pipeline.camera.floor_fit import plane_from_depth
from tests.pipeline.camera.test_floor_fit import INTR, gravity

EXAMPLES_OFFICE = "examples/worlds/office.world.json"


def _level_floor(H: float) -> np.ndarray:
    """Optical-axis depth [m] of a level camera ``H`` m over a floor (inf above the horizon)."""
    v, u = np.mgrid[0:INTR.height, 0:INTR.width].astype(np.float64)
    r = np.stack([(u - INTR.cx) / INTR.fx, (v - INTR.cy) / INTR.fy, np.ones_like(u)], axis=-1)
    gr = r @ gravity(0.0)
    return np.where(gr > 1e-6, H / np.maximum(gr, 1e-9), np.inf)


def test_one_image_row_of_points_is_no_floor() -> None:
    depth = np.full((INTR.height, INTR.width), np.nan)
    floor = _level_floor(2.0)
    row = int(INTR.height * 0.95)
    depth[row - 2:row + 3] = floor[row - 2:row + 3]  # a strip of floor seen under a box line, one lattice row
    assert plane_from_depth(depth, INTR, (0.0, 1.0, 0.0)) is None
    assert plane_from_depth(floor, INTR, (0.0, 1.0, 0.0)) is not None  # the whole floor is


def test_box_tops_with_the_floor_seen_past_them_are_not_the_floor() -> None:
    """A level camera 2 m up over boxes 1.2 m high up to 4 m ahead, the floor past them."""
    H, top = 2.0, 1.2
    floor = _level_floor(H)
    on_top = floor * (H - top) / H
    depth = np.where(on_top <= 4.0, on_top, floor)
    plane = plane_from_depth(depth, INTR, (0.0, 1.0, 0.0))
    # without the below-penalty and check: the box tops, 0.66 m under the camera, tilted 3.3 deg
    assert plane is None or abs(plane.camera_height - H) < 0.05, plane


def _hover(sim_shot, gt_map, world: str | None, x: float, y: float, z: float, yaw_deg: float,
           pitch_deg: float = 0.0):
    """Map one simulator render with the robot hovering at ``(x, y, z)``, the camera mounted at
    ``pitch_deg`` but told level (ground-truth perception; the fixtures of tests/pipeline/conftest.py)."""
    import json

    from pipeline.camera.geometry import CameraMount
    from pipeline.scene_json import scene_from_dict

    kw = {}
    if world is not None:
        from pathlib import Path
        d = json.loads((Path(__file__).resolve().parents[3] / world).read_text())
        kw = dict(world=scene_from_dict(d["scene"]), room=(d["room"]["min"], d["room"]["max"]))
    shot = sim_shot(x, y, z, yaw_deg, mount=CameraMount(pitch=math.radians(pitch_deg)), **kw)
    return gt_map(shot, CameraMount()).scene


# (0.12, 0.12, 0.88) facing +y: the search's hover along a wall ("disagrees ... by 6.0 sigma: pitch 11.7 deg,
# camera 1.75 m (given 1.23 m)"); (2.5, 3.5, 1.0) facing the box line (4.1 sigma, pitch -14.1 deg)
HOVER = [(None, 0.12, 0.12, 0.88, 90.0), (None, 2.5, 3.5, 1.0, 90.0), (None, 1.5, 3.0, 1.5, 90.0), (None, 3.5, 3.3, 2.0, 90.0),
         (None, 2.5, 5.0, 1.9, 270.0), (None, 2.5, 4.5, 1.9, 90.0), (None, 1.2, 5.0, 2.5, 300.0),
         (EXAMPLES_OFFICE, 3.0, 0.5, 1.0, 90.0), (EXAMPLES_OFFICE, 3.0, 0.5, 2.0, 90.0),
         (EXAMPLES_OFFICE, 3.0, 6.0, 1.9, 270.0), (EXAMPLES_OFFICE, 4.5, 4.0, 1.2, 150.0)]


@pytest.mark.parametrize("world, x, y, z, yaw_deg", HOVER)
def test_hovering_with_the_exact_pose_gives_no_pose_warning(sim_shot, gt_map, world, x, y, z, yaw_deg) -> None:
    scene = _hover(sim_shot, gt_map, world, x, y, z, yaw_deg)
    (capture,) = scene.captures
    assert "camera_pose_warning" not in capture.models, capture.models["camera_pose_warning"]
    assert "camera pose given" in capture.models["camera_pose"]


@pytest.mark.parametrize("world, x, y, z, yaw_deg", [(None, 2.5, 3.5, 1.9, 90.0), (EXAMPLES_OFFICE, 3.0, 0.5, 1.9, 90.0)])
def test_a_hovering_camera_pitched_10_deg_but_told_level_is_still_named(sim_shot, gt_map, world, x, y, z,
                                                                         yaw_deg) -> None:
    scene = _hover(sim_shot, gt_map, world, x, y, z, yaw_deg, pitch_deg=10.0)
    warning = scene.captures[0].models.get("camera_pose_warning")
    assert warning is not None and "disagrees with the given camera pose" in warning
    pitch = float(warning.split(": pitch ")[1].split(" deg")[0])
    assert 8.0 < pitch < 12.0, warning
