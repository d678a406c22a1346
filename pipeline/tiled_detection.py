"""Detection on overlapping tiles, for photos much larger than the detector's input.

A detector with a fixed input (YOLOX-Nano: 416 px) shrinks a 1600 px photo about four times, and a
person 40 px tall becomes 10 px: too small to find. :func:`detect_tiled` runs the detector on the
whole image and on overlapping tiles of at most ``tile_px`` a side at their own resolution, moves the
tile boxes into the image frame, drops tile boxes cut by an inner tile border (the object continues
in the next tile; the whole-image pass or a neighbour tile sees it whole) and merges everything with
class-aware NMS (slicing-aided inference, as in SAHI). Pixel boxes ``(x1, y1, x2, y2)`` [px].
"""

from __future__ import annotations

import math
from typing import Sequence

import numpy as np

from pipeline.models.base import Detection, Detector, Prompt
from pipeline.models.nms import batched_nms


def tile_grid(width: int, height: int, tile_px: int, overlap: float = 0.2) -> list[tuple[int, int, int, int]]:
    """Tiles ``(x0, y0, x1, y1)`` [px] of at most ``tile_px`` a side covering a ``width`` x ``height`` image,
    neighbours overlapping by at least ``overlap`` of a tile, spread evenly."""
    if tile_px < 16:
        raise ValueError(f"tile_px must be >= 16, got {tile_px}")
    if not 0 <= overlap < 1:
        raise ValueError(f"overlap must be in [0, 1), got {overlap}")

    def starts(size: int) -> list[int]:
        t = min(tile_px, size)
        if t >= size:
            return [0]
        n = math.ceil((size - t) / (t * (1 - overlap))) + 1
        return [round(i * (size - t) / (n - 1)) for i in range(n)]

    tw, th = min(tile_px, width), min(tile_px, height)
    return [(x, y, x + tw, y + th) for y in starts(height) for x in starts(width)]


def detect_tiled(
    detector: Detector,
    image_rgb: np.ndarray,
    prompts: Sequence[Prompt],
    tile_px: int = 640,
    overlap: float = 0.2,
    nms_iou: float = 0.5,
    min_ratio: float = 1.25,
    edge_px: float = 2.0,
) -> list[Detection]:
    """Detections of ``prompts`` in ``image_rgb``, from the whole image plus tiles (see the module).

    Tiles are used only when the image's longer side exceeds ``min_ratio * tile_px``; otherwise this
    is one plain ``detector.detect`` call.
    """
    h, w = image_rgb.shape[:2]
    found = list(detector.detect(image_rgb, prompts))
    if max(w, h) <= min_ratio * tile_px:
        return found
    for x0, y0, x1, y1 in tile_grid(w, h, tile_px, overlap):
        crop = np.ascontiguousarray(image_rgb[y0:y1, x0:x1])
        inner = (x0 > 0, y0 > 0, x1 < w, y1 < h)  # tile sides inside the image
        for d in detector.detect(crop, prompts):
            bx1, by1, bx2, by2 = d.box
            cut = (
                (inner[0] and bx1 <= edge_px)
                or (inner[1] and by1 <= edge_px)
                or (inner[2] and bx2 >= (x1 - x0) - edge_px)
                or (inner[3] and by2 >= (y1 - y0) - edge_px)
            )
            if not cut:
                found.append(Detection((bx1 + x0, by1 + y0, bx2 + x0, by2 + y0), d.score, d.label, d.prompt))
    if not found:
        return []
    boxes = np.array([d.box for d in found])
    keep = batched_nms(boxes, np.array([d.score for d in found]), [d.label for d in found], nms_iou)
    return [found[i] for i in keep]
