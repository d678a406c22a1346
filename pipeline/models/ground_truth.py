"""Ground-truth perception: the Detector / Segmenter / DepthEstimator interfaces served from given arrays.

For images whose objects are known: the simulated robot's renders (boxes, instance masks and metric
depth come out of the renderer) and the benchmark's ``--gt-boxes`` mode (the dataset's own 2D boxes).
Every backend name starts with ``ground-truth perception`` so a scene's ``capture.models`` never
passes these for a model's output.

Pixels: ``(x1, y1, x2, y2)`` boxes [px] (x right, y down); masks ``bool`` HxW; depth along the optical
axis [m] (camera frame z), ``<= 0`` / NaN where unknown (e.g. sky).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

import numpy as np

from pipeline.models.base import Box, DepthMap, Detection, Mask, ModelError, Prompt, check_image, check_prompts
from pipeline.models.nms import box_iou

GT_NAME = "ground-truth perception"
"""Prefix of every ground-truth backend name (written into ``capture.models``)."""


class GroundTruthDetector:
    """Reports the given boxes as detections (score 1 unless given), filtered to the prompts' classes.

    Args:
        boxes: ``N x 4`` boxes [px].
        labels: ``N`` class names (catalog class names).
        scores: Optional ``N`` confidences in ``[0, 1]`` (default 1).
        name: Backend name; keep the ``ground-truth perception`` prefix.
    """

    score_threshold: float = 0.0

    def __init__(
        self,
        boxes: Sequence[Sequence[float]] | np.ndarray,
        labels: Sequence[str],
        scores: Sequence[float] | None = None,
        name: str = f"{GT_NAME} (boxes)",
    ) -> None:
        b = np.asarray(boxes, dtype=np.float64).reshape(-1, 4) if len(boxes) else np.zeros((0, 4))
        if len(labels) != b.shape[0]:
            raise ModelError(f"{name}: {b.shape[0]} boxes but {len(labels)} labels")
        s = np.ones(b.shape[0]) if scores is None else np.asarray(scores, dtype=np.float64).reshape(-1)
        if s.shape[0] != b.shape[0]:
            raise ModelError(f"{name}: {b.shape[0]} boxes but {s.shape[0]} scores")
        # Detection validates each box (finite, x1 <= x2, y1 <= y2)
        self._detections = [
            Detection(tuple(bb), float(sc), str(lb), str(lb)) for bb, sc, lb in zip(b.tolist(), s, labels)  # type: ignore[arg-type]
        ]
        self.name = name

    def vocabulary(self, prompts: Sequence[Prompt]) -> frozenset[str]:
        """Every class of ``prompts``: ground truth can name anything."""
        return frozenset(c for _, c in check_prompts(prompts, self.name))

    def detect(self, image_rgb: np.ndarray, prompts: Sequence[Prompt]) -> list[Detection]:
        """The given boxes whose class is among ``prompts``' classes, clipped to the image, best first."""
        image = check_image(image_rgb, self.name)
        h, w = image.shape[:2]
        wanted = self.vocabulary(prompts)
        out = []
        for d in self._detections:
            if d.label not in wanted:
                continue
            x1, y1, x2, y2 = d.box
            x1, x2 = min(max(x1, 0.0), w), min(max(x2, 0.0), w)
            y1, y2 = min(max(y1, 0.0), h), min(max(y2, 0.0), h)
            if x2 > x1 and y2 > y1:
                out.append(Detection((x1, y1, x2, y2), d.score, d.label, d.prompt))
        return sorted(out, key=lambda d: -d.score)


