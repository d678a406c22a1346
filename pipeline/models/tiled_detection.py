"""Detection on overlapping tiles, for photos much larger than the detector's input.

A detector with a fixed input (YOLOX-Nano: 416 px) shrinks a 1600 px photo about four times, and a
person 40 px tall becomes 10 px: too small to find. :func:`detect_tiled` runs the detector on the
whole image and on overlapping tiles of at most ``tile_px`` a side at their own resolution, moves the
tile boxes into the image frame, drops tile boxes cut by an inner tile border (the object continues
in the next tile; the whole-image pass or a neighbour tile sees it whole) and merges everything with
class-aware NMS (slicing-aided inference, as in SAHI). Pixel boxes ``(x1, y1, x2, y2)`` [px].

:func:`detect_planned` is what the mapper calls: each member of a merged detector
(:class:`pipeline.models.ssd.MergedDetector`) is tiled to its own input size, then the members'
detections are merged by the merged detector's rules. A detector that *stretches* the whole image
to a square input (``stretches_input``, the Open Images SSD: a 1600 x 900 nuScenes or 1242 x 375
KITTI photo squeezed to 300 x 300) is also run on square windows of the image's short side (aspect
kept), and its tiles are square.
"""

from __future__ import annotations

import math
from typing import Sequence

import numpy as np

from pipeline.models.base import Detection, Detector, Prompt
from pipeline.models.nms import batched_nms


def tile_grid(width: int, height: int, tile_px: int, overlap: float = 0.2,
              square: bool = False) -> list[tuple[int, int, int, int]]:
    """Tiles ``(x0, y0, x1, y1)`` [px] of at most ``tile_px`` a side covering a ``width`` x ``height`` image,
    neighbours overlapping by at least ``overlap`` of a tile, spread evenly. ``square``: every tile is
    square, of side ``min(tile_px, width, height)``."""
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

    if square:
        tile_px = min(tile_px, width, height)
    tw, th = min(tile_px, width), min(tile_px, height)
    return [(x, y, x + tw, y + th) for y in starts(height) for x in starts(width)]


def tile_detections(
    detector: Detector,
    image_rgb: np.ndarray,
    prompts: Sequence[Prompt],
    tile_px: int,
    overlap: float = 0.2,
    edge_px: float = 2.0,
    square: bool = False,
) -> list[Detection]:
    """Detections on the tiles of :func:`tile_grid` only (no whole-image pass), in the image frame; a
    box within ``edge_px`` of an inner tile side is dropped (the object goes on in the next tile)."""
    h, w = image_rgb.shape[:2]
    found: list[Detection] = []
    for x0, y0, x1, y1 in tile_grid(w, h, tile_px, overlap, square):
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
    return found


def merge_detections(found: list[Detection], nms_iou: float) -> list[Detection]:
    """``found`` after class-aware NMS at ``nms_iou`` (boxes [px] in one image frame), best first."""
    if not found:
        return []
    boxes = np.array([d.box for d in found])
    keep = batched_nms(boxes, np.array([d.score for d in found]), [d.label for d in found], nms_iou)
    return [found[i] for i in keep]


def detect_tiled(
    detector: Detector,
    image_rgb: np.ndarray,
    prompts: Sequence[Prompt],
    tile_px: int = 640,
    overlap: float = 0.2,
    nms_iou: float = 0.5,
    min_ratio: float = 1.25,
    edge_px: float = 2.0,
    square: bool = False,
) -> list[Detection]:
    """Detections of ``prompts`` in ``image_rgb``, from the whole image plus tiles (see the module).

    Tiles are used only when the image's longer side exceeds ``min_ratio * tile_px``; otherwise this
    is one plain ``detector.detect`` call. ``square``: square tiles (:func:`tile_grid`), for a
    detector that stretches its input.
    """
    h, w = image_rgb.shape[:2]
    found = list(detector.detect(image_rgb, prompts))
    if max(w, h) <= min_ratio * tile_px:
        return found
    tiles = tile_detections(detector, image_rgb, prompts, tile_px, overlap, edge_px, square)
    return merge_detections(found + tiles, nms_iou)


def member_tile_px(detector: object, tile_factor: float | None) -> int | None:
    """Tile side [px] for ``detector``: ``tile_factor`` (its own ``tile_factor`` attribute when it has
    one, ``None`` there meaning no tiles) times the larger side of its ``input_size``; ``None`` without
    a fixed input size or a factor."""
    factor = getattr(detector, "tile_factor", tile_factor)
    size = getattr(detector, "input_size", None)
    if factor is None or not isinstance(size, (tuple, list)) or not size:
        return None
    try:
        side = max(int(v) for v in size)
    except (TypeError, ValueError):
        return None
    return max(64, int(round(float(factor) * side)))


def detect_planned(
    detector: Detector, image_rgb: np.ndarray, prompts: Sequence[Prompt], tile_factor: float | None = 1.5,
    min_ratio: float = 1.25, window_ratio: float = 1.5,
) -> list[Detection]:
    """Detections of ``prompts`` in ``image_rgb`` with each detector tiled to its own input size.

    - A merged detector (``members`` and ``merge``): each member detected on its own (recursively),
      then ``detector.merge(per_member_detections, prompts)``.
    - A detector with a fixed ``input_size``: :func:`detect_tiled` with tiles of
      :func:`member_tile_px` (its ``tile_factor`` attribute overrides ``tile_factor``).
    - A detector that stretches its input (``stretches_input`` true): also square windows of the
      short side when the image's aspect ratio exceeds ``window_ratio`` (16:9 nuScenes, 3.3:1 KITTI;
      a 4:3 photo stays whole: one run, the mapping-speed budget at 640 x 480), and square tiles.
    - Otherwise one plain ``detector.detect`` call.
    """
    members = getattr(detector, "members", None)
    if members and callable(getattr(detector, "merge", None)):
        per_member = [detect_planned(m, image_rgb, prompts, tile_factor, min_ratio, window_ratio) for m in members]
        return list(detector.merge(per_member, prompts))  # type: ignore[attr-defined]
    stretches = bool(getattr(detector, "stretches_input", False))
    tile_px = member_tile_px(detector, tile_factor)
    h, w = image_rgb.shape[:2]
    if not stretches:
        if tile_px is None:
            return list(detector.detect(image_rgb, prompts))
        return detect_tiled(detector, image_rgb, prompts, tile_px, min_ratio=min_ratio)
    found = list(detector.detect(image_rgb, prompts))
    short = min(w, h)
    if max(w, h) > window_ratio * short:  # square windows of the short side: the aspect ratio kept
        found += tile_detections(detector, image_rgb, prompts, short, square=True)
    if tile_px is not None and max(w, h) > min_ratio * tile_px and tile_px < short:
        found += tile_detections(detector, image_rgb, prompts, tile_px, square=True)
    return merge_detections(found, 0.5)
