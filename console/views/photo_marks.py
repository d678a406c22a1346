"""Readable marks on the camera panel's pictures: detection labels that never pile up, a depth scale.

Pure picture helpers (NumPy / OpenCV, RGB uint8 images, pixel coordinates x right, y down).

- :func:`photo_labels` gives one label per cluster of touching same-class boxes (a stack of 19
  cardboard boxes reads ``cardboard box ×19``) and leaves out any label that would overlap one
  already placed, instead of printing them on top of each other.
- :func:`depth_colorbar` draws the depth picture's colour scale with ticks in metres.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable, Sequence

import cv2
import numpy as np

Box = tuple[float, float, float, float]  # x1, y1, x2, y2 [px]
FONT = cv2.FONT_HERSHEY_SIMPLEX
FONT_SCALE = 0.45
TOUCH_PX = 3.0  # boxes this close (or overlapping) belong to one cluster [px]
BAR_WIDTH = 96  # width of the depth scale picture [px]
TICK_SCALE = 0.55  # font scale of its tick labels


@dataclass(frozen=True)
class PhotoLabel:
    """One label to print on the photo.

    Attributes:
        label: Class name of the cluster.
        text: What is printed (``cardboard box ×4``, ``desk 0.93``).
        rect: Background rectangle ``(x1, y1, x2, y2)`` [px] of the text in the picture.
        count: How many detections the label stands for.
    """

    label: str
    text: str
    rect: tuple[int, int, int, int]
    count: int


def _touch(a: Box, b: Box, gap: float = TOUCH_PX) -> bool:
    return a[0] <= b[2] + gap and b[0] <= a[2] + gap and a[1] <= b[3] + gap and b[1] <= a[3] + gap


def _overlap(a: Sequence[int], b: Sequence[int]) -> bool:
    return a[0] < b[2] and b[0] < a[2] and a[1] < b[3] and b[1] < a[3]


def box_clusters(detections: Sequence[tuple[str, float, Box]]) -> list[list[int]]:
    """Indices of the detections grouped by class and touching boxes (chained), input order kept."""
    parent = list(range(len(detections)))

    def find(i: int) -> int:
        while parent[i] != i:
            parent[i] = parent[parent[i]]
            i = parent[i]
        return i

    for i, (li, _, bi) in enumerate(detections):
        for j in range(i):
            lj, _, bj = detections[j]
            if li == lj and _touch(bi, bj):
                parent[find(i)] = find(j)
    groups: dict[int, list[int]] = {}
    for i in range(len(detections)):
        groups.setdefault(find(i), []).append(i)
    return list(groups.values())


def _measure(text: str) -> tuple[int, int, int]:
    (tw, th), base = cv2.getTextSize(text, FONT, FONT_SCALE, 1)
    return tw, th, base


def photo_labels(detections: Sequence[tuple[str, float, Box]], width: int, height: int,
                 measure: Callable[[str], tuple[int, int, int]] = _measure) -> tuple[list[PhotoLabel], int]:
    """Where to print the detection labels on a ``width`` x ``height`` picture, none overlapping.

    Args:
        detections: ``(label, score, box)`` per detection, boxes in the picture's pixels.
        width: Picture width [px].
        height: Picture height [px].
        measure: ``text -> (width, height, baseline)`` [px] of the printed text.

    Returns:
        The labels to print (best score first) and how many clusters got no label because every
        place for it overlapped a label already placed.
    """
    placed: list[PhotoLabel] = []
    skipped = 0
    clusters = box_clusters(detections)
    clusters.sort(key=lambda c: -max(detections[i][1] for i in c))
    for members in clusters:
        label = detections[members[0]][0]
        boxes = np.array([detections[i][2] for i in members], dtype=np.float64)
        x1, y1 = boxes[:, 0].min(), boxes[:, 1].min()
        x2, y2 = boxes[:, 2].max(), boxes[:, 3].max()
        name = label.replace("_", " ")
        text = f"{name} ×{len(members)}" if len(members) > 1 else f"{name} {detections[members[0]][1]:.2f}"
        tw, th, base = measure(text)
        w, h = tw + 4, th + base + 4
        left = int(round(min(max(x1, 0), max(width - w, 0))))
        spots = (y1 - h - 1, y1 + 1, y2 + 1)  # above the box, inside its top, below it
        rect = None
        for top in spots:
            t = int(round(top))
            if t < 0 or t + h > height:
                continue
            r = (left, t, left + w, t + h)
            if not any(_overlap(r, p.rect) for p in placed):
                rect = r
                break
        if rect is None:
            skipped += 1
            continue
        placed.append(PhotoLabel(label, text, rect, len(members)))
    return placed, skipped


def draw_labels(img: np.ndarray, labels: Sequence[PhotoLabel], colors: Callable[[str], tuple[int, int, int]]) -> None:
    """Print ``labels`` on ``img`` (RGB, in place), each on a background of its class colour."""
    for lab in labels:
        rgb = tuple(int(v) for v in colors(lab.label))
        x1, y1, x2, y2 = lab.rect
        cv2.rectangle(img, (x1, y1), (x2 - 1, y2 - 1), rgb, -1)
        lum = 0.299 * rgb[0] + 0.587 * rgb[1] + 0.114 * rgb[2]
        _, th, _ = _measure(lab.text)
        cv2.putText(img, lab.text, (x1 + 2, y1 + 2 + th), FONT, FONT_SCALE,
                    (0, 0, 0) if lum > 150 else (255, 255, 255), 1, cv2.LINE_AA)


def depth_colors(values: np.ndarray, near: float, far: float) -> np.ndarray:
    """RGB colours (N x 3 uint8) of depths [m] on the depth picture's scale: near = warm (red)."""
    v = np.asarray(values, dtype=np.float64).reshape(-1)
    norm = np.clip((v - near) / max(far - near, 1e-6), 0.0, 1.0)
    u8 = (255 * (1.0 - norm)).astype(np.uint8).reshape(-1, 1)
    return cv2.cvtColor(cv2.applyColorMap(u8, cv2.COLORMAP_TURBO), cv2.COLOR_BGR2RGB).reshape(-1, 3)


