"""YOLOX ONNX detector (closed vocabulary, COCO-80), e.g. YOLOX-Nano.

Pre-processing: RGB -> BGR, 0..255 floats without mean/std, scaled by ``r = min(S/h, S/w)`` and
pasted at the TOP-LEFT of an SxS canvas filled with 114. The raw output ``[1, A, 5 + C]`` holds, per
anchor of the stride-8/16/32 grids (x fastest), ``(dx, dy, log w, log h, objectness, class scores)``
already passed through a sigmoid: centre = (d + grid) * stride, size = exp(log) * stride,
score = objectness * class score. Boxes are divided by ``r`` and pass a class-wise NMS.

Backend labels (``coco_classes.txt`` beside the model) become class names through ``label_map``;
labels not in it are never reported.
"""

from __future__ import annotations

import time
from pathlib import Path
from typing import Mapping, Sequence

import cv2
import numpy as np

from pipeline.models.base import Detection, ModelError, ModelMissingError, Prompt, check_image, closed_vocabulary
from pipeline.models.nms import batched_nms
from pipeline.models.session import IOSignature, TensorSpec, open_session, run

STRIDES = (8, 16, 32)
PAD_VALUE = 114.0
DEFAULT_SCORE_THRESHOLD = 0.25
"""Minimum ``obj * cls`` score by default (the YOLOX demo's ``--conf``); see :class:`YoloxDetector`."""
SIGNATURE = IOSignature(
    inputs=(TensorSpec("images", 4, (1, 3, None, None)),),
    outputs=(TensorSpec("output", 3, (1, None, None)),),
)


def read_labels(path: Path, model_name: str = "yolox_nano") -> list[str]:
    """Class labels, one a line (blank lines ignored)."""
    if not path.is_file():
        raise ModelMissingError(model_name, f"no label file {path}")
    labels = [line.strip() for line in path.read_text(encoding="utf-8").splitlines() if line.strip()]
    if not labels:
        raise ModelError(f"{path}: label file is empty")
    return labels


def letterbox(image_rgb: np.ndarray, size: tuple[int, int]) -> tuple[np.ndarray, float]:
    """``(input tensor [1, 3, H, W] float32 BGR 0..255, scale r)`` for a top-left letterbox."""
    h, w = image_rgb.shape[:2]
    in_h, in_w = size
    r = min(in_h / h, in_w / w)
    new_w, new_h = max(1, int(round(w * r))), max(1, int(round(h * r)))
    resized = cv2.resize(image_rgb, (new_w, new_h), interpolation=cv2.INTER_LINEAR)
    canvas = np.full((in_h, in_w, 3), PAD_VALUE, dtype=np.float32)
    canvas[:new_h, :new_w] = resized[:, :, ::-1]  # RGB -> BGR
    return np.ascontiguousarray(canvas.transpose(2, 0, 1)[None]), r


def grid_and_strides(size: tuple[int, int], strides: Sequence[int] = STRIDES) -> tuple[np.ndarray, np.ndarray]:
    """Anchor grid cells (A, 2) as (x, y) and their strides (A, 1), x fastest, stride 8 first."""
    grids, expanded = [], []
    for s in strides:
        gh, gw = size[0] // s, size[1] // s
        yv, xv = np.meshgrid(np.arange(gh), np.arange(gw), indexing="ij")
        grids.append(np.stack((xv, yv), axis=2).reshape(-1, 2))
        expanded.append(np.full((gh * gw, 1), s))
    return np.concatenate(grids).astype(np.float32), np.concatenate(expanded).astype(np.float32)


def decode(raw: np.ndarray, size: tuple[int, int], strides: Sequence[int] = STRIDES) -> tuple[np.ndarray, np.ndarray]:
    """``(boxes (A, 4) x1y1x2y2 in the input frame, class scores (A, C) = obj * cls)`` of raw ``[1, A, 5+C]``."""
    pred = np.asarray(raw, dtype=np.float32).reshape(raw.shape[-2], raw.shape[-1])
    grids, stride = grid_and_strides(size, strides)
    if grids.shape[0] != pred.shape[0]:
        raise ModelError(
            f"YOLOX output has {pred.shape[0]} anchors, expected {grids.shape[0]} for a "
            f"{size[1]}x{size[0]} input with strides {tuple(strides)}"
        )
    centre = (pred[:, :2] + grids) * stride
    wh = np.exp(pred[:, 2:4]) * stride
    boxes = np.concatenate([centre - wh / 2, centre + wh / 2], axis=1)
    return boxes, pred[:, 4:5] * pred[:, 5:]


