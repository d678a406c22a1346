"""YOLOX backend: decoding on a tiny graph with a hand-made raw output, YOLOX-Nano on real photos."""

from __future__ import annotations

import json
import math
import time
from pathlib import Path

import numpy as np
import pytest
from onnx_fixtures import wrong_signature_model, yolox_model

from pipeline.camera.image_io import load_image
from pipeline.models.base import ModelError, ModelMissingError
from pipeline.models.yolox import DEFAULT_SCORE_THRESHOLD, YoloxDetector, decode, grid_and_strides, letterbox, read_labels

SHARED = Path(__file__).resolve().parents[3].parent / "shared"
YOLOX = SHARED / "models" / "yolox_nano"
DEV = SHARED / "bench" / "dev"

LABELS = [f"c{i}" for i in range(80)]
LABELS[0], LABELS[56], LABELS[57] = "person", "chair", "sofa"


def _anchor(size: int, stride: int, gx: int, gy: int) -> int:
    """Row of grid cell (gx, gy) of ``stride`` in the concatenated output (x fastest, stride 8 first)."""
    offset = sum((size // s) ** 2 for s in (8, 16, 32) if s < stride)
    return offset + gy * (size // stride) + gx


def _raw(size: int = 64) -> np.ndarray:
    n = sum((size // s) ** 2 for s in (8, 16, 32))
    raw = np.zeros((1, n, 85), np.float32)
    a = _anchor(size, 16, 1, 1)  # centre (16, 16) in the input, 16x16 box
    raw[0, a, :5] = (0.0, 0.0, 0.0, 0.0, 0.9)
    raw[0, a, 5 + 56] = 0.8  # chair: 0.72
    b = _anchor(size, 8, 2, 2)  # centre (18, 18), exp(0.7) * 8 = 16 px: IoU 0.6 with a, lower score
    raw[0, b, :5] = (0.25, 0.25, 0.7, 0.7, 0.8)
    raw[0, b, 5 + 56] = 0.5  # chair: 0.40 -> suppressed by NMS
    c = _anchor(size, 32, 1, 1)  # a person far from the chair: not in the label map
    raw[0, c, :5] = (0.0, 0.0, 0.0, 0.0, 0.95)
    raw[0, c, 5 + 0] = 0.95
    return raw


@pytest.fixture()
def tiny(tmp_path: Path) -> YoloxDetector:
    yolox_model(tmp_path / "yolox_nano.onnx", _raw(64), input_size=64)
    (tmp_path / "coco_classes.txt").write_text("\n".join(LABELS) + "\n")
    return YoloxDetector.from_dir(tmp_path, {"chair": "office_chair", "sofa": "sofa"}, threads=1)


def test_letterbox_is_top_left_bgr_with_114_padding() -> None:
    img = np.zeros((128, 256, 3), np.uint8)
    img[..., 0] = 200  # red
    t, r = letterbox(img, (64, 64))
    assert r == 0.25 and t.shape == (1, 3, 64, 64)
    assert t[0, 2, 0, 0] == 200 and t[0, 0, 0, 0] == 0  # BGR: red is channel 2
    assert np.all(t[0, :, 32:, :] == 114)  # below the 64x32 image


def test_grid_order_is_x_fastest_stride_8_first() -> None:
    grids, strides = grid_and_strides((64, 64))
    assert grids.shape == (84, 2) and strides[0, 0] == 8 and strides[-1, 0] == 32
    assert grids[1].tolist() == [1, 0] and grids[8].tolist() == [0, 1]


def test_decode_box_formula() -> None:
    boxes, scores = decode(_raw(64), (64, 64))
    a = _anchor(64, 16, 1, 1)
    assert boxes[a] == pytest.approx((8, 8, 24, 24))
    b = _anchor(64, 8, 2, 2)
    half = math.exp(0.7) * 8 / 2
    assert boxes[b] == pytest.approx((18 - half, 18 - half, 18 + half, 18 + half), abs=1e-4)
    assert scores[a, 56] == pytest.approx(0.72)
    with pytest.raises(ModelError, match="anchors"):
        decode(_raw(64), (96, 96))


def test_detect_maps_labels_and_runs_class_wise_nms(tiny: YoloxDetector) -> None:
    img = np.zeros((128, 256, 3), np.uint8)  # r = 0.25
    prompts = [("an office chair", "office_chair"), ("a sofa", "sofa"), ("a person", "pedestrian")]
    found = tiny.detect(img, prompts)
    assert len(found) == 1  # the overlapping chair is suppressed; the person is not in the label map
    (chair,) = found
    assert chair.label == "office_chair" and chair.prompt == "chair"
    assert chair.box == pytest.approx((32, 32, 96, 96))  # (8, 8, 24, 24) / 0.25
    assert chair.score == pytest.approx(0.72)
    assert tiny.vocabulary(prompts) == {"office_chair", "sofa"}
    assert tiny.detect(img, [("a sofa", "sofa")]) == []  # chair not asked for
    assert tiny.detect(img, []) == []


def test_score_threshold_keeps_only_boxes_above_it(tiny: YoloxDetector) -> None:
    img = np.zeros((128, 256, 3), np.uint8)
    chair = [("an office chair", "office_chair")]
    assert tiny.score_threshold == DEFAULT_SCORE_THRESHOLD == 0.25
    tiny.score_threshold = 0.71  # just below the chair's 0.72: kept
    assert [d.score for d in tiny.detect(img, chair)] == [pytest.approx(0.72)]
    tiny.score_threshold = 0.73
    assert tiny.detect(img, chair) == []
    tiny.score_threshold, tiny.nms_iou = 0.3, 0.9  # the second, overlapping chair (0.40) survives a lax NMS
    assert [round(d.score, 2) for d in tiny.detect(img, chair)] == [0.72, 0.4]


def test_errors(tmp_path: Path, tiny: YoloxDetector) -> None:
    with pytest.raises(ModelError, match="uint8"):
        tiny.detect(np.zeros((10, 10, 3), np.float64), [("chair", "office_chair")])
    with pytest.raises(ModelMissingError, match="morphonavi models fetch yolox_nano"):
        YoloxDetector.from_dir(tmp_path / "nothing")
    (tmp_path / "short.txt").write_text("a\nb\n")
    with pytest.raises(ModelError, match="80 classes but 2 labels"):
        YoloxDetector(tmp_path / "yolox_nano.onnx", read_labels(tmp_path / "short.txt"))
    wrong_signature_model(tmp_path / "bad.onnx")
    with pytest.raises(ModelError, match="missing input 'images'"):
        YoloxDetector(tmp_path / "bad.onnx", LABELS)


# -- real YOLOX-Nano ------------------------------------------------------------------------------

needs_yolox = pytest.mark.skipif(
    not (YOLOX / "yolox_nano.onnx").is_file() or not DEV.is_dir(),
    reason=f"real YOLOX-Nano weights / dev photos not found under {SHARED}",
)


def _iou(a, b) -> float:
    ix = max(0.0, min(a[2], b[2]) - max(a[0], b[0]))
    iy = max(0.0, min(a[3], b[3]) - max(a[1], b[1]))
    inter = ix * iy
    return inter / ((a[2] - a[0]) * (a[3] - a[1]) + (b[2] - b[0]) * (b[3] - b[1]) - inter)


@needs_yolox
@pytest.mark.parametrize(
    "sample, coco, box_key, min_iou",
    [
        ("kitti/000000", "person", "bbox2d_gt", 0.7),  # a pedestrian, tight 2D box
        ("scannet/scene0000_00_00102", "sofa", "bbox2d_proj", 0.6),
        ("sunrgbd/000017", "bed", "bbox2d_proj", 0.6),
    ],
)
def test_yolox_nano_finds_real_objects(sample: str, coco: str, box_key: str, min_iou: float) -> None:
    det = YoloxDetector.from_dir(YOLOX, {coco: coco}, threads=2)
    img = load_image(next(DEV.glob(sample + ".*[gG]")))
    gt = next(o for o in json.loads((DEV / f"{sample}.json").read_text())["objects"] if o["label"] == coco)
    t0 = time.perf_counter()
    found = det.detect(img, [(coco, coco)])
    elapsed = time.perf_counter() - t0
    assert found, f"no {coco} found in {sample}"
    best = max(_iou(d.box, gt[box_key]) for d in found)
    assert best > min_iou
    print(f"\nYOLOX-Nano {img.shape[1]}x{img.shape[0]}: {elapsed * 1000:.0f} ms, {coco} IoU {best:.2f}")
