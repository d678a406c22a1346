"""Monocular depth ONNX backends: Depth Anything V2 (hub export) and FastDepth.

Both return a :class:`DepthMap` at the original image size (bilinear resize of the model output).

- Depth Anything V2 (``onnx-community`` export): input ``pixel_values`` [1, 3, H, W] RGB/255 with
  the ImageNet mean/std, resized DPT-style (keep the aspect ratio, the side scale closer to 1 wins,
  both sides multiples of 14 around 518); output ``predicted_depth`` [1, H, W]. The relative
  models output relative INVERSE depth (disparity, larger = nearer); the metric ones (config
  ``depth_estimation_type: "metric"``) output depth [m].
- FastDepth (NYU Depth v2): input ``0`` [1, 3, 224, 224] RGB/255, whole image resized; output
  ``350`` [1, 1, 224, 224] metric depth [m].
"""

from __future__ import annotations

import math
import time
from pathlib import Path
from typing import Any

import cv2
import numpy as np

from pipeline.models.base import DepthKind, DepthMap, ModelError, check_image
from pipeline.models.hub_config import parse_size, parse_triplet, read_json
from pipeline.models.session import IOSignature, TensorSpec, open_session, run

IMAGENET_MEAN = (0.485, 0.456, 0.406)
IMAGENET_STD = (0.229, 0.224, 0.225)

DEPTH_ANYTHING_SIGNATURE = IOSignature(
    inputs=(TensorSpec("pixel_values", 4, (None, 3, None, None)),),
    outputs=(TensorSpec("predicted_depth", 3),),
)
FASTDEPTH_SIGNATURE = IOSignature(
    inputs=(TensorSpec("0", 4, (1, 3, None, None)),),
    outputs=(TensorSpec("350", 4, (1, 1, None, None)),),
)


def constrain_to_multiple(value: float, multiple: int, min_value: int = 0) -> int:
    """``value`` rounded to a multiple of ``multiple`` (at least ``min_value``), as DPT does."""
    x = int(round(value / multiple) * multiple)
    if x < min_value:
        x = int(math.ceil(value / multiple) * multiple)
    return max(x, multiple)


def dpt_resize_shape(
    height: int, width: int, target: tuple[int, int], multiple: int = 14, keep_aspect_ratio: bool = True
) -> tuple[int, int]:
    """``(h, w)`` the DPT image processor resizes a ``height`` x ``width`` image to."""
    scale_h, scale_w = target[0] / height, target[1] / width
    if keep_aspect_ratio:
        if abs(1 - scale_w) < abs(1 - scale_h):
            scale_h = scale_w
        else:
            scale_w = scale_h
    return constrain_to_multiple(scale_h * height, multiple), constrain_to_multiple(scale_w * width, multiple)


def _resize_to(values: np.ndarray, height: int, width: int) -> np.ndarray:
    out = cv2.resize(values.astype(np.float32), (width, height), interpolation=cv2.INTER_LINEAR)
    return np.ascontiguousarray(out, dtype=np.float32)


