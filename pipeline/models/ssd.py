"""SSD MobileNetV2 detector with the Open Images (OIDv4) 23-class head (MediaPipe Objectron stage 1), and
a detector that merges two closed-vocabulary detectors.

The model (``oidv4_ssd/oidv4_ssd.onnx``, see ``../shared/models/README.md``): input
``normalized_input_image_tensor`` float32 ``[1, 3, 300, 300]``, the whole RGB image *stretched* to
300 x 300 (bilinear, no letterbox), ``x / 127.5 - 1``; outputs ``boxes`` ``[1, 1917, 4]`` (x0, y0, x1,
y1 normalised to the original image) and ``scores`` ``[1, 1917, 24]`` (sigmoid; column 0 is the
background). Per class: scores above the threshold, class-wise NMS (IoU 0.45).

Its vocabulary (Desk, Box, Table, Computer monitor, Laptop, Mug, ...) complements COCO's: the
:class:`MergedDetector` runs both and keeps, per class, the best of overlapping boxes.
"""

from __future__ import annotations

import time
from pathlib import Path
from typing import Mapping, Sequence

import cv2
import numpy as np

from pipeline.models.base import Detection, ModelError, Prompt, check_image, closed_vocabulary
from pipeline.models.nms import batched_nms
from pipeline.models.session import IOSignature, TensorSpec, open_session, run
from pipeline.models.yolox import read_labels

INPUT = "normalized_input_image_tensor"
SIGNATURE = IOSignature(
    inputs=(TensorSpec(INPUT, 4, (1, 3, 300, 300)),),
    outputs=(TensorSpec("boxes", 3, (1, None, 4)), TensorSpec("scores", 3, (1, None, None))),
)
DEFAULT_SCORE_THRESHOLD = 0.3
"""Minimum class score (the threshold the model's README used; its best indoor scores are ~0.66)."""


def preprocess(image_rgb: np.ndarray, size: tuple[int, int] = (300, 300)) -> np.ndarray:
    """``[1, 3, H, W]`` float32: the whole image stretched to ``size`` (h, w), scaled to -1..1."""
    x = cv2.resize(image_rgb, (size[1], size[0]), interpolation=cv2.INTER_LINEAR).astype(np.float32) / 127.5 - 1.0
    return np.ascontiguousarray(x.transpose(2, 0, 1)[None])


