"""A floor plane seen over little floor is uncertain, and a wall's foot does not tilt it.

The console's Look around on the simulator (exact depth, exact pose) warned "the photo's floor
disagrees with the given camera pose by 4.3 sigma": facing a wall 1 m away, the lower image holds a
strip of floor and the wall's foot; the plane that kept both within the RANSAC tolerance was tilted
3-5 deg and claimed the 2-deg sigma of a whole floor. Boxes whose bottom a nearer box hides (a desk
behind a compressor) gave contacts above the horizon. A camera truly pitched down is still named.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from pipeline.camera.floor_fit import MIN_PLANE_ANGLE_SIGMA, plane_from_depth
from tests.pipeline.camera.test_floor_fit import INTR, gravity


def _floor_and_wall(wall_at: float, H: float = 0.35) -> np.ndarray:
    """Optical-axis depth [m] of a level camera ``H`` m over a floor, facing a wall ``wall_at`` m ahead."""
    g = gravity(0.0)
    v, u = np.mgrid[0:INTR.height, 0:INTR.width].astype(np.float64)
    r = np.stack([(u - INTR.cx) / INTR.fx, (v - INTR.cy) / INTR.fy, np.ones_like(u)], axis=-1)
    gr = r @ g
    floor = np.where(gr > 1e-6, H / np.maximum(gr, 1e-9), np.inf)
    return np.minimum(floor, wall_at)  # the wall is a plane z = wall_at in the camera frame


def _tilt_deg(plane) -> float:
    return math.degrees(math.acos(min(1.0, float(np.dot(plane.gravity_cam, gravity(0.0))))))


def test_a_wall_s_foot_does_not_tilt_the_floor() -> None:
    near = plane_from_depth(_floor_and_wall(1.2), INTR, (0.0, 1.0, 0.0))
    far = plane_from_depth(_floor_and_wall(12.0), INTR, (0.0, 1.0, 0.0))
    assert near is not None and far is not None
    assert _tilt_deg(near) < 0.5 and abs(near.camera_height - 0.35) < 0.01  # was 3-5 deg, 0.40-0.44 m
    assert _tilt_deg(far) < 0.5 and abs(far.camera_height - 0.35) < 0.01
    # exact depth: both at the depth model's floor of 2 deg; the height is measured where the points are
    assert near.sigma_angle == pytest.approx(MIN_PLANE_ANGLE_SIGMA) == far.sigma_angle
    assert 0.5 < near.support_point[2] < 1.2 and near.support_point[2] < far.support_point[2]


def test_a_noisy_strip_of_floor_widens_its_own_sigma() -> None:
    """A learned map's 5 % noise: a 1 m strip of floor before a wall is uncertain, a floor to 12 m is not."""
    planes = {}
    for wall in (1.0, 12.0):
        depth = _floor_and_wall(wall)
        noisy = depth * (1.0 + 0.05 * np.random.default_rng(3).standard_normal(depth.shape))
        planes[wall] = plane = plane_from_depth(noisy, INTR, (0.0, 1.0, 0.0))
        assert plane is not None
        assert _tilt_deg(plane) < 2 * math.degrees(plane.sigma_angle)  # its error within its own 2 sigma
    assert planes[12.0].sigma_angle == pytest.approx(MIN_PLANE_ANGLE_SIGMA)
    assert planes[1.0].sigma_angle > 2.5 * planes[12.0].sigma_angle


def _sim_map(sim_shot, gt_map, x: float, y: float, yaw_deg: float, pitch_deg: float = 0.0):
    """Map one simulator render at a robot pose, the camera mounted at ``pitch_deg`` but told level
    (the ``sim_shot`` and ``gt_map`` fixtures of tests/pipeline/conftest.py)."""
    from pipeline.camera.geometry import CameraMount

    return gt_map(sim_shot(x, y, 0.0, yaw_deg, mount=CameraMount(pitch=math.radians(pitch_deg))), CameraMount()).scene


# the start pose's look around (the warning was at heading 30 deg) and a wall of boxes 0.7 m ahead
LOOK = [(2.5, 0.7, 90.0 + 60.0 * i) for i in range(6)] + [(0.8, 5.2, 257.2), (1.0, 1.0, 247.1)]


@pytest.mark.parametrize("x, y, yaw_deg", LOOK)
def test_look_around_on_the_simulator_with_the_exact_pose_does_not_cry_wolf(sim_shot, gt_map, x: float, y: float,
                                                                           yaw_deg: float) -> None:
    from pipeline.camera.pose_check import floor_check

    scene = _sim_map(sim_shot, gt_map, x, y, yaw_deg)
    (capture,) = scene.captures
    assert "camera_pose_warning" not in capture.models, capture.models["camera_pose_warning"]
    assert not [w for w in floor_check(scene) if "disagrees" in w]
    assert "camera pose given" in capture.models["camera_pose"]


@pytest.mark.parametrize("x, y, yaw_deg", [(2.5, 0.7, 90.0), (2.5, 0.7, 270.0), (0.8, 5.2, 257.2)])
def test_a_camera_pitched_10_deg_but_told_level_is_still_named(sim_shot, gt_map, x: float, y: float,
                                                               yaw_deg: float) -> None:
    scene = _sim_map(sim_shot, gt_map, x, y, yaw_deg, pitch_deg=10.0)
    warning = scene.captures[0].models.get("camera_pose_warning")
    assert warning is not None and "disagrees with the given camera pose" in warning
    pitch = float(warning.split(": pitch ")[1].split(" deg")[0])
    assert 8.0 < pitch < 12.0 and "(given 0.0)" in warning or "(given -0.0)" in warning
