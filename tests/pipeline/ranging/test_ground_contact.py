"""Ground-contact ranging on synthetic pinhole geometry with known answers."""

from __future__ import annotations

import math

import numpy as np
import pytest

from pipeline.ranging.distance import DistanceError, Truncation
from pipeline.camera.geometry import Intrinsics, project
from pipeline.ranging.ground_contact import GroundModel, border_bound, floor_point, ground_contact_cue

INTR = Intrinsics(700.0, 700.0, 640.0, 360.0, 1280, 720)


def gravity(pitch_deg: float) -> tuple[float, float, float]:
    """Unit gravity in the camera frame of a camera pitched down by ``pitch_deg`` (no roll)."""
    p = math.radians(pitch_deg)
    return (0.0, math.cos(p), math.sin(p))


def standing_box(x: float, z_front: float, size: tuple[float, float, float], g: np.ndarray,
                 H: float) -> tuple[tuple[float, float, float, float], np.ndarray]:
    """2D box of an axis-aligned box (footprint faces the camera) whose front bottom edge is at lateral
    ``x`` and horizontal distance ``z_front`` on the floor; and its centre (camera frame)."""
    w, h, l = size
    down = np.asarray(g)
    fwd = np.cross(np.array([1.0, 0.0, 0.0]), down)  # horizontal forward
    right = np.array([1.0, 0.0, 0.0])
    floor0 = H * down  # the floor point under the camera
    corners = []
    for dx in (-w / 2, w / 2):
        for dz in (0.0, l):
            for up in (0.0, h):
                corners.append(floor0 + (x + dx) * right + (z_front + dz) * fwd - up * down)
    uv = project(np.array(corners), INTR)
    box = (float(uv[:, 0].min()), float(uv[:, 1].min()), float(uv[:, 0].max()), float(uv[:, 1].max()))
    centre = floor0 + x * right + (z_front + l / 2) * fwd - (h / 2) * down
    return box, centre


@pytest.mark.parametrize("pitch_deg", [0.0, 10.0, 25.0])
@pytest.mark.parametrize("dist", [3.0, 8.0, 20.0])
def test_contact_point_gives_the_true_centre_depth(pitch_deg: float, dist: float) -> None:
    g = np.array(gravity(pitch_deg))
    H = 1.4
    size = (0.6, 0.9, 0.6)
    box, centre = standing_box(0.4, dist, size, g, H)
    # the footprint faces the camera: its near edge is `l / 2` before the centre, known here exactly
    cue, c = ground_contact_cue(box, Truncation(), GroundModel(tuple(g), H), INTR, 0.3, 0.0, 0.45)  # type: ignore[misc]
    assert cue.distance == pytest.approx(centre[2], rel=2e-3)
    assert np.allclose(c[1:], centre[1:], atol=2e-3 * dist)
    # laterally the box-centre column is off by the perspective of the far edge (under 3 % of the distance; the mapper uses the depth)
    assert abs(c[0] - centre[0]) < 0.03 * dist


def test_sigma_grows_like_distance_squared_over_height_times_pitch_error() -> None:
    """Far away the pitch term dominates: sigma ~ d^2 / H * sigma_pitch (level camera)."""
    g = np.array(gravity(0.0))
    H, sp = 1.5, 0.01
    ground = GroundModel(tuple(g), H, sigma_pitch=sp, sigma_height=0.0, sigma_floor=0.0, sigma_px=0.0)
    sigmas = {}
    for d in (10.0, 20.0, 40.0):
        box, centre = standing_box(0.0, d, (0.5, 1.7, 0.5), g, H)
        cue, _ = ground_contact_cue(box, Truncation(), ground, INTR, 0.0, 0.0, 0.85)  # type: ignore[misc]
        expected = (d * d + H * H) / H * math.hypot(sp, 0.02 * (box[3] - box[1]) / INTR.fy)
        assert cue.sigma == pytest.approx(expected, rel=0.02)
        sigmas[d] = cue.sigma
    assert sigmas[20.0] / sigmas[10.0] == pytest.approx(4.0, rel=0.1)
    assert sigmas[40.0] / sigmas[20.0] == pytest.approx(4.0, rel=0.1)


def test_height_error_scales_the_distance() -> None:
    g = np.array(gravity(0.0))
    H = 1.0
    ground = GroundModel(tuple(g), H, sigma_pitch=0.0, sigma_height=0.05, sigma_floor=0.0, sigma_px=0.0)
    box, centre = standing_box(0.0, 5.0, (0.5, 1.0, 0.5), g, H)
    cue, _ = ground_contact_cue(box, Truncation(), ground, INTR, 0.0, 0.0, 0.5)  # type: ignore[misc]
    px_term = (25.0 + 1.0) / H * 0.02 * (box[3] - box[1]) / INTR.fy
    assert cue.sigma == pytest.approx(math.hypot(5.0 / H * 0.05, px_term), rel=0.02)


def test_a_cut_bottom_or_a_ray_above_the_horizon_gives_no_contact() -> None:
    g = gravity(0.0)
    ground = GroundModel(g, 1.2)
    assert ground_contact_cue((100, 100, 200, 719), Truncation(bottom=True), ground, INTR, 0.2, 0.1, 0.5) is None
    # bottom edge above the principal row of a level camera: the ray never meets the floor
    assert ground_contact_cue((100, 100, 200, 300), Truncation(), ground, INTR, 0.2, 0.1, 0.5) is None
    assert floor_point((640, 360), g, 1.2, INTR) is None
    p = floor_point((640, 360 + 700 * 0.3), g, 1.2, INTR)
    assert p is not None and p[2] == pytest.approx(4.0)


def test_border_bound_is_the_floor_at_the_last_row() -> None:
    g = np.array(gravity(5.0))
    H = 1.65
    ground = GroundModel(tuple(g), H)
    bound = border_bound((500, 300, 800, 720), 720, ground, INTR, 1.0, 0.2, 0.75)
    assert bound is not None
    floor = floor_point((650, 720), g, H, INTR)
    assert floor is not None
    # centre: one metre behind the floor point, 0.75 m up; its depth along the optical axis
    fwd = np.cross([1.0, 0.0, 0.0], g)
    assert bound[0] == pytest.approx(float(floor[2] + 1.0 * fwd[2] - 0.75 * g[2]), rel=1e-3)
    assert bound[1] > 0


def test_bad_ground_models_name_the_field() -> None:
    with pytest.raises(DistanceError, match="camera_height"):
        GroundModel((0.0, 1.0, 0.0), -1.0)
    with pytest.raises(DistanceError, match="gravity_cam"):
        GroundModel((0.0, 2.0, 0.0), 1.0)
    with pytest.raises(DistanceError, match="sigma_pitch"):
        GroundModel((0.0, 1.0, 0.0), 1.0, sigma_pitch=float("nan"))
    with pytest.raises(DistanceError, match="half_depth"):
        ground_contact_cue((0, 0, 10, 500), Truncation(), GroundModel((0.0, 1.0, 0.0), 1.0), INTR, -1.0, 0.0, 0.0)
