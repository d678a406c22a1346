"""A floor-standing object is at least as tall as the photo shows (pipeline/ranging/measured_height.py), on
synthetic pinhole geometry with known answers."""

from __future__ import annotations

import math

import numpy as np
import pytest

from pipeline.catalog import default_catalog
from pipeline.ranging.distance import DistanceError
from pipeline.camera.geometry import Intrinsics, Pose, mount_from_gravity_height, project
from pipeline.models.ground_truth import GroundTruthBundle, GroundTruthDetector
from pipeline.mapper import Mapper, MapperConfig
from pipeline.ranging.measured_height import estimate_height, top_height

INTR = Intrinsics(600.0, 600.0, 640.0, 360.0, 1280, 720)
H = 1.2  # camera height [m]


def gravity(pitch_deg: float) -> np.ndarray:
    """Unit gravity (camera frame) of a camera pitched down by ``pitch_deg``."""
    p = math.radians(pitch_deg)
    return np.array([0.0, math.cos(p), math.sin(p)])


def standing(x: float, z_front: float, size: tuple[float, float, float], g: np.ndarray):  # type: ignore[no-untyped-def]
    """2D box [px] (unclipped) and camera-frame centre [m] of a box standing on the floor, its front
    face ``z_front`` ahead (horizontally), facing the camera."""
    w, h, l = size
    fwd = np.cross(np.array([1.0, 0.0, 0.0]), g)
    floor0 = H * g
    corners = [floor0 + (x + dx) * np.array([1.0, 0.0, 0.0]) + (z_front + dz) * fwd - up * g
               for dx in (-w / 2, w / 2) for dz in (0.0, l) for up in (0.0, h)]
    uv = project(np.array(corners), INTR)
    box = (float(uv[:, 0].min()), float(uv[:, 1].min()), float(uv[:, 0].max()), float(uv[:, 1].max()))
    return box, floor0 + x * np.array([1.0, 0.0, 0.0]) + (z_front + l / 2) * fwd - (h / 2) * g


@pytest.mark.parametrize("pitch_deg", [0.0, 15.0])
@pytest.mark.parametrize("size", [(0.6, 1.9, 0.5), (1.4, 0.75, 0.7)])  # a wardrobe above the camera, a desk below
def test_the_top_edge_gives_the_height_above_the_floor(pitch_deg: float, size: tuple[float, float, float]) -> None:
    g = gravity(pitch_deg)
    box, centre = standing(0.3, 3.0, size, g)
    top = top_height(box[1], 0.5 * (box[0] + box[2]), centre, size[2] / 2, INTR, g, H)
    assert top == pytest.approx(size[1], abs=0.03)


def test_a_cut_top_is_a_lower_bound_and_an_uncut_top_keeps_the_catalog() -> None:
    g = gravity(10.0)
    size = (0.6, 1.9, 0.5)
    box, centre = standing(0.0, 1.0, size, g)
    assert box[1] < 0  # the top is out of the photo
    cut = (box[0], 0.0, box[2], box[3])
    visible = top_height(0.0, 0.5 * (box[0] + box[2]), centre, 0.25, INTR, g, H)
    assert visible is not None and 0.9 < visible < 1.9
    est = estimate_height(cut, True, centre, 0.05, 0.25, 0.9, 0.5, INTR, g, H)
    # the class prior (0.9 m +- 50 %) given "at least `visible`": above the bound, within the prior's tail
    assert est.how == "at_least_visible" and visible < est.height < visible * 1.4 and 0 < est.sigma < 0.5 * est.height
    rng = np.random.default_rng(0)  # Monte Carlo of the same posterior (log-normal prior, uncertain bound)
    prior = np.exp(rng.normal(math.log(0.9), 0.5, 2_000_000))
    bound = visible + rng.normal(0.0, est_sigma_top(cut, centre, g), prior.size)
    kept_h = prior[prior >= bound]
    assert est.height == pytest.approx(float(np.exp(np.log(kept_h).mean())), rel=0.03)
    # an uncut top keeps the catalog's height (an uncut edge of a loose box is too noisy a height)
    kept = estimate_height(box, False, centre, 0.05, 0.25, 0.9, 0.5, INTR, g, H)
    assert kept.how == "catalog" and kept.height == 0.9 and kept.top == pytest.approx(1.9, abs=0.05)
    # a cut top well below the catalog's height changes little
    low = estimate_height(cut, True, centre, 0.05, 0.25, 3.5, 0.2, INTR, g, H)
    assert low.how == "catalog" and low.height == pytest.approx(3.5, rel=0.01)


