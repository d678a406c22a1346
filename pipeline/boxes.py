"""Parsing 2D image boxes ``(x1, y1, x2, y2)`` [px] (x right, y down), shared by models and geometry."""

from __future__ import annotations

import math
from typing import Sequence

Box4 = tuple[float, float, float, float]


class BoxError(ValueError):
    """A malformed box: not four numbers, not finite, or inverted."""


def parse_box(box: Sequence[float], allow_empty: bool = False) -> Box4:
    """``box`` as four finite floats with ``x2 > x1`` and ``y2 > y1`` (``>=`` with ``allow_empty``)."""
    try:
        x1, y1, x2, y2 = (float(v) for v in box)
    except (TypeError, ValueError):
        raise BoxError(f"a box is 4 numbers (x1, y1, x2, y2) [px], got {box!r}") from None
    if not all(math.isfinite(v) for v in (x1, y1, x2, y2)):
        raise BoxError(f"box has non-finite coordinates: {box!r}")
    if (x2 < x1 or y2 < y1) if allow_empty else (x2 <= x1 or y2 <= y1):
        op = "<=" if allow_empty else "<"
        raise BoxError(f"box must have x1 {op} x2 and y1 {op} y2, got {box!r}")
    return x1, y1, x2, y2


def clip_box(box: Box4, width: int, height: int) -> Box4 | None:
    """The part of ``box`` inside a ``width`` x ``height`` image, ``None`` when nothing is left."""
    x1, y1, x2, y2 = box
    cx1, cx2 = min(max(x1, 0.0), width), min(max(x2, 0.0), width)
    cy1, cy2 = min(max(y1, 0.0), height), min(max(y2, 0.0), height)
    return (cx1, cy1, cx2, cy2) if cx2 > cx1 and cy2 > cy1 else None
