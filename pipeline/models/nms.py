"""Non-maximum suppression over ``(x1, y1, x2, y2)`` boxes [px]: OpenCV's ``cv2.dnn.NMSBoxes`` /
``NMSBoxesBatched``, and the pairwise IoU in numpy.

OpenCV keeps the same boxes in the same order as the greedy numpy NMS this replaced and is 3 to 130
times faster (30 to 1000 boxes; ``python bench/nms.py`` measures both in one run). OpenCV ranks by float32
scores and drops scores <= its threshold, so it is given each box's rank in the stable descending score order
(exact, all above 0) instead of the score: ties keep the input order, as before.
"""

from __future__ import annotations

from typing import Sequence

import cv2
import numpy as np


def box_iou(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Pairwise IoU of boxes ``a`` (N, 4) and ``b`` (M, 4) -> (N, M)."""
    a = np.asarray(a, dtype=np.float64).reshape(-1, 4)
    b = np.asarray(b, dtype=np.float64).reshape(-1, 4)
    lt = np.maximum(a[:, None, :2], b[None, :, :2])
    rb = np.minimum(a[:, None, 2:], b[None, :, 2:])
    inter = np.prod(np.clip(rb - lt, 0.0, None), axis=2)
    area_a = np.prod(np.clip(a[:, 2:] - a[:, :2], 0.0, None), axis=1)
    area_b = np.prod(np.clip(b[:, 2:] - b[:, :2], 0.0, None), axis=1)
    union = area_a[:, None] + area_b[None, :] - inter
    return np.where(union > 0, inter / np.where(union > 0, union, 1.0), 0.0)


def _cv_inputs(boxes: np.ndarray, scores: np.ndarray) -> tuple[list[list[float]], list[float]]:
    """``(x, y, w, h)`` boxes (negative sizes clipped to 0: no area) and the rank scores for OpenCV."""
    xywh = np.concatenate([boxes[:, :2], np.clip(boxes[:, 2:] - boxes[:, :2], 0.0, None)], axis=1)
    order = np.argsort(-scores, kind="stable")
    rank = np.empty(scores.shape[0], dtype=np.float64)
    rank[order] = np.arange(scores.shape[0], 0, -1, dtype=np.float64)  # best = n ... worst = 1 (exact in float32)
    return xywh.tolist(), rank.tolist()


def _checked(boxes: np.ndarray, scores: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    boxes = np.asarray(boxes, dtype=np.float64).reshape(-1, 4)
    scores = np.asarray(scores, dtype=np.float64).reshape(-1)
    if boxes.shape[0] != scores.shape[0]:
        raise ValueError(f"nms: {boxes.shape[0]} boxes but {scores.shape[0]} scores")
    return boxes, scores


def nms(boxes: np.ndarray, scores: np.ndarray, iou_threshold: float) -> np.ndarray:
    """Indices of the boxes kept by greedy NMS, highest score first (``cv2.dnn.NMSBoxes``).

    A box is dropped when its IoU with an already kept, higher-scoring box is > ``iou_threshold``.
    """
    boxes, scores = _checked(boxes, scores)
    if boxes.shape[0] == 0:
        return np.zeros(0, dtype=np.int64)
    xywh, rank = _cv_inputs(boxes, scores)
    keep = cv2.dnn.NMSBoxes(xywh, rank, 0.0, float(iou_threshold))
    return np.asarray(keep, dtype=np.int64).reshape(-1)


def batched_nms(
    boxes: np.ndarray, scores: np.ndarray, classes: Sequence[object] | np.ndarray, iou_threshold: float
) -> np.ndarray:
    """Class-aware NMS: boxes of different classes never suppress each other (``cv2.dnn.NMSBoxesBatched``).

    ``classes`` may hold ints or strings. Returns kept indices, highest score first.
    """
    boxes, scores = _checked(boxes, scores)
    if boxes.shape[0] == 0:
        return np.zeros(0, dtype=np.int64)
    _, class_ids = np.unique(np.asarray(classes, dtype=object).astype(str), return_inverse=True)
    xywh, rank = _cv_inputs(boxes, scores)
    keep = cv2.dnn.NMSBoxesBatched(xywh, rank, class_ids.reshape(-1).astype(int).tolist(), 0.0, float(iou_threshold))
    return np.asarray(keep, dtype=np.int64).reshape(-1)
