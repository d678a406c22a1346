"""The Open Images SSD backend (real weights from ../shared/models when present) and the merged detector."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from pipeline.catalog import default_catalog
from pipeline.camera.image_io import read_image
from pipeline.models.base import Detection
from pipeline.models.nms import box_iou
from pipeline.models.ssd import MergedDetector, SsdDetector, preprocess

SHARED = Path(__file__).resolve().parents[3].parent / "shared"
SSD_DIR = SHARED / "models" / "oidv4_ssd"
PHOTO = SHARED / "bench" / "dev" / "scannet" / "scene0000_00_00000.jpg"


def test_preprocess_stretches_the_whole_image_to_minus_one_one() -> None:
    img = np.zeros((40, 100, 3), dtype=np.uint8)
    img[:, :50, 0] = 255
    x = preprocess(img)
    assert x.shape == (1, 3, 300, 300) and x.dtype == np.float32
    assert x[0, 0, :, :140].min() == pytest.approx(1.0) and x[0, 0, :, 160:].max() == pytest.approx(-1.0)


@pytest.mark.skipif(not (SSD_DIR / "oidv4_ssd.onnx").is_file() or not PHOTO.is_file(),
                    reason="../shared/models/oidv4_ssd or the dev photo not present")
def test_the_ssd_finds_the_scannet_table_coco_lacks() -> None:
    cat = default_catalog()
    det = SsdDetector.from_dir(SSD_DIR, threads=1)
    det.label_map = {l: e.name for l in det.labels[1:] if (e := cat.lookup(l)) is not None}
    assert det.label_map["Desk"] == "desk" and det.label_map["Computer monitor"] == "monitor"
    assert det.label_map["Box"] == "cardboard_box" and "Footwear" not in det.label_map
    image = read_image(PHOTO).image
    found = det.detect(image, cat.prompts())
    tables = [d for d in found if d.label == "table"]
    assert tables and tables[0].score > 0.5
    gt_table = np.array([[516.9, 366.6, 1239.4, 967.0]])  # the dev set's projected table box
    assert box_iou(np.array([tables[0].box]), gt_table)[0, 0] > 0.7
    assert all(d.score > det.score_threshold for d in found)
    assert det.vocabulary([("a desk", "desk"), ("a bed", "bed")]) == frozenset({"desk"})


class FakeDetector:
    def __init__(self, name: str, dets: list[Detection], classes: set[str]) -> None:
        self.name, self.dets, self.classes, self.score_threshold = name, dets, classes, 0.3
        self.input_size = (416, 416)

    def vocabulary(self, prompts):  # type: ignore[no-untyped-def]
        return frozenset(c for _, c in prompts if c in self.classes)

    def detect(self, image, prompts):  # type: ignore[no-untyped-def]
        return list(self.dets)


def test_merged_detections_keep_the_best_of_a_class_and_every_class() -> None:
    a = FakeDetector("yolox", [Detection((0, 0, 10, 10), 0.6, "chair", "chair"),
                               Detection((50, 50, 60, 70), 0.9, "person", "person")], {"chair", "person"})
    b = FakeDetector("ssd", [Detection((1, 0, 10, 10), 0.7, "chair", "Chair"),
                             Detection((0, 0, 10, 10), 0.5, "desk", "Desk")], {"chair", "desk"})
    m = MergedDetector(a, b)
    out = m.detect(np.zeros((100, 100, 3), np.uint8), [("x", "chair"), ("y", "desk"), ("z", "person")])
    assert [(d.label, d.prompt, d.score) for d in out] == [("person", "person", 0.9), ("chair", "Chair", 0.7),
                                                          ("desk", "Desk", 0.5)]
    assert m.vocabulary([("x", "chair"), ("y", "desk"), ("w", "bed")]) == frozenset({"chair", "desk"})
    assert m.name == "yolox+ssd (union)" and m.input_size == (416, 416)
