"""Distance formulas and 3D placement on synthetic pinhole geometry with known answers."""

from __future__ import annotations

import math

import numpy as np
import pytest

from pipeline.ranging.distance import (
    DepthScale, DistanceError, Truncation, depth_fit_spread, expected_horizontal_extent, fit_depth_scale,
    fuse_distances, geometric_distance, inverse_variance_weights, mask_median_depth, truncation,
)
from pipeline.camera.geometry import Intrinsics, project
from pipeline.ranging.placement import (
    box_axes, box_corners, centre_on_ray, fit_box_to_2d, geometric_estimate, gravity_basis, heading_in_frame,
    visible_surface_offset,
)

INTR = Intrinsics(500.0, 520.0, 320.0, 240.0, 640, 480)


def projected_box(center: np.ndarray, axes: np.ndarray, size: tuple[float, float, float],
                  intr: Intrinsics = INTR) -> list[float]:
    uv = project(box_corners(center, axes, size), intr)
    return [float(uv[:, 0].min()), float(uv[:, 1].min()), float(uv[:, 0].max()), float(uv[:, 1].max())]


# --- truncation --------------------------------------------------------------------------------------


def test_truncation_flags_the_sides_near_the_border() -> None:
    assert truncation([100, 50, 200, 300], 640, 480) == Truncation()
    t = truncation([0, 50, 640, 479], 640, 480, margin_px=2)
    assert (t.left, t.top, t.right, t.bottom) == (True, False, True, True)
    assert t.horizontal_cut and t.vertical_cut
    assert truncation([2.5, 10, 50, 60], 640, 480, margin_px=3).left
    assert not truncation([3.5, 10, 50, 60], 640, 480, margin_px=3).left


@pytest.mark.parametrize("box", [[10, 10, 5, 20], [0, 0, 10], [0, float("nan"), 1, 2], "abcd"])
def test_bad_boxes_are_rejected(box: object) -> None:
    with pytest.raises(DistanceError):
        truncation(box, 640, 480)  # type: ignore[arg-type]


# --- size prior --------------------------------------------------------------------------------------


@pytest.mark.parametrize("z", [0.8, 3.0, 25.0])
def test_geometric_distance_recovers_depth_of_a_frontal_object(z: float) -> None:
    h, w = 1.2, 0.7
    # a fronto-parallel rectangle h x w at depth z, 0.3 m right of the axis
    top = project(np.array([[0.3, -h / 2, z], [0.3 + w, h / 2, z]]), INTR)
    box = [top[0, 0], top[0, 1], top[1, 0], top[1, 1]]
    g = geometric_distance(box, h, w, INTR.fx, INTR.fy)
    assert g is not None and g.axis == "vertical"
    assert g.distance == pytest.approx(z, rel=1e-9)


def test_geometric_distance_uses_the_uncut_dimension() -> None:
    z, h, w = 4.0, 3.0, 0.8
    # a tall object whose top (2.5 m above the optical axis) is outside the image
    full = project(np.array([[-w / 2, -2.5, z], [w / 2, 0.5, z]]), INTR)
    assert full[0, 1] < 0
    cut_box = [full[0, 0], 0.0, full[1, 0], full[1, 1]]
    tr = truncation(cut_box, 640, 480)
    assert tr.top and not tr.horizontal_cut
    naive = geometric_distance(cut_box, h, w, INTR.fx, INTR.fy)  # ignoring the cut: too far
    assert naive is not None and naive.distance > 1.2 * z
    g = geometric_distance(cut_box, h, w, INTR.fx, INTR.fy, tr)
    assert g is not None and g.axis == "horizontal"
    assert g.distance == pytest.approx(z, rel=1e-9)
    both = Truncation(left=True, top=True)
    assert geometric_distance(cut_box, h, w, INTR.fx, INTR.fy, both) is None
    assert geometric_distance(cut_box, h, None, INTR.fx, INTR.fy, tr) is None


def test_geometric_distance_rejects_bad_sizes() -> None:
    with pytest.raises(DistanceError, match="height_m"):
        geometric_distance([0, 0, 10, 10], 0.0, 1.0, 500, 500)
    with pytest.raises(DistanceError, match="fx"):
        geometric_distance([0, 0, 10, 10], 1.0, 1.0, -500, 500)


