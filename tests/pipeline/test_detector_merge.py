"""Two detectors together: per-member tiling (each to its own input size, square windows for a detector
that stretches its input) and the class-aware merge (pipeline.models.tiled_detection, pipeline.models.ssd)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import cv2
import numpy as np
import pytest

from pipeline.models.base import Detection, ModelError
from pipeline.models.ssd import MergedDetector
from pipeline.models.tiled_detection import detect_planned, member_tile_px, tile_grid

SHARED = Path(__file__).resolve().parents[3] / "shared" / "models"
PROMPTS = [("a person", "person"), ("a car", "car"), ("a chair", "chair"), ("a table", "table"),
           ("a desk", "desk"), ("a box", "cardboard_box"), ("a bed", "bed")]


class BlobDetector:
    """Finds the white blobs of one class, like a real detector limited by its input resolution: a blob
    is seen only when it is at least 10 px at the scale of the ``input_size`` input. Records the shape of
    every image it is given."""

    def __init__(self, name: str, label: str, classes: set[str], input_size: tuple[int, int], *,
                 score: float = 0.9, threshold: float = 0.25, stretches: bool = False) -> None:
        self.name, self.label, self.classes, self.input_size = name, label, classes, input_size
        self.score, self.score_threshold, self.stretches_input = score, threshold, stretches
        self.seen: list[tuple[int, int]] = []

    def vocabulary(self, prompts: Any) -> frozenset[str]:
        return frozenset(c for _, c in prompts if c in self.classes)

    def detect(self, image_rgb: np.ndarray, prompts: Any) -> list[Detection]:
        h, w = image_rgb.shape[:2]
        self.seen.append((h, w))
        sy, sx = self.input_size[0] / h, self.input_size[1] / w
        if not self.stretches_input:
            sy = sx = min(sy, sx)
        n, _, stats, _ = cv2.connectedComponentsWithStats((image_rgb[:, :, 0] == 255).astype(np.uint8))
        return [Detection((float(x), float(y), float(x + bw), float(y + bh)), self.score, self.label, self.label)
                for x, y, bw, bh, _ in stats[1:n] if min(bw * sx, bh * sy) >= 10]


class FixedDetector:
    """Returns the same detections whatever the image."""

    def __init__(self, name: str, dets: list[Detection], classes: set[str], threshold: float) -> None:
        self.name, self.dets, self.classes, self.score_threshold = name, dets, classes, threshold

    def vocabulary(self, prompts: Any) -> frozenset[str]:
        return frozenset(c for _, c in prompts if c in self.classes)

    def detect(self, image_rgb: np.ndarray, prompts: Any) -> list[Detection]:
        return list(self.dets)


def det(box: tuple[float, float, float, float], score: float, label: str) -> Detection:
    return Detection(box, score, label, label)


# --- tiling per member --------------------------------------------------------------------------------


def test_square_tiles_cover_a_wide_image_with_squares_of_the_short_side() -> None:
    tiles = tile_grid(1242, 375, 624, overlap=0.2, square=True)
    covered = np.zeros((375, 1242), bool)
    for x0, y0, x1, y1 in tiles:
        assert x1 - x0 == 375 and y1 - y0 == 375
        covered[y0:y1, x0:x1] = True
    assert covered.all()
    assert {(x1 - x0, y1 - y0) for x0, y0, x1, y1 in tile_grid(1242, 375, 624)} == {(624, 375)}  # default: not square


def test_member_tile_side_follows_its_own_input_size_and_factor() -> None:
    a = BlobDetector("a", "person", {"person"}, (416, 416))
    b = BlobDetector("b", "desk", {"desk"}, (300, 300), stretches=True)
    assert member_tile_px(a, 1.5) == 624 and member_tile_px(b, 1.5) == 450
    b.tile_factor = None  # type: ignore[attr-defined]  # its own setting wins: no tiles
    assert member_tile_px(b, 1.5) is None
    assert member_tile_px(object(), 1.5) is None and member_tile_px(a, None) is None


def test_each_member_is_tiled_to_its_own_input_and_a_stretching_one_sees_square_windows() -> None:
    image = np.zeros((400, 1600, 3), np.uint8)
    image[300:324, 1400:1416, 0] = 255  # a small person: 16 x 24 px (10.7 px wide on a 150 px tile at 100 px)
    first = BlobDetector("yolo", "person", {"person"}, (100, 100))
    second = BlobDetector("ssd", "desk", {"desk"}, (100, 100), stretches=True)
    second.tile_factor = None  # type: ignore[attr-defined]
    merged = MergedDetector(first, second, policy="class_aware")
    found = detect_planned(merged, image, PROMPTS, tile_factor=1.5)
    # the first member: the whole image, then 150 px tiles (at that scale the 10 px blob is seen)
    assert first.seen[0] == (400, 1600) and set(first.seen[1:]) == {(150, 150)}
    assert [(d.label, d.box) for d in found] == [("person", (1400.0, 300.0, 1416.0, 324.0))]
    # the second: the whole image and square windows of the short side (400 px), no tiles of its own
    assert second.seen[0] == (400, 1600) and set(second.seen[1:]) == {(400, 400)} and len(second.seen) == 1 + 5


def test_a_stretching_detector_finds_a_wide_photos_object_only_in_square_windows() -> None:
    """Stretched whole, a 3.3:1 photo squeezes a 40 x 40 px box to 9.7 x 32 px at a 300 px input: too
    narrow. In a 375 px square window it is 32 x 32 px."""
    image = np.zeros((375, 1242, 3), np.uint8)
    image[200:240, 600:640, 0] = 255
    ssd = BlobDetector("ssd", "car", {"car"}, (300, 300), stretches=True)
    assert ssd.detect(image, PROMPTS) == []
    ssd.tile_factor = None  # type: ignore[attr-defined]
    found = detect_planned(ssd, image, PROMPTS, tile_factor=1.5)
    assert [d.box for d in found] == [(600.0, 200.0, 640.0, 240.0)]
    # a 4:3 photo is run whole only (within window_ratio 1.5)
    ssd.seen.clear()
    detect_planned(ssd, np.zeros((480, 640, 3), np.uint8), PROMPTS, tile_factor=1.5)
    assert ssd.seen == [(480, 640)]


# --- class-aware merge ---------------------------------------------------------------------------------


def yolox_like(dets: list[Detection]) -> FixedDetector:
    return FixedDetector("yolox", dets, {"person", "car", "chair", "table", "bed"}, 0.25)


def ssd_like(dets: list[Detection]) -> FixedDetector:
    return FixedDetector("ssd", dets, {"person", "car", "chair", "table", "desk", "cardboard_box"}, 0.3)


def test_roles_give_each_class_to_one_member() -> None:
    m = MergedDetector(yolox_like([]), ssd_like([]), policy="class_aware", second_owns={"table"})
    first, second = m.roles(PROMPTS)
    assert first == {"person", "car", "chair", "bed"}
    assert second == {"table", "desk", "cardboard_box"}
    union = MergedDetector(yolox_like([]), ssd_like([]))
    assert union.roles(PROMPTS) == ({"person", "car", "chair", "table", "bed"},
                                    {"person", "car", "chair", "table", "desk", "cardboard_box"})


def test_class_aware_merge_keeps_each_class_from_its_owner() -> None:
    a = yolox_like([det((0, 0, 10, 20), 0.6, "person"), det((100, 100, 200, 160), 0.5, "table")])
    b = ssd_like([det((1, 0, 10, 20), 0.7, "person"), det((300, 100, 400, 160), 0.35, "table"),
                  det((500, 100, 600, 160), 0.4, "cardboard_box"), det((20, 50, 40, 90), 0.45, "car")])
    m = MergedDetector(a, b, policy="class_aware", second_owns={"table"})
    out = m.detect(np.zeros((200, 700, 3), np.uint8), PROMPTS)
    assert [(d.label, d.score) for d in out] == [("person", 0.6), ("cardboard_box", 0.4), ("table", 0.35)]
    # the union keeps every class of both: the SSD's person wins its NMS on the raw score
    u = MergedDetector(a, b).detect(np.zeros((200, 700, 3), np.uint8), PROMPTS)
    assert [(d.label, d.score) for d in u] == [("person", 0.7), ("table", 0.5), ("car", 0.45), ("cardboard_box", 0.4),
                                               ("table", 0.35)]


def test_cross_member_duplicates_keep_the_one_further_above_its_own_threshold() -> None:
    # YOLOX chair 0.6 (threshold 0.25: margin 0.47) over an SSD desk 0.5 (0.3: margin 0.29): the chair stays
    a = yolox_like([det((0, 0, 100, 100), 0.6, "chair")])
    b = ssd_like([det((2, 0, 100, 100), 0.5, "desk")])
    out = MergedDetector(a, b, policy="class_aware").merge([a.dets, b.dets], PROMPTS)
    assert [d.label for d in out] == ["chair"]
    # SSD desk 0.66 (margin 0.514) over a YOLOX bed 0.55 (margin 0.400): the desk stays
    a = yolox_like([det((0, 0, 100, 100), 0.55, "bed")])
    b = ssd_like([det((0, 2, 100, 100), 0.66, "desk")])
    assert [d.label for d in MergedDetector(a, b, policy="class_aware").merge([a.dets, b.dets], PROMPTS)] == ["desk"]
    # a YOLOX bed 0.65 is below the desk's raw 0.66 but further above its own threshold (0.533): the bed stays
    a = yolox_like([det((0, 0, 100, 100), 0.65, "bed")])
    assert [d.label for d in MergedDetector(a, b, policy="class_aware").merge([a.dets, b.dets], PROMPTS)] == ["bed"]
    # boxes of different classes from ONE member are the mapper's business (same_object_iou), not the merge's
    a = yolox_like([det((0, 0, 100, 100), 0.6, "chair"), det((0, 0, 100, 98), 0.5, "bed")])
    assert len(MergedDetector(a, ssd_like([]), policy="class_aware").merge([a.dets, []], PROMPTS)) == 2
    # below same_object_iou both stay
    b = ssd_like([det((50, 0, 150, 100), 0.66, "desk")])
    a = yolox_like([det((0, 0, 100, 100), 0.6, "chair")])
    assert len(MergedDetector(a, b, policy="class_aware").merge([a.dets, b.dets], PROMPTS)) == 2


def test_merge_refuses_bad_settings_by_name() -> None:
    with pytest.raises(ModelError, match="MergedDetector.policy"):
        MergedDetector(yolox_like([]), ssd_like([]), policy="best")  # type: ignore[arg-type]
    with pytest.raises(ModelError, match="MergedDetector.same_object_iou"):
        MergedDetector(yolox_like([]), ssd_like([]), same_object_iou=1.5)
    with pytest.raises(ModelError, match="merge expects 2"):
        MergedDetector(yolox_like([]), ssd_like([])).merge([[]], PROMPTS)


# --- the offline set with the real models --------------------------------------------------------------

needs_models = pytest.mark.skipif(
    not all((SHARED / n).is_dir() for n in ("yolox_nano", "mobilesam", "fastdepth", "oidv4_ssd")),
    reason=f"real offline models (yolox_nano, mobilesam, fastdepth, oidv4_ssd) not in {SHARED}",
)


@needs_models
def test_offline_set_adds_the_ssd_when_present_and_says_so_when_absent(tmp_path: Path) -> None:
    from pipeline.catalog import Catalog
    from pipeline.mapper_config import MapperError, load_mapping_models

    catalog = Catalog.load()
    full = load_mapping_models("offline", SHARED, catalog)
    assert isinstance(full.detector, MergedDetector) and full.detector.policy == "class_aware"
    assert full.detector.name == "yolox_nano+oidv4_ssd (class-aware)" and not full.note
    first, second = full.detector.roles(catalog.prompts())
    assert {"desk", "cardboard_box", "table"} <= second and not ({"person", "car", "chair"} & second)
    assert {"person", "car", "chair"} <= first
    for name in ("yolox_nano", "mobilesam", "fastdepth"):  # a models folder without the SSD
        (tmp_path / name).symlink_to(SHARED / name, target_is_directory=True)
    alone = load_mapping_models("offline", tmp_path, catalog)
    assert alone.detector.name == "yolox_nano" and "oidv4_ssd" in alone.note and "models fetch oidv4_ssd" in alone.note
    assert load_mapping_models("offline-oidv4_ssd", SHARED, catalog).detector.name == "yolox_nano"
    assert load_mapping_models("offline+oidv4_ssd:union", SHARED, catalog).detector.policy == "union"
    with pytest.raises(MapperError, match="offline-owl"):
        load_mapping_models("offline-owl", SHARED, catalog)


@needs_models
def test_real_merge_finds_the_scannet_table_from_the_ssd_and_the_kitti_person_from_yolox() -> None:
    from pipeline.catalog import Catalog
    from pipeline.camera.image_io import read_image
    from pipeline.mapper_config import load_mapping_models
    from pipeline.models.nms import box_iou

    dev = SHARED.parent / "bench" / "dev"
    if not (dev / "scannet" / "scene0000_00_00000.jpg").is_file() or not (dev / "kitti" / "000000.png").is_file():
        pytest.skip(f"dev photos not in {dev}")
    catalog = Catalog.load()
    merged = load_mapping_models("offline", SHARED, catalog).detector
    prompts = catalog.prompts()
    room = detect_planned(merged, read_image(dev / "scannet" / "scene0000_00_00000.jpg").image, prompts, 1.5)
    tables = [d for d in room if d.label == "table"]
    assert tables and tables[0].prompt == "Table" and tables[0].score > 0.5  # the SSD's label, not COCO's
    assert box_iou(np.array([tables[0].box]), np.array([[516.9, 366.6, 1239.4, 967.0]]))[0, 0] > 0.7
    street = detect_planned(merged, read_image(dev / "kitti" / "000000.png").image, prompts, 1.5)
    people = [d for d in street if d.label == "person"]
    assert people and all(d.prompt == "person" for d in people)  # persons only from YOLOX (COCO label)
    assert box_iou(np.array([people[0].box]), np.array([[704, 153, 801, 309]]))[0, 0] > 0.6


def test_models_list_says_whether_the_offline_set_runs_the_ssd(tmp_path: Path) -> None:
    from pipeline.models.cli_support import models_list

    assert "offline also runs oidv4_ssd beside its detector when present: missing, so offline runs without it" \
        in models_list(tmp_path)
    (tmp_path / "oidv4_ssd").mkdir()
    for name in ("oidv4_ssd.onnx", "labelmap.txt"):
        (tmp_path / "oidv4_ssd" / name).write_bytes(b"x")
    assert models_list(tmp_path).endswith("offline also runs oidv4_ssd beside its detector when present: present")


def test_a_desk_and_a_table_on_one_object_are_one_detection() -> None:
    from pipeline.models.ssd import SAME_OBJECT_LABELS, suppress_same_object

    table = Detection((536, 468, 1221, 956), 0.66, "table", "Table")
    desk = Detection((523, 455, 1241, 945), 0.53, "desk", "Desk")  # the SSD on the ScanNet table: IoU 0.91
    other_desk = Detection((20, 250, 360, 850), 0.34, "desk", "Desk")  # elsewhere: stays
    chair = Detection((530, 460, 1220, 950), 0.5, "chair", "Chair")  # not in a group: stays
    out = suppress_same_object([desk, table, other_desk, chair], SAME_OBJECT_LABELS, 0.45)
    assert out == [table, other_desk, chair]
    assert suppress_same_object([desk, table], (), 0.45) == [desk, table]
    # the merge applies the member's groups to what its whole image, windows and tiles found together
    ssd = ssd_like([])
    ssd.same_object_labels = SAME_OBJECT_LABELS  # type: ignore[attr-defined]
    m = MergedDetector(yolox_like([]), ssd, policy="class_aware", second_owns={"table"})
    assert m.merge([[], [desk, table]], PROMPTS) == [table]