def nice_ticks(near: float, far: float, count: int = 5) -> list[float]:
    """About ``count`` round tick values [m] within ``[near, far]`` (steps of 1, 2 or 5 x 10^k)."""
    if not (math.isfinite(near) and math.isfinite(far)) or far <= near:
        return []
    raw = (far - near) / max(count - 1, 1)
    mag = 10 ** math.floor(math.log10(raw))
    step = next(m * mag for m in (1, 2, 5, 10) if m * mag >= raw)
    first = math.ceil(near / step - 1e-9) * step
    return [round(first + k * step, 10) for k in range(int((far - first) / step + 1e-9) + 1)]


def depth_colorbar(near: float, far: float, height: int, width: int = BAR_WIDTH) -> tuple[np.ndarray, list[tuple[float, int]]]:
    """The depth scale: a vertical bar, ``near`` [m] at the top, ``far`` at the bottom, ticks in metres.

    Returns the picture (``height`` x ``width`` RGB) and the ticks as ``(metres, row)``.
    """
    img = np.full((height, width, 3), 255, np.uint8)
    pad = 8
    rows = np.arange(pad, height - pad)
    if len(rows) < 2 or not (math.isfinite(near) and math.isfinite(far)) or far <= near:
        return img, []
    values = near + (rows - pad) / (len(rows) - 1) * (far - near)
    bar = depth_colors(values, near, far)
    img[pad:height - pad, 4:18] = bar[:, None, :]
    ticks: list[tuple[float, int]] = []
    for v in nice_ticks(near, far):
        row = int(round(pad + (v - near) / (far - near) * (len(rows) - 1)))
        ticks.append((v, row))
        cv2.line(img, (18, row), (23, row), (60, 60, 60), 1)
        text = f"{v:g} m"
        (_, th), _ = cv2.getTextSize(text, FONT, TICK_SCALE, 1)
        y = min(max(row + th // 2, th + 1), height - 2)
        cv2.putText(img, text, (26, y), FONT, TICK_SCALE, (30, 30, 30), 1, cv2.LINE_AA)
    return img, ticks