def test_expected_horizontal_extent_is_the_mean_over_yaw() -> None:
    w, l = 0.6, 1.9
    yaw = np.linspace(0, 2 * math.pi, 200001)
    mean = float(np.mean(w * np.abs(np.cos(yaw)) + l * np.abs(np.sin(yaw))))
    assert expected_horizontal_extent(w, l) == pytest.approx(mean, rel=1e-4)


# --- depth map ---------------------------------------------------------------------------------------


def test_mask_median_depth_ignores_invalid_values() -> None:
    depth = np.full((4, 5), 7.0, dtype=np.float32)
    depth[1, 1:4] = [2.0, 3.0, 4.0]
    depth[2, 1:4] = [np.nan, np.inf, 0.0]
    depth[3, 1] = -1.0
    mask = np.zeros((4, 5), dtype=bool)
    mask[1:4, 1:4] = True
    assert mask_median_depth(depth, mask) == pytest.approx(4.0)  # the valid values 2, 3, 4, 7, 7
    only_invalid = np.zeros((4, 5), dtype=bool)
    only_invalid[2, 1:4] = True
    assert mask_median_depth(depth, only_invalid) is None
    assert mask_median_depth(depth, np.zeros((4, 5), bool)) is None
    with pytest.raises(DistanceError, match="same H x W"):
        mask_median_depth(depth, np.ones((4, 4), bool))


def test_relative_scale_fit_ignores_an_outlier() -> None:
    z = np.array([1.5, 2.0, 3.0, 4.5, 6.0])
    values = z / 2.5  # relative depth = z / 2.5
    values[2] *= 3.0  # one badly wrong reading
    fit = fit_depth_scale(values, z, "relative")
    assert fit is not None
    assert fit.scale == pytest.approx(2.5, rel=1e-9)
    assert (fit.n_refs, fit.n_inliers) == (5, 4)
    assert fit.to_metric(values[0]) == pytest.approx(1.5)


def test_inverse_depth_fit_recovers_scale_and_shift_despite_outliers() -> None:
    rng = np.random.default_rng(3)
    z = rng.uniform(1.0, 12.0, size=10)
    s, t = 0.8, 0.05  # 1/z = s * v + t  ->  v = (1/z - t) / s
    v = (1.0 / z - t) / s
    v[[1, 6]] *= [2.0, 0.4]  # two outliers
    fit = fit_depth_scale(v, z, "inverse_relative")
    assert fit is not None
    assert fit.scale == pytest.approx(s, rel=1e-6)
    assert fit.shift == pytest.approx(t, abs=1e-6)
    assert fit.n_inliers == 8
    good = np.delete(np.arange(10), [1, 6])
    assert np.allclose(fit.to_metric(v[good]), z[good])


def test_inverse_depth_with_one_reference_fits_scale_only() -> None:
    fit = fit_depth_scale([0.25], [8.0], "inverse_relative")
    assert fit is not None and fit.shift == 0.0
    assert fit.to_metric(0.25) == pytest.approx(8.0)
    assert fit.to_metric(0.5) == pytest.approx(4.0)  # twice the disparity: half the depth


def test_scale_fit_without_valid_references() -> None:
    assert fit_depth_scale([], [], "metric") is None
    assert fit_depth_scale([0.0, np.nan], [2.0, 3.0], "relative") is None
    with pytest.raises(DistanceError, match="depth kind"):
        fit_depth_scale([1.0], [1.0], "disparity")  # type: ignore[arg-type]
    with pytest.raises(DistanceError, match="same length"):
        fit_depth_scale([1.0, 2.0], [1.0], "metric")


def test_depth_scale_to_metric_marks_impossible_values() -> None:
    inv = DepthScale("inverse_relative", 1.0, -0.5)
    assert math.isnan(inv.to_metric(0.2))  # 1/z = -0.3: no positive depth
    assert inv.to_metric(1.0) == pytest.approx(2.0)
    assert math.isnan(DepthScale("metric", 2.0).to_metric(0.0))


