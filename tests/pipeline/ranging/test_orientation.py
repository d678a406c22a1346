"""Yaw from a partial point cloud: synthetic ground-plane points of known footprints and yaws."""

from __future__ import annotations

import math

import numpy as np
import pytest

from pipeline.camera.geometry import Intrinsics
from pipeline.ranging.orientation import (
    backproject_mask, fit_footprint_yaw, ground_plane_points, length_axis_from_points,
)
from pipeline.ranging.placement import box_axes, gravity_basis


def mod_pi_error(a: float, b: float) -> float:
    d = (a - b) % math.pi
    return min(d, math.pi - d)


def visible_faces(centre: tuple[float, float], yaw: float, w: float, l: float, viewer: tuple[float, float],
                  n: int = 200, noise: float = 0.0, top: bool = False, seed: int = 0) -> np.ndarray:
    """Ground-plane points [m] of the footprint sides (length ``l`` along ``yaw``) facing ``viewer``,
    plus the filled footprint (``top``: a top face seen from above)."""
    rng = np.random.default_rng(seed)
    c = np.asarray(centre, dtype=np.float64)
    a_l = np.array([math.cos(yaw), math.sin(yaw)])
    a_w = np.array([-math.sin(yaw), math.cos(yaw)])
    pts = []
    for normal, along, half_n, half_a in ((a_l, a_w, l / 2, w / 2), (a_w, a_l, w / 2, l / 2)):
        for s in (-1.0, 1.0):
            mid = c + s * half_n * normal
            if float((np.asarray(viewer) - mid) @ (s * normal)) > 0:  # side faces the viewer
                t = rng.uniform(-half_a, half_a, n)
                pts.append(mid + t[:, None] * along)
    if top:
        u, v = rng.uniform(-l / 2, l / 2, n), rng.uniform(-w / 2, w / 2, n)
        pts.append(c + u[:, None] * a_l + v[:, None] * a_w)
    p = np.concatenate(pts)
    return p + rng.normal(0.0, noise, p.shape) if noise > 0 else p


@pytest.mark.parametrize("yaw", [0.0, 0.3, 0.8, 1.2, 1.7, 2.5, 3.0])
@pytest.mark.parametrize("w,l", [(1.4, 0.7), (0.3, 0.65), (0.8, 0.42)])
def test_l_shaped_view_gives_the_yaw(yaw: float, w: float, l: float) -> None:
    pts = visible_faces((0.3, 4.0), yaw, w, l, viewer=(0.0, 0.0), noise=0.005, seed=int(10 * yaw))
    fit = fit_footprint_yaw(pts, (w, l))
    assert fit is not None
    assert mod_pi_error(fit.yaw, yaw) < math.radians(3.0)
    assert 0.0 <= fit.yaw < math.pi


@pytest.mark.parametrize("yaw", [0.2, 1.0, 2.2])
def test_top_face_and_sides_give_the_yaw(yaw: float) -> None:
    pts = visible_faces((-1.0, 3.0), yaw, 1.2, 0.6, viewer=(0.0, 0.0), noise=0.01, top=True)
    fit = fit_footprint_yaw(pts, (1.2, 0.6))
    assert fit is not None and mod_pi_error(fit.yaw, yaw) < math.radians(3.0)


def test_one_side_seen_square_on_is_assigned_by_its_length() -> None:
    """A single visible side: its direction is the length axis when it is as long as ``l``, else the
    width axis."""
    rng = np.random.default_rng(1)
    line = np.stack([rng.uniform(-0.7, 0.7, 300), np.full(300, 3.0)], axis=1)  # 1.4 m along x
    along = fit_footprint_yaw(line, (0.5, 1.4))  # l = 1.4: length axis along x
    across = fit_footprint_yaw(line, (1.4, 0.5))  # w = 1.4: length axis along y
    assert along is not None and mod_pi_error(along.yaw, 0.0) < math.radians(2.0)
    assert across is not None and mod_pi_error(across.yaw, math.pi / 2) < math.radians(2.0)


def test_too_few_or_degenerate_points_give_none() -> None:
    assert fit_footprint_yaw(np.zeros((10, 2)), (0.5, 1.0)) is None  # too few
    assert fit_footprint_yaw(np.full((200, 2), 2.0), (0.5, 1.0)) is None  # one point
    rng = np.random.default_rng(2)
    ring = rng.normal(size=(2000, 2))
    ring = 0.5 * ring / np.linalg.norm(ring, axis=1, keepdims=True)  # a circle: no preferred direction
    assert fit_footprint_yaw(ring, (1.0, 1.0)) is None
    with pytest.raises(ValueError):
        fit_footprint_yaw(ring, (0.0, 1.0))


def test_backprojection_and_ground_plane_of_a_level_camera() -> None:
    """A level camera (gravity = +y): a fronto-parallel wall at 2 m lies along e1 = camera x."""
    intr = Intrinsics(100.0, 100.0, 32.0, 24.0, 64, 48)
    depth = np.full((48, 64), 2.0)
    mask = np.zeros((48, 64), dtype=bool)
    mask[10:30, 5:60] = True
    pts = backproject_mask(mask, depth, intr, erode_px=0)
    assert pts.shape == (20 * 55, 3) and np.allclose(pts[:, 2], 2.0)
    assert np.allclose(pts[0], [(5.5 - 32) / 100 * 2, (10.5 - 24) / 100 * 2, 2.0])
    g = np.array([0.0, 1.0, 0.0])
    e1, down, e3 = gravity_basis(g)
    xy = ground_plane_points(pts, g)
    assert np.allclose(xy[:, 0], pts @ e1) and np.allclose(xy[:, 1], pts @ e3)
    assert np.ptp(xy[:, 1]) < 1e-9  # one depth: a line along e1


def test_length_axis_from_a_rendered_depth_map() -> None:
    """A box (w 1.2, l 0.6, h 0.5) at a known yaw about gravity, ray-cast into a tilted camera's exact
    depth: the fitted length axis is the box's."""
    intr = Intrinsics(300.0, 300.0, 160.0, 120.0, 320, 240)
    pitch = math.radians(25.0)  # camera looking down: gravity has a +z component
    g = np.array([0.0, math.cos(pitch), math.sin(pitch)])
    yaw = 0.7
    w, h, l = 1.2, 0.5, 0.6
    axes = box_axes(yaw, g)  # rows: length, down, width (camera frame)
    centre = np.array([0.2, 0.0, 3.0]) + 0.8 * g  # below the optical axis
    u, v = np.meshgrid(np.arange(320) + 0.5, np.arange(240) + 0.5)
    rays = np.stack([(u - 160) / 300, (v - 120) / 300, np.ones_like(u)], axis=-1)
    half = np.array([l, h, w]) / 2
    d_loc = rays @ axes.T
    o_loc = -(axes @ centre)
    with np.errstate(divide="ignore", invalid="ignore"):
        t1, t2 = (-half - o_loc) / d_loc, (half - o_loc) / d_loc
    t_near = np.nanmax(np.minimum(t1, t2), axis=-1)
    t_far = np.nanmin(np.maximum(t1, t2), axis=-1)
    hit = (t_near <= t_far) & (t_near > 0)
    depth = np.where(hit, t_near, 0.0)
    axis = length_axis_from_points(hit, depth, intr, g, (w, h, l))
    assert axis is not None
    assert abs(float(axis @ g)) < 1e-9  # horizontal
    assert abs(float(axis @ axes[0])) > math.cos(math.radians(3.0))
    assert length_axis_from_points(np.zeros_like(hit), depth, intr, g, (w, h, l)) is None
