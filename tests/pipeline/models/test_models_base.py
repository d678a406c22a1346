"""Value types, input checks, NMS and the signature-checked session helper."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from onnx_fixtures import depth_anything_model, fastdepth_model, wrong_signature_model

from pipeline.models import DepthMap, Detection, ModelError, ModelMissingError
from pipeline.models.base import check_box, check_image, check_prompts
from pipeline.models.nms import batched_nms, box_iou, nms
from pipeline.models.session import IOSignature, TensorSpec, available_providers, open_session


def test_detection_normalises_and_validates() -> None:
    d = Detection((1, 2, 11, 22), np.float32(0.5), "chair", "a chair")
    assert d.box == (1.0, 2.0, 11.0, 22.0) and isinstance(d.score, float)
    assert (d.width, d.height) == (10.0, 20.0)
    with pytest.raises(ModelError, match="x1 <= x2"):
        Detection((5, 0, 1, 1), 0.5, "a", "a")
    with pytest.raises(ModelError, match="4 finite numbers"):
        Detection((0, 0, float("nan"), 1), 0.5, "a", "a")


def test_depth_map_validates_kind_and_shape() -> None:
    with pytest.raises(ModelError, match="metric, relative or inverse_relative"):
        DepthMap(np.zeros((2, 2), np.float32), "absolute")  # type: ignore[arg-type]
    with pytest.raises(ModelError, match="HxW"):
        DepthMap(np.zeros((2, 2, 1), np.float32), "metric")


def test_missing_error_names_the_fetch_command() -> None:
    err = ModelMissingError(["owlv2", "fastdepth"], "looked in /x")
    assert "morphonavi models fetch owlv2" in str(err) and "morphonavi models fetch fastdepth" in str(err)
    assert isinstance(err, ModelError) and isinstance(err, FileNotFoundError)
    assert err.names == ("owlv2", "fastdepth")


def test_input_checks() -> None:
    assert check_image(np.zeros((4, 5, 3), np.uint8)).shape == (4, 5, 3)
    for bad, msg in [([[1]], "numpy"), (np.zeros((4, 5), np.uint8), "HxWx3"),
                     (np.zeros((4, 5, 4), np.uint8), "HxWx3"), (np.zeros((4, 5, 3), np.uint16), "uint8"),
                     (np.zeros((1, 5, 3), np.uint8), "too small")]:
        with pytest.raises(ModelError, match=msg):
            check_image(bad)
    assert check_box((-5, 2, 20, 30), 10, 10) == (0.0, 2.0, 10.0, 10.0)
    assert check_prompts([("a chair ", "chair")]) == [("a chair", "chair")]
    with pytest.raises(ModelError, match="empty"):
        check_prompts([("", "chair")])
    with pytest.raises(ModelError, match="got a string"):
        check_prompts("chair")  # type: ignore[arg-type]


def test_nms_greedy_and_class_aware() -> None:
    boxes = np.array([[0, 0, 10, 10], [1, 1, 11, 11], [20, 20, 30, 30], [0, 0, 10, 10]], float)
    scores = np.array([0.9, 0.8, 0.7, 0.95])
    assert box_iou(boxes[:1], boxes[1:2])[0, 0] == pytest.approx(81 / 119)
    assert nms(boxes, scores, 0.5).tolist() == [3, 2]
    # Box 3 is another class: it does not suppress the chair boxes.
    kept = batched_nms(boxes, scores, ["chair", "chair", "chair", "table"], 0.5)
    assert kept.tolist() == [3, 0, 2]
    assert batched_nms(np.zeros((0, 4)), np.zeros(0), [], 0.5).tolist() == []
    rng = np.random.default_rng(0)
    xy = rng.uniform(0, 500, (300, 2))
    many = np.hstack([xy, xy + rng.uniform(5, 80, (300, 2))])
    keep = nms(many, rng.uniform(size=300), 0.3)
    iou = box_iou(many[keep], many[keep])
    np.fill_diagonal(iou, 0)
    assert iou.max() <= 0.3


def test_session_checks_signature(tmp_path: Path) -> None:
    assert available_providers()[-1] == "CPUExecutionProvider"
    path = depth_anything_model(tmp_path / "da.onnx")
    sig = IOSignature((TensorSpec("pixel_values", 4, (None, 3, None, None)),), (TensorSpec("predicted_depth", 3),))
    session = open_session(path, sig, threads=1)
    assert session.get_inputs()[0].name == "pixel_values"
    with pytest.raises(ModelError, match="has rank 3, expected 4"):
        open_session(path, IOSignature((TensorSpec("pixel_values", 4),), (TensorSpec("predicted_depth", 4),)))
    fd = fastdepth_model(tmp_path / "fd.onnx")
    with pytest.raises(ModelError, match="dimension 2 is 224, expected 416"):
        open_session(fd, IOSignature((TensorSpec("0", 4, (1, 3, 416, 416)),), ()))
    with pytest.raises(ModelError, match="unexpected input"):
        open_session(wrong_signature_model(tmp_path / "w.onnx"), IOSignature((), (TensorSpec("y", 4),)))
    with pytest.raises(ModelError, match="threads must be a positive integer"):
        open_session(path, sig, threads=0)
    (tmp_path / "junk.onnx").write_bytes(b"definitely not onnx")
    with pytest.raises(ModelError, match="cannot load the ONNX file"):
        open_session(tmp_path / "junk.onnx", None, model_name="junk")
    with pytest.raises(ModelMissingError, match="morphonavi models fetch fastdepth"):
        open_session(tmp_path / "nope.onnx", None, model_name="fastdepth")
