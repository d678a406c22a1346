"""OpenCV's NMS (pipeline.models.nms) keeps exactly what the greedy numpy NMS it replaced kept, in the same order."""

from __future__ import annotations

import numpy as np
import pytest

from pipeline.models.nms import batched_nms, box_iou, nms


def greedy(boxes: np.ndarray, scores: np.ndarray, iou_threshold: float) -> list[int]:
    """The former implementation: stable descending score order, drop IoU > threshold with a kept box."""
    order = np.argsort(-scores, kind="stable")
    iou = box_iou(boxes[order], boxes[order])
    suppressed = np.zeros(order.size, dtype=bool)
    keep = []
    for i in range(order.size):
        if not suppressed[i]:
            keep.append(int(order[i]))
            suppressed |= iou[i] > iou_threshold
    return keep


def clustered(rng: np.random.Generator, n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    k = max(3, n // 10)
    centres, sizes = rng.uniform(40, 440, (k, 2)), rng.uniform(20, 200, (k, 2))
    which = rng.integers(0, k, n)
    c = centres[which] + rng.normal(0, 8, (n, 2))
    s = sizes[which] * rng.uniform(0.8, 1.2, (n, 2))
    return np.hstack([c - s / 2, c + s / 2]), rng.uniform(0.05, 1.0, n), rng.integers(0, 4, n)


@pytest.mark.parametrize("n", [1, 7, 60, 250])
@pytest.mark.parametrize("iou", [0.3, 0.45, 0.7])
def test_opencv_nms_equals_the_greedy_reference(n: int, iou: float) -> None:
    rng = np.random.default_rng(n)
    for _ in range(5):
        boxes, scores, classes = clustered(rng, n)
        assert nms(boxes, scores, iou).tolist() == greedy(boxes, scores, iou)
        by_class = {c: np.flatnonzero(classes == c) for c in np.unique(classes)}
        expected = sorted((int(idx[k]) for c, idx in by_class.items() for k in greedy(boxes[idx], scores[idx], iou)),
                          key=lambda i: (-scores[i], i))
        assert batched_nms(boxes, scores, classes, iou).tolist() == expected


def test_ties_zero_scores_and_empty_boxes_keep_the_input_order() -> None:
    boxes = np.array([[0, 0, 10, 10], [0, 0, 10, 10], [30, 30, 30, 40], [50, 50, 60, 60]], float)
    scores = np.array([0.0, 0.0, 0.5, 0.0])  # ties and zero scores (OpenCV alone would drop scores <= 0)
    assert nms(boxes, scores, 0.5).tolist() == [2, 0, 3]  # the zero-width box suppresses nothing
    with pytest.raises(ValueError, match="2 boxes but 1 scores"):
        nms(boxes[:2], scores[:1], 0.5)
