"""A floor contact hidden by a nearer object: detected from the boxes, used as an upper bound only
when the contact reads farther than the other cues (pipeline/ranging/occlusion.py)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from pipeline.catalog import default_catalog
from pipeline.ranging.fusion import Cue
from pipeline.camera.geometry import Intrinsics, Pose, mount_from_gravity_height, project
from pipeline.models.ground_truth import GroundTruthBundle, GroundTruthDetector
from pipeline.mapper import Mapper, MapperConfig
from pipeline.models.base import DepthMap
from pipeline.ranging.occlusion import bottom_occluders, contact_as_bound, hides_bottom


def test_a_lower_box_spanning_the_bottom_edge_hides_it() -> None:
    nightstand = (100.0, 100.0, 160.0, 160.0)
    assert hides_bottom((80.0, 130.0, 300.0, 260.0), nightstand)  # the bed: lower and across the whole edge
    assert not hides_bottom((80.0, 162.0, 300.0, 260.0), nightstand)  # starts below the edge: the contact shows
    assert not hides_bottom((80.0, 130.0, 161.0, 161.0), nightstand)  # bottom level with it: not nearer
    assert not hides_bottom((140.0, 130.0, 300.0, 260.0), nightstand)  # covers a third of the edge only
    assert hides_bottom((120.0, 130.0, 300.0, 260.0), nightstand)  # two thirds: at least MIN_COVER
    assert not hides_bottom(nightstand, (80.0, 130.0, 300.0, 260.0))  # never the other way round


def test_bottom_occluders_pick_the_lowest_reaching_box() -> None:
    boxes = [(100.0, 100.0, 160.0, 160.0), (80.0, 130.0, 300.0, 200.0), (90.0, 140.0, 200.0, 240.0),
             (400.0, 0.0, 500.0, 50.0)]
    assert bottom_occluders(boxes) == [2, None, None, None]
    assert bottom_occluders([]) == []


@pytest.mark.parametrize("box", [(1.0, 2.0, 3.0), (1.0, 2.0, 0.5, 4.0), (0.0, 0.0, float("nan"), 1.0), "abcd"])
def test_bad_boxes_are_named(box: object) -> None:
    with pytest.raises(ValueError, match=r"boxes\[1\]"):
        bottom_occluders([(0.0, 0.0, 1.0, 1.0), box])  # type: ignore[list-item]


def test_only_a_contact_farther_than_the_other_cues_becomes_a_bound() -> None:
    sp, dp = Cue("size_prior", 5.0, 1.0), Cue("depth", 4.8, 1.2)
    far = Cue("ground_contact", 8.0, 0.5)
    cues, bound = contact_as_bound([sp, far, dp])
    assert [c.name for c in cues] == ["size_prior", "depth"] and bound == (8.0, 0.5)
    near = Cue("ground_contact", 4.0, 0.3)  # nearer than the others: an occlusion cannot explain it
    assert contact_as_bound([sp, near, dp]) == ([sp, near, dp], None)
    agree = Cue("ground_contact", 5.3, 0.3)  # farther, but within one combined sigma: measured
    assert contact_as_bound([sp, agree, dp]) == ([sp, agree, dp], None)
    assert contact_as_bound([far]) == ([far], None)  # nothing to compare with: kept
    assert contact_as_bound([sp, dp]) == ([sp, dp], None)


def test_others_that_disagree_among_themselves_cannot_turn_a_contact_into_a_bound() -> None:
    """A ScanNet cabinet behind a sofa: its top-cut size prior reads 1.8 m (+-34 %), the depth map 6.5 m
    (+-41 %), the contact 4.4 m (+-7 %; truth 4.9 m). Taken at their sigmas the two others put it 1.4 sigma
    nearer than the contact and the contact became a bound that dragged the cabinet to 2.3 m; they are
    2.4 sigma apart from each other, so they know less than their sigmas say (Birge ratio), and the
    contact is a measurement."""
    sp, dp = Cue("size_prior", 1.8, 0.34 * 1.8), Cue("depth", 6.47, 0.41 * 6.47)
    gc = Cue("ground_contact", 4.4, 0.07 * 4.4)
    assert contact_as_bound([sp, gc, dp]) == ([sp, gc, dp], None)
    # the same contact against two others that agree with each other is still a bound
    sp2, dp2 = Cue("size_prior", 2.6, 0.34 * 2.6), Cue("depth", 2.7, 0.41 * 2.7)
    cues, bound = contact_as_bound([sp2, gc, dp2])
    assert [c.name for c in cues] == ["size_prior", "depth"] and bound == (4.4, gc.sigma)


# --- the mapper on synthetic pinhole geometry -------------------------------------------------------
INTR = Intrinsics(600.0, 600.0, 640.0, 360.0, 1280, 720)
H = 1.2  # camera height [m], camera level
G = (0.0, 1.0, 0.0)


def _box(x: float, z_near: float, w: float, h: float, l: float) -> tuple[float, float, float, float]:
    """2D box [px] of an upright box standing on the floor, front face at depth ``z_near``."""
    corners = np.array([[x + dx, H - up, z_near + dz] for dx in (-w / 2, w / 2) for dz in (0.0, l) for up in (0.0, h)])
    uv = project(corners, INTR)
    return (float(uv[:, 0].min()), float(uv[:, 1].min()), float(uv[:, 0].max()), float(uv[:, 1].max()))


class _SurfaceDepth:
    """A metric (not exact) depth model: the given depth [m] inside each box, far wall elsewhere."""

    kind = "metric"

    def __init__(self, regions: list[tuple[tuple[float, float, float, float], float]]) -> None:
        self.regions = regions
        self.name = "synthetic depth"
        self.last_timings: dict[str, float] = {}

    def estimate(self, image_rgb: np.ndarray) -> DepthMap:
        d = np.full(image_rgb.shape[:2], 9.0, dtype=np.float32)
        for (x1, y1, x2, y2), z in self.regions:  # later (nearer) regions paint over earlier ones
            d[int(y1):int(math.ceil(y2)), int(x1):int(math.ceil(x2))] = z
        return DepthMap(d, "metric")


def _map_nightstand(with_bed: bool):  # type: ignore[no-untyped-def]
    """A tall nightstand (1.0 m; the catalog says 0.55 m) 4.5 m ahead whose lower 45 % a bed hides: the
    visible part is as tall as the catalog's, so the size prior is right and the contact reads far."""
    z_ns, ns = 4.5, (0.5, 1.0, 0.45)
    full = _box(0.3, z_ns, *ns)
    visible = (full[0], full[1], full[2], full[1] + 0.55 * (full[3] - full[1]))
    bed = _box(0.0, 2.4, 1.6, 0.8, 2.0)
    assert hides_bottom(bed, visible)
    boxes, labels = [visible], ["nightstand"]
    regions = [(visible, z_ns)]
    if with_bed:
        boxes.append(bed)
        labels.append("bed")
        regions.append((bed, 2.4))
    bundle = GroundTruthBundle(GroundTruthDetector(boxes, labels), None, _SurfaceDepth(regions))  # type: ignore[arg-type]
    image = np.zeros((720, 1280, 3), dtype=np.uint8)
    with Mapper(bundle, default_catalog(), MapperConfig()) as mapper:
        result = mapper.run(image, INTR, mount_from_gravity_height(G, H), Pose())
    (obj,) = [o for o in result.objects if o.detection.label == "nightstand"]
    (scene_obj,) = [o for o in result.scene.objects if o.label == "nightstand"]
    assert obj.cue("ground_contact") is not None
    key = "ground_contact_bound" if obj.contact_hidden_by else "ground_contact"  # the scene says how it was used
    assert scene_obj.source.distances[key] == pytest.approx(obj.cue("ground_contact").distance)  # type: ignore[union-attr]
    assert ({"ground_contact", "ground_contact_bound"} - {key}).isdisjoint(scene_obj.source.distances)
    truth_z = z_ns + ns[2] / 2
    return obj, abs(obj.fusion.distance - truth_z) / truth_z  # type: ignore[union-attr]


def test_a_contact_hidden_by_the_bed_bounds_the_distance_instead_of_deciding_it() -> None:
    alone, err_alone = _map_nightstand(with_bed=False)
    assert alone.contact_hidden_by is None and "ground_contact" in alone.fusion.used  # type: ignore[union-attr]
    hidden, err_hidden = _map_nightstand(with_bed=True)
    assert hidden.contact_hidden_by == "bed"
    assert "ground_contact" not in hidden.fusion.used and hidden.bound is None  # type: ignore[union-attr]
    assert err_hidden < 0.5 * err_alone, (err_alone, err_hidden)
    assert err_alone > 0.2  # without the bed in view the hidden contact misleads: nothing tells it apart
