"""Non-maximum suppression: :mod:`pipeline.models.nms` (OpenCV's ``cv2.dnn.NMSBoxes`` / ``NMSBoxesBatched``)
against the greedy numpy NMS it replaced (kept here as the baseline).

Run from the repository root::

    python bench/nms.py [--sizes 30,100,300,1000] [--repeat 200] [--seed 0]

For random detector-like box sets (image 640 x 480 px, boxes ``(x1, y1, x2, y2)`` [px] in clusters around a
few objects, scores in (0, 1), 8 classes) it prints, per size: whether OpenCV keeps the same boxes (as a set
and in the same order) at IoU thresholds 0.45 and 0.7, plain and class-aware, and the median time of each
with OpenCV's as a ratio against the numpy baseline in the same run.
"""

from __future__ import annotations

import argparse
import os
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

import cv2  # noqa: E402
import numpy as np  # noqa: E402

from pipeline.models.nms import batched_nms, box_iou, nms  # noqa: E402


def numpy_nms(boxes: np.ndarray, scores: np.ndarray, iou_threshold: float) -> np.ndarray:
    """The former greedy NMS (numpy): kept indices, highest score first."""
    order = np.argsort(-scores, kind="stable")
    if order.size == 0:
        return order.astype(np.int64)
    iou = box_iou(boxes[order], boxes[order])
    suppressed = np.zeros(order.size, dtype=bool)
    keep: list[int] = []
    for i in range(order.size):
        if suppressed[i]:
            continue
        keep.append(i)
        suppressed |= iou[i] > iou_threshold
    return order[np.asarray(keep, dtype=np.int64)]


def numpy_batched(boxes: np.ndarray, scores: np.ndarray, classes: np.ndarray, iou_threshold: float) -> np.ndarray:
    """The former class-aware NMS: each class shifted into its own region of the plane, one pass."""
    _, class_ids = np.unique(np.asarray(classes, dtype=object).astype(str), return_inverse=True)
    span = float(np.max(boxes[:, 2:]) - min(np.min(boxes[:, :2]), 0.0)) + 1.0
    return numpy_nms(boxes + (class_ids.astype(np.float64) * span)[:, None], scores, iou_threshold)


def boxes_like_a_detector(rng: np.random.Generator, n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``n`` boxes around ``max(3, n // 10)`` objects, their scores and classes."""
    k = max(3, n // 10)
    centres = rng.uniform((40, 40), (600, 440), size=(k, 2))
    sizes = rng.uniform(20, 200, size=(k, 2))
    which = rng.integers(0, k, size=n)
    c = centres[which] + rng.normal(0, 8, size=(n, 2))
    s = sizes[which] * rng.uniform(0.8, 1.2, size=(n, 2))
    boxes = np.concatenate([c - s / 2, c + s / 2], axis=1)
    scores = rng.uniform(0.05, 1.0, size=n)
    classes = rng.integers(0, 8, size=n)
    return boxes, scores, classes


def median_time(fn, repeat: int) -> float:  # noqa: ANN001
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return float(np.median(times))


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="nms.py", description=__doc__.split("\n\n")[0])
    parser.add_argument("--sizes", default="30,100,300,1000", help="box counts, comma-separated (default 30,100,300,1000)")
    parser.add_argument("--repeat", type=int, default=200, help="timed runs per case (default 200)")
    parser.add_argument("--sets", type=int, default=50, help="random box sets per size for the equality check (default 50)")
    parser.add_argument("--seed", type=int, default=0, help="random seed (default 0)")
    args = parser.parse_args(argv)
    try:
        sizes = [int(v) for v in args.sizes.split(",")]
    except ValueError:
        parser.error(f"--sizes: must be integers separated by commas, got {args.sizes!r}")
    if args.repeat < 1 or args.sets < 1 or any(n < 1 for n in sizes):
        parser.error("--sizes, --repeat and --sets must be >= 1")
    rng = np.random.default_rng(args.seed)
    print(f"OpenCV {cv2.__version__}, numpy {np.__version__}; baseline: the former numpy NMS")
    for n in sizes:
        same_set = same_order = same_set_b = same_order_b = total = 0
        for _ in range(args.sets):
            boxes, scores, classes = boxes_like_a_detector(rng, n)
            for iou in (0.45, 0.7):
                ours, cv = numpy_nms(boxes, scores, iou), nms(boxes, scores, iou)
                ours_b, cv_b = numpy_batched(boxes, scores, classes, iou), batched_nms(boxes, scores, classes, iou)
                total += 1
                same_set += set(ours.tolist()) == set(cv.tolist())
                same_order += ours.tolist() == cv.tolist()
                same_set_b += set(ours_b.tolist()) == set(cv_b.tolist())
                same_order_b += ours_b.tolist() == cv_b.tolist()
        boxes, scores, classes = boxes_like_a_detector(rng, n)
        t_ours = median_time(lambda: numpy_nms(boxes, scores, 0.45), args.repeat)
        t_cv = median_time(lambda: nms(boxes, scores, 0.45), args.repeat)
        t_ours_b = median_time(lambda: numpy_batched(boxes, scores, classes, 0.45), args.repeat)
        t_cv_b = median_time(lambda: batched_nms(boxes, scores, classes, 0.45), args.repeat)
        print(f"{n:5d} boxes: same kept set {same_set}/{total} (same order {same_order}), class-aware "
              f"{same_set_b}/{total} ({same_order_b}); median time numpy {1e3 * t_ours:.3f} ms, OpenCV "
              f"{1e3 * t_cv:.3f} ms = {t_cv / t_ours:.2f}x; class-aware numpy {1e3 * t_ours_b:.3f} ms, "
              f"OpenCV {1e3 * t_cv_b:.3f} ms = {t_cv_b / t_ours_b:.2f}x")
    return 0


if __name__ == "__main__":
    sys.exit(main())