def est_sigma_top(box: tuple[float, float, float, float], centre: np.ndarray, g: np.ndarray) -> float:
    """The bound's sigma [m] the module documents, for the Monte Carlo above (rel 0.05, half depth 0.25)."""
    top = top_height(box[1], 0.5 * (box[0] + box[2]), centre, 0.25, INTR, g, H)
    assert top is not None
    d = float(np.linalg.norm(centre))
    slope = abs(H - top) / d
    return math.sqrt((slope * d * 0.05) ** 2 + (slope * 0.25) ** 2 + (1.5 / INTR.fy * d) ** 2)


@pytest.mark.parametrize("key, kwargs", [
    ("catalog_height", {"catalog_height": 0.0}),
    ("camera_height", {"camera_height": float("nan")}),
    ("spread_h", {"spread_h": -0.1}),
    ("rel_sigma", {"rel_sigma": float("inf")}),
])
def test_bad_inputs_name_the_field(key: str, kwargs: dict[str, float]) -> None:
    args = {"box": (0.0, 0.0, 10.0, 10.0), "top_cut": True, "centre_cam": (0.0, 0.0, 3.0), "rel_sigma": 0.05,
            "half_depth": 0.2, "catalog_height": 0.9, "spread_h": 0.5, "intr": INTR,
            "gravity_cam": (0.0, 1.0, 0.0), "camera_height": H}
    args.update(kwargs)
    with pytest.raises(DistanceError, match=key):
        estimate_height(**args)  # type: ignore[arg-type]


def _map_wardrobe(config: MapperConfig):  # type: ignore[no-untyped-def]
    """A 2.0 m cabinet (the catalog says 0.9 m) 1.2 m ahead, its top beyond the photo's top border."""
    g = gravity(0.0)
    box, centre = standing(0.0, 1.2, (0.6, 2.0, 0.5), g)
    assert box[1] < 0  # the top is out of the photo
    cut = (box[0], 0.0, box[2], box[3])
    bundle = GroundTruthBundle(GroundTruthDetector([cut], ["cabinet"]), None, None)
    with Mapper(bundle, default_catalog(), config) as mapper:
        result = mapper.run(np.zeros((720, 1280, 3), dtype=np.uint8), INTR, mount_from_gravity_height(tuple(g), H),
                            Pose())
    (obj,) = result.objects
    return obj, centre, result.scene.objects[0]


def test_the_mapper_maps_a_cut_wardrobe_at_least_as_tall_as_seen_standing_on_the_floor() -> None:
    old, _, old_scene = _map_wardrobe(MapperConfig(measure_height=False))
    assert old.size[1] == pytest.approx(0.9) and old_scene.size[1] == pytest.approx(0.9)
    new, centre, scene_obj = _map_wardrobe(MapperConfig())
    assert new.height is not None and new.height.how == "at_least_visible"
    # at least what the photo shows (the top border's ray at the cabinet), and about the true 2.0 m
    assert new.height.top is not None and scene_obj.size[1] > new.height.top > 1.5
    assert scene_obj.size[1] == pytest.approx(2.0, abs=0.3) and new.size[1] == pytest.approx(scene_obj.size[1])
    # standing on the floor (camera frame, level camera: y down, the floor at y = H): centre h / 2 up
    assert H - new.center_cam[1] == pytest.approx(new.size[1] / 2, abs=1e-6)
    assert abs(new.center_cam[1] - centre[1]) < 0.15 < abs(old.center_cam[1] - centre[1])