def test_depth_fit_spread_measures_disagreement() -> None:
    z = np.array([2.0, 3.0, 4.0, 5.0, 6.0])
    exact = depth_fit_spread(z, z, DepthScale("metric", 1.0))
    assert exact == pytest.approx(0.0, abs=1e-12)
    noisy = z * np.exp([0.2, -0.2, 0.2, -0.2, 0.0])
    spread = depth_fit_spread(noisy, z, DepthScale("metric", 1.0))
    assert spread == pytest.approx(1.4826 * 0.2, rel=1e-6)
    assert depth_fit_spread(z[:2], z[:2], DepthScale("metric", 1.0)) is None


def test_inverse_variance_weights() -> None:
    wg, wd = inverse_variance_weights(0.1, 0.2)
    assert (wg, wd) == pytest.approx((0.8, 0.2))  # the paper's weights are sigma_d = 2 sigma_g


# --- fusion ------------------------------------------------------------------------------------------


def test_fusion_follows_the_paper() -> None:
    f = fuse_distances(5.0, 10.0)
    assert f is not None and f.method == "fused" and f.distance == pytest.approx(6.0)
    f = fuse_distances(5.0, 10.0, 0.5, 0.5)
    assert f is not None and f.distance == pytest.approx(7.5)
    d = fuse_distances(None, 9.0)
    assert d is not None and (d.method, d.distance) == ("depth", 9.0)
    g = fuse_distances(4.0, None)
    assert g is not None and (g.method, g.distance) == ("geometric", 4.0)
    assert fuse_distances(None, None) is None
    assert fuse_distances(float("nan"), -1.0) is None


def test_fusion_gate_drops_a_depth_reading_far_from_the_size_prior() -> None:
    kept = fuse_distances(10.0, 13.0, gate=math.log(1.5))
    assert kept is not None and kept.method == "fused"
    dropped = fuse_distances(10.0, 40.0, gate=math.log(1.5))
    assert dropped is not None and (dropped.method, dropped.distance) == ("geometric", 10.0)


def test_fusion_rejects_bad_weights() -> None:
    with pytest.raises(DistanceError, match="weights"):
        fuse_distances(1.0, 2.0, 0.0, 0.0)
    with pytest.raises(DistanceError, match="weights"):
        fuse_distances(1.0, 2.0, -0.2, 1.2)


# --- placement ---------------------------------------------------------------------------------------


def test_centre_on_ray_pushes_along_the_ray() -> None:
    uv = (420.0, 240.0)
    c = centre_on_ray(uv, 5.0, 1.0, INTR)
    ray = np.array([100.0 / 500.0, 0.0, 1.0])
    ray /= np.linalg.norm(ray)
    surface = np.array([1.0, 0.0, 5.0])
    assert np.allclose(c, surface + ray)
    assert np.allclose(project(c[None], INTR)[0], uv)
    with pytest.raises(DistanceError):
        centre_on_ray(uv, -1.0, 0.2, INTR)


def test_gravity_basis_is_orthonormal_and_follows_gravity() -> None:
    g = np.array([0.1, 0.95, 0.3])
    e1, down, e3 = gravity_basis(g)
    basis = np.stack([e1, down, e3])
    assert np.allclose(basis @ basis.T, np.eye(3))
    assert np.allclose(down, g / np.linalg.norm(g))
    axes = box_axes(0.7, g)
    assert np.allclose(axes @ axes.T, np.eye(3))
    assert abs(float(axes[0] @ down)) < 1e-12  # the length axis is horizontal


def test_visible_surface_of_a_box_seen_square_on() -> None:
    axes = box_axes(0.0, [0.0, 1.0, 0.0])  # length along x, width along z (towards the camera)
    size = (0.8, 1.0, 2.0)  # w, h, l
    assert visible_surface_offset([0.0, 0.0, 5.0], axes, size) == pytest.approx(0.4)
    # seen steeply from above (camera 5 m higher), the top face fills most of the mask: the
    # median depth is about the centre's
    steep = visible_surface_offset([0.0, 5.0, 2.0], axes, size)
    assert 0.0 <= steep < 0.15


