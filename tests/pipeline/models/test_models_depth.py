"""Depth backends: Depth Anything V2 pre-processing on a tiny graph, FastDepth on real photos."""

from __future__ import annotations

import json
import time
from pathlib import Path

import numpy as np
import pytest
from onnx_fixtures import depth_anything_model, fastdepth_model, wrong_signature_model

from pipeline.camera.image_io import load_image
from pipeline.models.base import DepthMap, ModelError
from pipeline.models.depth import DepthAnythingEstimator, FastDepthEstimator, dpt_resize_shape

SHARED = Path(__file__).resolve().parents[3].parent / "shared"
FASTDEPTH = SHARED / "models" / "fastdepth"
DEV = SHARED / "bench" / "dev"

PRE = {
    "do_normalize": True, "do_resize": True, "ensure_multiple_of": 14, "image_mean": [0.485, 0.456, 0.406],
    "image_std": [0.229, 0.224, 0.225], "keep_aspect_ratio": True, "resample": 3,
    "rescale_factor": 0.00392156862745098, "size": {"height": 518, "width": 518},
}


def _da_dir(tmp_path: Path, config: dict) -> Path:
    d = tmp_path / "da"
    depth_anything_model(d / "model.onnx")
    (d / "config.json").write_text(json.dumps(config))
    (d / "preprocessor_config.json").write_text(json.dumps(PRE))
    return d


def test_dpt_resize_shape_follows_the_hub_processor() -> None:
    # 640x480: the height scale (518/480) is closer to 1, so the height becomes 518.
    assert dpt_resize_shape(480, 640, (518, 518)) == (518, 686)
    assert dpt_resize_shape(530, 730, (518, 518)) == (518, 714)
    # Wide KITTI frame: the height scale is still the one closer to 1 -> 518 x 1722 (as the hub does).
    assert dpt_resize_shape(375, 1242, (518, 518)) == (518, 1722)
    # Tiny image: the width scale is closer to 1 -> width 518, height a multiple of 14.
    assert dpt_resize_shape(48, 64, (518, 518)) == (392, 518)


def test_depth_anything_relative_is_inverse_depth_at_original_size(tmp_path: Path) -> None:
    est = DepthAnythingEstimator.from_dir(_da_dir(tmp_path, {"model_type": "depth_anything"}), threads=1)
    assert est.kind == "inverse_relative"
    img = np.zeros((48, 64, 3), np.uint8)
    img[:, :32] = 255  # bright left half
    t = est.preprocess(img)
    assert t.shape == (1, 3, 392, 518)
    assert t[0, :, 0, 0] == pytest.approx((1.0 - est.mean) / est.std, abs=1e-3)
    dm = est.estimate(img)
    assert isinstance(dm, DepthMap) and dm.kind == "inverse_relative"
    assert dm.values.shape == (48, 64) and dm.values.dtype == np.float32
    assert dm.values[:, :28].mean() > dm.values[:, 36:].mean()
    assert float(dm.values.min()) >= 0.0


def test_depth_anything_metric_kind_from_config_and_override(tmp_path: Path) -> None:
    d = _da_dir(tmp_path, {"model_type": "depth_anything", "depth_estimation_type": "metric", "max_depth": 20})
    assert DepthAnythingEstimator.from_dir(d).kind == "metric"
    assert DepthAnythingEstimator.from_dir(d, kind="relative").kind == "relative"
    small = DepthAnythingEstimator.from_dir(d, input_size=266)
    assert small.preprocess(np.zeros((480, 640, 3), np.uint8)).shape[2:] == (266, 350)


def test_bad_config_and_signature(tmp_path: Path) -> None:
    d = _da_dir(tmp_path, {})
    (d / "preprocessor_config.json").write_text('{"size": "big"}')
    with pytest.raises(ModelError, match="cannot read an image size"):
        DepthAnythingEstimator.from_dir(d)
    (d / "preprocessor_config.json").write_text("[1, 2")
    with pytest.raises(ModelError, match="not a readable JSON"):
        DepthAnythingEstimator.from_dir(d)
    wrong_signature_model(tmp_path / "w" / "fastdepth.onnx", input_name="0")
    with pytest.raises(ModelError, match="missing output '350'"):
        FastDepthEstimator.from_dir(tmp_path / "w")


def test_fastdepth_tiny_graph_resizes_back(tmp_path: Path) -> None:
    fastdepth_model(tmp_path / "fastdepth.onnx")
    est = FastDepthEstimator.from_dir(tmp_path, threads=1)
    img = np.full((90, 160, 3), 255, np.uint8)
    dm = est.estimate(img)
    assert dm.kind == "metric" and dm.values.shape == (90, 160)
    assert dm.values == pytest.approx(10.0, abs=1e-4)  # 10 * mean of RGB / 255
    with pytest.raises(ModelError, match="uint8"):
        est.estimate(img.astype(np.float32))


# -- real FastDepth -------------------------------------------------------------------------------

needs_fastdepth = pytest.mark.skipif(
    not (FASTDEPTH / "fastdepth.onnx").is_file() or not DEV.is_dir(),
    reason=f"real FastDepth weights / dev photos not found under {SHARED}",
)


def _box_median(values: np.ndarray, box) -> float:
    x1, y1, x2, y2 = (int(round(v)) for v in box)
    return float(np.median(values[y1:y2, x1:x2]))


@needs_fastdepth
@pytest.mark.parametrize(
    "sample, near, far",
    [("sunrgbd/000001", "ottoman", "lamp"), ("scannet/scene0000_00_00102", "sofa", "cabinet")],
)
def test_fastdepth_orders_near_and_far_objects(sample: str, near: str, far: str) -> None:
    est = FastDepthEstimator.from_dir(FASTDEPTH, threads=2)
    img = load_image(next(DEV.glob(sample + ".*[gG]")))
    gt = {o["label"]: o for o in json.loads((DEV / f"{sample}.json").read_text())["objects"]}
    assert gt[near]["center_cam"][2] + 1.5 < gt[far]["center_cam"][2]  # the premise: > 1.5 m apart
    t0 = time.perf_counter()
    dm = est.estimate(img)
    elapsed = time.perf_counter() - t0
    assert dm.kind == "metric" and dm.values.shape == img.shape[:2]
    d_near = _box_median(dm.values, gt[near]["bbox2d_proj"])
    d_far = _box_median(dm.values, gt[far]["bbox2d_proj"])
    assert d_near < d_far
    assert 0.5 < d_near / gt[near]["center_cam"][2] < 2.0  # metric, roughly right scale indoors
    print(f"\nFastDepth {img.shape[1]}x{img.shape[0]}: {elapsed * 1000:.0f} ms; {near} {d_near:.2f} m "
          f"(gt {gt[near]['center_cam'][2]:.2f}), {far} {d_far:.2f} m (gt {gt[far]['center_cam'][2]:.2f})")