class GroundTruthSegmenter:
    """Answers a box prompt with the given instance mask whose bounding box best overlaps it.

    Args:
        masks: ``N`` boolean HxW instance masks, or one integer HxW instance-id image (0 = none).
        name: Backend name; keep the ``ground-truth perception`` prefix.
    """

    def __init__(self, masks: Sequence[np.ndarray] | np.ndarray, name: str = f"{GT_NAME} (masks)") -> None:
        self.name = name
        if isinstance(masks, np.ndarray) and masks.ndim == 2:  # instance-id image
            stack = [masks == i for i in np.unique(masks) if i != 0]
        else:
            stack = [np.asarray(m, dtype=bool) for m in masks]
        if any(m.ndim != 2 or m.shape != stack[0].shape for m in stack):
            raise ModelError(f"{name}: masks must all be HxW arrays of one size")
        self._masks = stack
        self._boxes = np.array([_mask_box(m) for m in stack]).reshape(-1, 4)
        self._hw: tuple[int, int] | None = None
        self.last_timings: dict[str, float] = {}

    def set_image(self, image_rgb: np.ndarray) -> None:
        """Check that the image matches the masks' size."""
        image = check_image(image_rgb, self.name)
        hw = (image.shape[0], image.shape[1])
        if self._masks and self._masks[0].shape != hw:
            raise ModelError(f"{self.name}: masks are {self._masks[0].shape[::-1]} but the image is {hw[::-1]}")
        self._hw = hw
        self.last_timings = {"encoder": 0.0, "decoder": 0.0}

    def segment_box(self, box: Box) -> Mask:
        """The instance mask best matching ``box`` (an empty mask when none overlaps it)."""
        if self._hw is None:
            raise ModelError(f"{self.name}: call set_image() before segment_box()")
        b = np.asarray(box, dtype=np.float64).reshape(1, 4)
        if self._boxes.shape[0]:
            iou = box_iou(b, self._boxes)[0]
            best = int(np.argmax(iou))
            if iou[best] > 0:
                return Mask(self._masks[best].copy(), 1.0, tuple(float(v) for v in box))  # type: ignore[arg-type]
        return Mask(np.zeros(self._hw, dtype=bool), 0.0, tuple(float(v) for v in box))  # type: ignore[arg-type]

    def segment(self, image_rgb: np.ndarray, boxes: Sequence[Box]) -> list[Mask]:
        """Masks for ``boxes``."""
        self.set_image(image_rgb)
        return [self.segment_box(b) for b in boxes]


class GroundTruthDepth:
    """Serves the given metric depth map [m] (camera-frame z); kind ``metric``."""

    kind = "metric"
    exact = True  # the mapper neither rescales it nor lets size priors override it

    def __init__(self, depth_m: np.ndarray, name: str = f"{GT_NAME} (depth)") -> None:
        d = np.asarray(depth_m, dtype=np.float32)
        if d.ndim != 2:
            raise ModelError(f"{name}: depth must be an HxW array [m], got shape {d.shape}")
        self._depth = np.where(np.isfinite(d) & (d > 0), d, 0.0).astype(np.float32)
        self.name = name
        self.last_timings: dict[str, float] = {}

    def estimate(self, image_rgb: np.ndarray) -> DepthMap:
        """The given depth map (it must match the image size)."""
        image = check_image(image_rgb, self.name)
        if image.shape[:2] != self._depth.shape:
            raise ModelError(f"{self.name}: depth is {self._depth.shape[::-1]} but the image is {image.shape[1::-1]}")
        return DepthMap(self._depth, "metric")


@dataclass(frozen=True)
class GroundTruthBundle:
    """The three ground-truth backends, shaped like the model registry's bundle."""

    detector: GroundTruthDetector
    segmenter: GroundTruthSegmenter | None = None
    depth: GroundTruthDepth | None = None


def ground_truth_bundle(
    boxes: Sequence[Sequence[float]] | np.ndarray,
    labels: Sequence[str],
    masks: Sequence[np.ndarray] | np.ndarray | None = None,
    depth_m: np.ndarray | None = None,
    scores: Sequence[float] | None = None,
) -> GroundTruthBundle:
    """Ground-truth perception from a renderer's (or a dataset's) arrays; see the module docstring."""
    return GroundTruthBundle(
        GroundTruthDetector(boxes, labels, scores),
        None if masks is None else GroundTruthSegmenter(masks),
        None if depth_m is None else GroundTruthDepth(depth_m),
    )


def _mask_box(mask: np.ndarray) -> tuple[float, float, float, float]:
    ys, xs = np.nonzero(mask)
    if xs.size == 0:
        return (0.0, 0.0, 0.0, 0.0)
    return (float(xs.min()), float(ys.min()), float(xs.max() + 1), float(ys.max() + 1))