def _synthetic_boxes(n: int, seed: int) -> list[tuple[np.ndarray, np.ndarray, tuple[float, float, float], list[float], np.ndarray]]:
    """Boxes on a floor 1.2 m below a camera pitched down 9-29 degrees: (centre, axes, size, 2D box, gravity)."""
    rng = np.random.default_rng(seed)
    out = []
    while len(out) < n:
        pitch = rng.uniform(0.15, 0.5)
        g = np.array([0.0, math.cos(pitch), math.sin(pitch)])
        size = tuple(float(v) for v in rng.uniform(0.4, 1.5, 3))
        _, down, _ = gravity_basis(g)
        z = rng.uniform(2.5, 6.0)
        c = np.array([rng.uniform(-0.2, 0.2) * z, 0.0, z])
        c = c - down * float(c @ down) + down * (1.2 - size[1] / 2)
        axes = box_axes(rng.uniform(0, math.pi), g)
        box = projected_box(c, axes, size)  # type: ignore[arg-type]
        if any(truncation(box, 640, 480).sides):
            continue
        out.append((c, axes, size, box, g))
    return out  # type: ignore[return-value]


def test_box_fit_finds_boxes_seen_from_above_better_than_the_plain_formula() -> None:
    fit_err, ray_err = [], []
    for c, _, size, box, g in _synthetic_boxes(30, seed=0):
        fit = geometric_estimate(box, size, INTR, Truncation(), g, "box_fit")
        ray = geometric_estimate(box, size, INTR, Truncation(), g, "ray")
        assert fit is not None and fit.method == "box_fit" and ray is not None and ray.method == "ray"
        fit_err.append(np.linalg.norm(fit.center - c) / np.linalg.norm(c))
        ray_err.append(np.linalg.norm(ray.center - c) / np.linalg.norm(c))
    # the box's top face makes h_px too large: the plain formula reads boxes seen from above too near
    assert np.median(fit_err) < 0.04
    assert np.mean(fit_err) < 0.6 * np.mean(ray_err)


def test_box_fit_uses_the_cut_side_as_a_bound() -> None:
    g = np.array([0.0, math.cos(0.2), math.sin(0.2)])
    size = (1.8, 1.5, 4.2)  # a car
    axes = box_axes(0.3, g)
    c = np.array([-3.2, 0.9, 7.0])
    box = projected_box(c, axes, size)
    assert box[0] < 0  # the car sticks out of the left border
    cut = [0.0, box[1], box[2], box[3]]
    tr = truncation(cut, 640, 480)
    assert tr.left and not (tr.top or tr.right or tr.bottom)
    fit = fit_box_to_2d(cut, size, g, INTR, tr)
    assert fit is not None and fit.n_edges == 3
    assert np.linalg.norm(fit.center - c) / np.linalg.norm(c) < 0.08
    # cut on both axes: no size-prior estimate at all
    assert fit_box_to_2d([0.0, 0.0, box[2], box[3]], size, g, INTR, Truncation(left=True, top=True)) is None


def test_box_fit_rejects_bad_input() -> None:
    with pytest.raises(DistanceError, match="size"):
        fit_box_to_2d([10, 10, 50, 80], (1.0, -1.0, 1.0), [0, 1, 0], INTR)
    with pytest.raises(DistanceError, match="gravity"):
        fit_box_to_2d([10, 10, 50, 80], (1.0, 1.0, 1.0), [0, 0, 0], INTR)
    with pytest.raises(DistanceError, match="placement"):
        geometric_estimate([10, 10, 50, 80], (1.0, 1.0, 1.0), INTR, method="magic")


def test_heading_in_a_z_up_frame() -> None:
    # camera looking along world +x (level): optical x (right) is world -y
    R_world_cam = np.array([[0.0, 0.0, 1.0], [-1.0, 0.0, 0.0], [0.0, -1.0, 0.0]])
    assert heading_in_frame([0.0, 0.0, 1.0], R_world_cam) == pytest.approx(0.0)
    assert heading_in_frame([1.0, 0.0, 0.0], R_world_cam) == pytest.approx(-math.pi / 2)
