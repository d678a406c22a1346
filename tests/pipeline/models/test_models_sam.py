"""SAM-family segmenter: tiny graphs for the coordinate handling, MobileSAM on real photos."""

from __future__ import annotations

import json
import time
from pathlib import Path

import numpy as np
import pytest
from onnx_fixtures import sam_decoder, sam_encoder, wrong_signature_model

from pipeline.camera.image_io import load_image
from pipeline.models.base import ModelError, ModelMissingError
from pipeline.models.sam import SamSegmenter, resized_shape

SHARED = Path(__file__).resolve().parents[3].parent / "shared"
MOBILESAM = SHARED / "models" / "mobilesam"
DEV = SHARED / "bench" / "dev"


@pytest.fixture()
def tiny(tmp_path: Path) -> SamSegmenter:
    sam_encoder(tmp_path / "encoder.onnx", size=64)
    sam_decoder(tmp_path / "decoder.onnx", encoder_size=64)
    return SamSegmenter.from_dir(tmp_path, threads=1)


def test_input_size_is_read_from_the_encoder(tiny: SamSegmenter) -> None:
    assert tiny.input_size == 64
    img = np.zeros((30, 60, 3), np.uint8)
    t = tiny.preprocess(img)
    assert t.shape == (1, 3, 64, 64)
    # 60x30 -> 64x32, padded with zeros (after normalisation) below row 32.
    assert np.all(t[0, :, 32:, :] == 0.0)
    assert t[0, 0, 0, 0] == pytest.approx((0 - 123.675) / 58.395)


def test_box_mask_in_original_frame(tiny: SamSegmenter) -> None:
    img = np.zeros((120, 200, 3), np.uint8)
    box = (40.0, 30.0, 120.0, 90.0)
    (mask,) = tiny.segment(img, [box])
    assert mask.values.shape == (120, 200) and mask.values.dtype == bool
    ys, xs = np.nonzero(mask.values)
    # The decoder saw the box in the 64-px frame; the mask comes back in original pixels.
    assert (xs.min(), xs.max() + 1, ys.min(), ys.max() + 1) == pytest.approx((40, 120, 30, 90), abs=1)
    assert mask.predicted_iou == pytest.approx(0.875)
    assert mask.area == pytest.approx(80 * 60, rel=0.05)
    assert set(tiny.last_timings) == {"encoder", "decoder"}


def test_one_encoder_run_many_boxes(tiny: SamSegmenter) -> None:
    tiny.set_image(np.zeros((100, 100, 3), np.uint8))
    a = tiny.segment_box((0, 0, 50, 50))
    b = tiny.segment_box((50, 50, 100, 100))
    assert a.values[10, 10] and not a.values[80, 80]
    assert b.values[80, 80] and not b.values[10, 10]


def test_errors(tiny: SamSegmenter, tmp_path: Path) -> None:
    fresh = SamSegmenter.from_dir(tmp_path)
    with pytest.raises(ModelError, match="set_image"):
        fresh.segment_box((0, 0, 5, 5))
    tiny.set_image(np.zeros((50, 50, 3), np.uint8))
    with pytest.raises(ModelError, match="does not overlap"):
        tiny.segment_box((60, 60, 80, 80))
    with pytest.raises(ModelError, match="x1 <= x2"):
        tiny.segment_box((30, 0, 10, 5))
    with pytest.raises(ModelError, match="4 numbers"):
        tiny.segment_box((1, 2, 3))  # type: ignore[arg-type]
    with pytest.raises(ModelError, match="fixed at 64x64"):
        SamSegmenter.from_dir(tmp_path, input_size=32)
    with pytest.raises(ModelMissingError, match="morphonavi models fetch"):
        SamSegmenter.from_dir(tmp_path / "nowhere")
    wrong_signature_model(tmp_path / "w" / "encoder.onnx")
    sam_decoder(tmp_path / "w" / "decoder.onnx")
    with pytest.raises(ModelError, match="missing input 'input'"):
        SamSegmenter.from_dir(tmp_path / "w")


def test_resized_shape_matches_sam_rounding() -> None:
    assert resized_shape(530, 730, 1024) == (743, 1024)
    assert resized_shape(480, 640, 1024) == (768, 1024)


# -- real MobileSAM -------------------------------------------------------------------------------

needs_mobilesam = pytest.mark.skipif(
    not (MOBILESAM / "encoder.onnx").is_file() or not (DEV / "sunrgbd" / "000017.jpg").is_file(),
    reason=f"real MobileSAM weights / dev photos not found under {SHARED}",
)


def _mask_bbox(values: np.ndarray) -> tuple[int, int, int, int]:
    ys, xs = np.nonzero(values)
    return int(xs.min()), int(ys.min()), int(xs.max()) + 1, int(ys.max()) + 1


def _iou(a, b) -> float:
    ix = max(0.0, min(a[2], b[2]) - max(a[0], b[0]))
    iy = max(0.0, min(a[3], b[3]) - max(a[1], b[1]))
    inter = ix * iy
    return inter / ((a[2] - a[0]) * (a[3] - a[1]) + (b[2] - b[0]) * (b[3] - b[1]) - inter)


@needs_mobilesam
def test_mobilesam_masks_follow_real_objects() -> None:
    sam = SamSegmenter.from_dir(MOBILESAM, threads=2)
    assert sam.input_size == 1024
    img = load_image(DEV / "sunrgbd" / "000017.jpg")
    gt = json.loads((DEV / "sunrgbd" / "000017.json").read_text())
    t0 = time.perf_counter()
    sam.set_image(img)
    encoder_s = time.perf_counter() - t0
    for obj in gt["objects"]:  # bed, nightstand: projected 3D boxes
        x1, y1, x2, y2 = (int(round(v)) for v in obj["bbox2d_proj"])
        mask = sam.segment_box(obj["bbox2d_proj"])
        inside = mask.values[y1:y2, x1:x2].sum()
        assert inside / ((x2 - x1) * (y2 - y1)) > 0.5, obj["label"]  # fills most of its box
        assert mask.area - inside < 0.05 * mask.area, obj["label"]  # and stays inside it
        assert mask.predicted_iou > 0.85
    print(f"\nMobileSAM on {img.shape[1]}x{img.shape[0]}: encoder {encoder_s:.2f} s, "
          f"decoder {sam.last_timings['decoder'] / len(gt['objects']):.3f} s per box (figures only: speed is "
          "checked by bench/pipeline_speed.py, never by a timed test)")


@needs_mobilesam
def test_mobilesam_person_mask_matches_its_2d_box() -> None:
    """KITTI gives a tight 2D box of the visible person: the mask's own bounding box must match it."""
    sam = SamSegmenter.from_dir(MOBILESAM, threads=2)
    img = load_image(DEV / "kitti" / "000000.png")
    gt = json.loads((DEV / "kitti" / "000000.json").read_text())
    box = gt["objects"][0]["bbox2d_gt"]
    (mask,) = sam.segment(img, [box])
    assert _iou(_mask_bbox(mask.values), box) > 0.7  # measured 0.78: the top of the head is left out