class YoloxDetector:
    """Closed-vocabulary YOLOX detector.

    Args:
        model_path: The ``.onnx`` file.
        labels: Backend label of each class column (e.g. the 80 COCO names).
        label_map: Backend label -> class name; labels not in it are ignored. ``None``: identity.
        score_threshold: Minimum ``obj * cls`` score. 0.25, the YOLOX project's own demo default:
            on the dev set (tiled, 52 in-vocabulary objects) 0.3 -> 0.25 found one object more for
            6 more unmatched detections on fully annotated photos; 0.2 / 0.1 found at most two more
            for 17 / 54 more unmatched ones, each of which also costs the mapper a segmenter
            decoder run.
        nms_iou: IoU above which a lower-scoring box of the same class is dropped.
        threads: onnxruntime intra-op threads (default: every core).
    """

    def __init__(
        self,
        model_path: Path | str,
        labels: Sequence[str],
        label_map: Mapping[str, str] | None = None,
        *,
        score_threshold: float = DEFAULT_SCORE_THRESHOLD,
        nms_iou: float = 0.45,
        threads: int | None = None,
        name: str = "yolox_nano",
    ) -> None:
        self.name = name
        self.score_threshold = float(score_threshold)
        self.nms_iou = float(nms_iou)
        self.labels = list(labels)
        self.label_map: dict[str, str] = dict(label_map) if label_map is not None else {l: l for l in self.labels}
        self.session = open_session(model_path, SIGNATURE, threads=threads, model_name=name)
        shape = self.session.get_inputs()[0].shape
        if not (isinstance(shape[2], int) and isinstance(shape[3], int)):
            raise ModelError(f"model {name!r}: expected a fixed input size, got {shape}")
        self.input_size: tuple[int, int] = (shape[2], shape[3])
        out_classes = self.session.get_outputs()[0].shape[2]
        if isinstance(out_classes, int) and out_classes - 5 != len(self.labels):
            raise ModelError(
                f"model {name!r}: output has {out_classes - 5} classes but {len(self.labels)} labels were given"
            )
        self.last_timings: dict[str, float] = {}

    @classmethod
    def from_dir(
        cls, model_dir: Path | str, label_map: Mapping[str, str] | None = None, **kwargs: object
    ) -> YoloxDetector:
        """Load ``yolox_nano.onnx`` and ``coco_classes.txt`` from ``model_dir``."""
        model_dir = Path(model_dir)
        labels = read_labels(model_dir / "coco_classes.txt", str(kwargs.get("name", "yolox_nano")))
        return cls(model_dir / "yolox_nano.onnx", labels, label_map, **kwargs)  # type: ignore[arg-type]

    def vocabulary(self, prompts: Sequence[Prompt]) -> frozenset[str]:
        """Class names of ``prompts`` that some backend label maps to."""
        return closed_vocabulary(prompts, self.label_map, self.name)

    def detect(self, image_rgb: np.ndarray, prompts: Sequence[Prompt]) -> list[Detection]:
        """Detections of the prompts' classes, best first (the prompt texts themselves are unused)."""
        image = check_image(image_rgb, self.name)
        wanted = self.vocabulary(prompts)
        columns = [i for i, l in enumerate(self.labels) if self.label_map.get(l) in wanted]
        if not columns:
            self.last_timings = {"detect": 0.0}
            return []
        t0 = time.perf_counter()
        tensor, r = letterbox(image, self.input_size)
        (raw,) = run(self.session, ["output"], {"images": tensor}, f"model {self.name!r}")
        boxes, scores = decode(raw, self.input_size)
        scores = scores[:, columns]
        best = np.argmax(scores, axis=1)
        best_score = scores[np.arange(scores.shape[0]), best]
        keep = best_score >= self.score_threshold
        boxes, best, best_score = boxes[keep] / r, best[keep], best_score[keep]
        h, w = image.shape[:2]
        boxes[:, [0, 2]] = np.clip(boxes[:, [0, 2]], 0, w)
        boxes[:, [1, 3]] = np.clip(boxes[:, [1, 3]], 0, h)
        raw_labels = [self.labels[columns[i]] for i in best]
        classes = [self.label_map[l] for l in raw_labels]
        order = batched_nms(boxes, best_score, classes, self.nms_iou)
        self.last_timings = {"detect": time.perf_counter() - t0}
        return [
            Detection(tuple(boxes[i].tolist()), float(best_score[i]), classes[i], raw_labels[i])  # type: ignore
            for i in order
            if boxes[i, 2] > boxes[i, 0] and boxes[i, 3] > boxes[i, 1]
        ]