class SsdDetector:
    """Closed-vocabulary SSD (OIDv4 labels).

    Args:
        model_path: The ``.onnx`` file (decoded boxes and scores).
        labels: Label of each score column, column 0 the background.
        label_map: Backend label -> class name; labels not in it are ignored. ``None``: identity.
        score_threshold: Minimum class score.
        nms_iou: IoU above which a lower-scoring box of the same class is dropped.
        threads: onnxruntime intra-op threads.
    """

    def __init__(self, model_path: Path | str, labels: Sequence[str], label_map: Mapping[str, str] | None = None, *,
                 score_threshold: float = DEFAULT_SCORE_THRESHOLD, nms_iou: float = 0.45,
                 threads: int | None = None, name: str = "oidv4_ssd") -> None:
        self.name = name
        self.score_threshold = float(score_threshold)
        self.nms_iou = float(nms_iou)
        self.labels = list(labels)
        self.label_map: dict[str, str] = dict(label_map) if label_map is not None else {l: l for l in self.labels[1:]}
        self.session = open_session(model_path, SIGNATURE, threads=threads, model_name=name)
        cols = self.session.get_outputs()[1].shape[2]
        if isinstance(cols, int) and cols != len(self.labels):
            raise ModelError(f"model {name!r}: scores have {cols} columns but {len(self.labels)} labels were given")
        self.last_timings: dict[str, float] = {}

    @classmethod
    def from_dir(cls, model_dir: Path | str, label_map: Mapping[str, str] | None = None, **kwargs: object) -> SsdDetector:
        """Load ``oidv4_ssd.onnx`` and ``labelmap.txt`` from ``model_dir``."""
        model_dir = Path(model_dir)
        labels = read_labels(model_dir / "labelmap.txt", str(kwargs.get("name", "oidv4_ssd")))
        return cls(model_dir / "oidv4_ssd.onnx", labels, label_map, **kwargs)  # type: ignore[arg-type]

    def vocabulary(self, prompts: Sequence[Prompt]) -> frozenset[str]:
        """Class names of ``prompts`` that some backend label maps to."""
        return closed_vocabulary(prompts, self.label_map, self.name)

    def detect(self, image_rgb: np.ndarray, prompts: Sequence[Prompt]) -> list[Detection]:
        """Detections of the prompts' classes, best first."""
        image = check_image(image_rgb, self.name)
        wanted = self.vocabulary(prompts)
        columns = [i for i, l in enumerate(self.labels) if i > 0 and self.label_map.get(l) in wanted]
        if not columns:
            self.last_timings = {"detect": 0.0}
            return []
        t0 = time.perf_counter()
        h, w = image.shape[:2]
        boxes, scores = run(self.session, ["boxes", "scores"], {INPUT: preprocess(image)}, f"model {self.name!r}")
        boxes = np.asarray(boxes, dtype=np.float64)[0] * np.array([w, h, w, h])
        boxes[:, [0, 2]] = np.clip(boxes[:, [0, 2]], 0, w)
        boxes[:, [1, 3]] = np.clip(boxes[:, [1, 3]], 0, h)
        scores = np.asarray(scores, dtype=np.float64)[0]
        out_b, out_s, out_l = [], [], []
        for c in columns:  # one box may be kept for several classes (a desk is also a table), as MediaPipe does
            keep = scores[:, c] > self.score_threshold
            if keep.any():
                out_b.append(boxes[keep])
                out_s.append(scores[keep, c])
                out_l += [self.labels[c]] * int(keep.sum())
        if not out_b:
            self.last_timings = {"detect": time.perf_counter() - t0}
            return []
        b, s = np.concatenate(out_b), np.concatenate(out_s)
        classes = [self.label_map[l] for l in out_l]
        order = batched_nms(b, s, classes, self.nms_iou)
        self.last_timings = {"detect": time.perf_counter() - t0}
        return [Detection(tuple(b[i].tolist()), float(s[i]), classes[i], out_l[i])  # type: ignore[arg-type]
                for i in order if b[i, 2] > b[i, 0] and b[i, 3] > b[i, 1]]


class MergedDetector:
    """Two detectors run on the same image; their detections merged class-aware (a class's overlapping
    boxes from both keep only the best, IoU ``nms_iou``). ``input_size`` (tiling) is the first one's.

    Each detector's ``label_map`` stays its own; :attr:`labels` / :attr:`label_map` are not exposed, so the
    mapper's label mapping is done per member before merging."""

    def __init__(self, first: object, second: object, nms_iou: float = 0.5) -> None:
        self.members = (first, second)
        self.name = f"{getattr(first, 'name', 'detector')}+{getattr(second, 'name', 'detector')}"
        self.score_threshold = min(float(getattr(first, "score_threshold", 0.0)),
                                   float(getattr(second, "score_threshold", 0.0)))
        self.nms_iou = float(nms_iou)
        size = getattr(first, "input_size", None)
        if size is not None:
            self.input_size = size
        self.last_timings: dict[str, float] = {}

    def vocabulary(self, prompts: Sequence[Prompt]) -> frozenset[str]:
        """The union of the members' vocabularies."""
        return frozenset().union(*(m.vocabulary(prompts) for m in self.members))  # type: ignore[attr-defined]

    def detect(self, image_rgb: np.ndarray, prompts: Sequence[Prompt]) -> list[Detection]:
        """Both members' detections, class-aware NMS over the union, best first."""
        t0 = time.perf_counter()
        dets = [d for m in self.members for d in m.detect(image_rgb, prompts)]  # type: ignore[attr-defined]
        self.last_timings = {"detect": time.perf_counter() - t0}
        if not dets:
            return []
        order = batched_nms(np.array([d.box for d in dets], dtype=np.float64), np.array([d.score for d in dets]),
                            [d.label for d in dets], self.nms_iou)
        return [dets[i] for i in order]


__all__ = ["DEFAULT_SCORE_THRESHOLD", "MergedDetector", "SIGNATURE", "SsdDetector", "preprocess"]