class DepthAnythingEstimator:
    """Depth Anything V2 ONNX export.

    Args:
        model_path: The ``.onnx`` file.
        kind: ``"inverse_relative"`` (relative models) or ``"metric"``; ``None``: from ``config``.
        config: ``config.json`` contents (``depth_estimation_type``, ``max_depth``).
        preprocessor: ``preprocessor_config.json`` contents (``size``, ``image_mean``, ...).
        input_size: Target side instead of the config's (518); smaller is faster and blurrier.
        threads: onnxruntime intra-op threads (default: every core).
    """

    def __init__(
        self,
        model_path: Path | str,
        *,
        kind: DepthKind | None = None,
        config: dict[str, Any] | None = None,
        preprocessor: dict[str, Any] | None = None,
        input_size: int | None = None,
        threads: int | None = None,
        name: str = "depth_anything_v2_small",
    ) -> None:
        self.name = name
        config = config or {}
        pre = preprocessor or {}
        if kind is None:
            kind = "metric" if config.get("depth_estimation_type") == "metric" else "inverse_relative"
        if kind not in ("metric", "relative", "inverse_relative"):
            raise ModelError(f"model {name!r}: unknown depth kind {kind!r}")
        self.kind: DepthKind = kind
        where = f"model {name!r} preprocessor config"
        self.target = parse_size(pre.get("size", 518), where) if input_size is None else (input_size, input_size)
        self.multiple = int(pre.get("ensure_multiple_of", 14) or 1)
        self.keep_aspect_ratio = bool(pre.get("keep_aspect_ratio", True))
        self.mean = np.array(parse_triplet(pre.get("image_mean"), IMAGENET_MEAN, where), dtype=np.float32)
        self.std = np.array(parse_triplet(pre.get("image_std"), IMAGENET_STD, where), dtype=np.float32)
        self.rescale = float(pre.get("rescale_factor", 1 / 255))
        self.session = open_session(model_path, DEPTH_ANYTHING_SIGNATURE, threads=threads, model_name=name)
        self.last_timings: dict[str, float] = {}

    @classmethod
    def from_dir(cls, model_dir: Path | str, **kwargs: Any) -> DepthAnythingEstimator:
        """Load ``model.onnx``, ``config.json`` and ``preprocessor_config.json`` from ``model_dir``."""
        model_dir = Path(model_dir)
        return cls(
            model_dir / "model.onnx",
            config=read_json(model_dir / "config.json"),
            preprocessor=read_json(model_dir / "preprocessor_config.json"),
            **kwargs,
        )

    def preprocess(self, image_rgb: np.ndarray) -> np.ndarray:
        """Model input [1, 3, h, w] float32 (h, w multiples of 14)."""
        h, w = image_rgb.shape[:2]
        nh, nw = dpt_resize_shape(h, w, self.target, self.multiple, self.keep_aspect_ratio)
        resized = cv2.resize(image_rgb, (nw, nh), interpolation=cv2.INTER_CUBIC).astype(np.float32)
        tensor = (resized * self.rescale - self.mean) / self.std
        return np.ascontiguousarray(tensor.transpose(2, 0, 1)[None], dtype=np.float32)

    def estimate(self, image_rgb: np.ndarray) -> DepthMap:
        """Depth of ``image_rgb`` at its own size; ``kind`` as configured."""
        image = check_image(image_rgb, self.name)
        t0 = time.perf_counter()
        feeds = {"pixel_values": self.preprocess(image)}
        (out,) = run(self.session, ["predicted_depth"], feeds, f"model {self.name!r}")
        values = np.asarray(out, dtype=np.float32).reshape(out.shape[-2], out.shape[-1])
        if self.kind == "inverse_relative":
            values = np.maximum(values, 0.0)
        depth = DepthMap(_resize_to(values, image.shape[0], image.shape[1]), self.kind)
        self.last_timings = {"depth": time.perf_counter() - t0}
        return depth


class FastDepthEstimator:
    """FastDepth (NYU Depth v2) ONNX: metric depth [m], indoor scale.

    Args:
        model_path: The ``.onnx`` file (input ``0`` [1, 3, 224, 224], output ``350``).
        threads: onnxruntime intra-op threads (default: every core).
    """

    kind: DepthKind = "metric"

    def __init__(self, model_path: Path | str, *, threads: int | None = None, name: str = "fastdepth") -> None:
        self.name = name
        self.session = open_session(model_path, FASTDEPTH_SIGNATURE, threads=threads, model_name=name)
        h, w = self.session.get_inputs()[0].shape[2:4]
        self.input_hw = (h if isinstance(h, int) else 224, w if isinstance(w, int) else 224)
        self.last_timings: dict[str, float] = {}

    @classmethod
    def from_dir(cls, model_dir: Path | str, **kwargs: Any) -> FastDepthEstimator:
        """Load ``fastdepth.onnx`` from ``model_dir``."""
        return cls(Path(model_dir) / "fastdepth.onnx", **kwargs)

    def preprocess(self, image_rgb: np.ndarray) -> np.ndarray:
        """Model input [1, 3, 224, 224] float32, RGB / 255."""
        h, w = self.input_hw
        resized = cv2.resize(image_rgb, (w, h), interpolation=cv2.INTER_AREA).astype(np.float32) / 255.0
        return np.ascontiguousarray(resized.transpose(2, 0, 1)[None])

    def estimate(self, image_rgb: np.ndarray) -> DepthMap:
        """Metric depth [m] of ``image_rgb`` at its own size."""
        image = check_image(image_rgb, self.name)
        t0 = time.perf_counter()
        (out,) = run(self.session, ["350"], {"0": self.preprocess(image)}, f"model {self.name!r}")
        values = np.maximum(np.asarray(out, dtype=np.float32)[0, 0], 0.0)
        depth = DepthMap(_resize_to(values, image.shape[0], image.shape[1]), "metric")
        self.last_timings = {"depth": time.perf_counter() - t0}
        return depth
