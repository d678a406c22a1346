"""Segment-Anything-family ONNX segmenter (encoder + prompt decoder), e.g. MobileSAM.

Encoder: RGB, longest side resized to the encoder's input size S (read from the model, 1024 for
MobileSAM), normalised with the ImageNet mean/std in 0..255 units, zero-padded at the bottom/right
to SxS; output: the image embedding. Decoder (the standard SAM ONNX decoder): a box is the points
(x1, y1) label 2 and (x2, y2) label 3 plus a padding point (0, 0) label -1, in the resized frame;
``orig_im_size`` = (H, W); ``masks`` are logits at the original size, > 0 on the object.
"""

from __future__ import annotations

import time
from pathlib import Path
from typing import Sequence

import cv2
import numpy as np

from pipeline.models.base import Box, Mask, ModelError, check_box, check_image
from pipeline.models.session import IOSignature, TensorSpec, open_session, run

PIXEL_MEAN = np.array([123.675, 116.28, 103.53], dtype=np.float32)
PIXEL_STD = np.array([58.395, 57.12, 57.375], dtype=np.float32)

ENCODER_SIGNATURE = IOSignature(
    inputs=(TensorSpec("input", 4, (None, 3, None, None)),),
    outputs=(TensorSpec("output", 4),),
)
DECODER_SIGNATURE = IOSignature(
    inputs=(
        TensorSpec("image_embeddings", 4),
        TensorSpec("point_coords", 3, (1, None, 2)),
        TensorSpec("point_labels", 2, (1, None)),
        TensorSpec("mask_input", 4, (1, 1, None, None)),
        TensorSpec("has_mask_input", 1, (1,)),
        TensorSpec("orig_im_size", 1, (2,)),
    ),
    outputs=(TensorSpec("masks", 4), TensorSpec("iou_predictions", 2)),
)


def resized_shape(height: int, width: int, long_side: int) -> tuple[int, int]:
    """``(h, w)`` after scaling the longest side to ``long_side`` (SAM's rounding)."""
    scale = long_side / max(height, width)
    return int(height * scale + 0.5), int(width * scale + 0.5)


class SamSegmenter:
    """Box-prompted SAM segmenter: :meth:`set_image` runs the encoder, :meth:`segment_box` the decoder.

    Args:
        encoder_path: Encoder ``.onnx`` (input ``input`` [B, 3, S, S]).
        decoder_path: Decoder ``.onnx`` (the standard SAM ONNX decoder).
        input_size: Encoder input side; only for encoders with a dynamic input size (a fixed
            size in the model wins and a different value raises :class:`ModelError`).
        threads: onnxruntime intra-op threads (default: every core).
    """

    def __init__(
        self,
        encoder_path: Path | str,
        decoder_path: Path | str,
        *,
        input_size: int | None = None,
        threads: int | None = None,
        name: str = "mobilesam",
    ) -> None:
        self.name = name
        self.encoder = open_session(encoder_path, ENCODER_SIGNATURE, threads=threads, model_name=name)
        self.decoder = open_session(decoder_path, DECODER_SIGNATURE, threads=threads, model_name=name)
        h, w = self.encoder.get_inputs()[0].shape[2:4]
        fixed = h if isinstance(h, int) and h == w else None
        if fixed is not None and input_size not in (None, fixed):
            raise ModelError(
                f"model {name!r}: the encoder's input size is fixed at {fixed}x{fixed}; cannot use {input_size}"
            )
        size = fixed or input_size or 1024
        if not isinstance(size, int) or size < 16:
            raise ModelError(f"model {name!r}: input_size must be an integer >= 16, got {size!r}")
        self.input_size: int = size
        mask_in = self.decoder.get_inputs()
        shape = next(i.shape for i in mask_in if i.name == "mask_input")
        self._mask_input_shape = tuple(d if isinstance(d, int) else 256 for d in shape)
        self._embedding: np.ndarray | None = None
        self._image_hw: tuple[int, int] | None = None
        self.last_timings: dict[str, float] = {}

    @classmethod
    def from_dir(cls, model_dir: Path | str, **kwargs: object) -> SamSegmenter:
        """Load ``encoder.onnx`` and ``decoder.onnx`` from ``model_dir``."""
        model_dir = Path(model_dir)
        return cls(model_dir / "encoder.onnx", model_dir / "decoder.onnx", **kwargs)  # type: ignore[arg-type]

    def preprocess(self, image_rgb: np.ndarray) -> np.ndarray:
        """Encoder input [1, 3, S, S] float32 for ``image_rgb``."""
        h, w = image_rgb.shape[:2]
        nh, nw = resized_shape(h, w, self.input_size)
        resized = cv2.resize(image_rgb, (nw, nh), interpolation=cv2.INTER_LINEAR).astype(np.float32)
        tensor = np.zeros((self.input_size, self.input_size, 3), dtype=np.float32)
        tensor[:nh, :nw] = (resized - PIXEL_MEAN) / PIXEL_STD
        return np.ascontiguousarray(tensor.transpose(2, 0, 1)[None])

    def set_image(self, image_rgb: np.ndarray) -> None:
        """Run the encoder on ``image_rgb`` (uint8 HxWx3 RGB) and keep its embedding."""
        image = check_image(image_rgb, self.name)
        t0 = time.perf_counter()
        (embedding,) = run(self.encoder, ["output"], {"input": self.preprocess(image)}, f"model {self.name!r} encoder")
        self._embedding = embedding
        self._image_hw = (image.shape[0], image.shape[1])
        self.last_timings = {"encoder": time.perf_counter() - t0, "decoder": 0.0}

    def segment_box(self, box: Box) -> Mask:
        """Mask of the object in ``box`` [px] of the current image (one decoder run)."""
        if self._embedding is None or self._image_hw is None:
            raise ModelError(f"model {self.name!r}: call set_image() before segment_box()")
        h, w = self._image_hw
        x1, y1, x2, y2 = check_box(box, w, h, self.name)
        nh, nw = resized_shape(h, w, self.input_size)
        sx, sy = nw / w, nh / h
        coords = np.array([[[x1 * sx, y1 * sy], [x2 * sx, y2 * sy], [0.0, 0.0]]], dtype=np.float32)
        feeds = {
            "image_embeddings": self._embedding,
            "point_coords": coords,
            "point_labels": np.array([[2, 3, -1]], dtype=np.float32),
            "mask_input": np.zeros(self._mask_input_shape, dtype=np.float32),
            "has_mask_input": np.zeros(1, dtype=np.float32),
            "orig_im_size": np.array([h, w], dtype=np.float32),
        }
        t0 = time.perf_counter()
        masks, iou = run(self.decoder, ["masks", "iou_predictions"], feeds, f"model {self.name!r} decoder")
        self.last_timings["decoder"] = self.last_timings.get("decoder", 0.0) + time.perf_counter() - t0
        if masks.ndim != 4 or masks.shape[-2:] != (h, w):
            raise ModelError(
                f"model {self.name!r}: decoder returned masks of shape {masks.shape}, expected (1, 1, {h}, {w})"
            )
        best = int(np.argmax(iou[0])) if iou.shape[-1] > 1 else 0
        return Mask(masks[0, best] > 0.0, float(iou[0, best]), (x1, y1, x2, y2))

    def segment(self, image_rgb: np.ndarray, boxes: Sequence[Box]) -> list[Mask]:
        """Masks of ``boxes`` in ``image_rgb``: one encoder run, one decoder run per box."""
        self.set_image(image_rgb)
        return [self.segment_box(b) for b in boxes]
