"""Pixel regions of a detection: its mask, or its box when there is no mask.

Image frame: pixels, boxes ``(x1, y1, x2, y2)``, masks ``H x W`` bool.
"""

from __future__ import annotations

import math
from typing import Sequence

import numpy as np


def box_mask(box: Sequence[float], h: int, w: int, shrink: float = 0.0) -> np.ndarray:
    """The box (optionally shrunk by ``shrink`` of its size on each side) as a bool HxW mask."""
    x1, y1, x2, y2 = box
    dx, dy = shrink * (x2 - x1), shrink * (y2 - y1)
    c1, c2 = int(max(0, math.floor(x1 + dx))), int(min(w, math.ceil(x2 - dx)))
    r1, r2 = int(max(0, math.floor(y1 + dy))), int(min(h, math.ceil(y2 - dy)))
    m = np.zeros((h, w), dtype=bool)
    if c2 > c1 and r2 > r1:
        m[r1:r2, c1:c2] = True
    return m


def region_box(mask: np.ndarray | None, box: Sequence[float]) -> tuple[float, float, float, float]:
    """Bounding box ``(x1, y1, x2, y2)`` [px] of the mask's pixels (the box itself without a mask)."""
    if mask is not None and mask.any():
        rows = np.flatnonzero(mask.any(axis=1))
        cols = np.flatnonzero(mask.any(axis=0))
        return (float(cols[0]), float(rows[0]), float(cols[-1] + 1), float(rows[-1] + 1))
    x1, y1, x2, y2 = box
    return (float(x1), float(y1), float(x2), float(y2))


def region_width(mask: np.ndarray | None, box: Sequence[float]) -> float:
    """Width [px] of :func:`region_box`."""
    x1, _, x2, _ = region_box(mask, box)
    return x2 - x1


def region_centre(mask: np.ndarray | None, box: Sequence[float]) -> tuple[float, float]:
    """Pixel centre of the mask's bounding box (the detection box without a mask)."""
    x1, y1, x2, y2 = region_box(mask, box)
    return ((x1 + x2) / 2, (y1 + y2) / 2)


__all__ = ["box_mask", "region_box", "region_centre", "region_width"]
