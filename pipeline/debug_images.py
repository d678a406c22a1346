"""Pictures of one mapping run, for people: detections, masks and the depth map.

:func:`write_debug_images` writes into a folder:

- ``detections.png``: every detection box with its class, score and fused distance [m] (camera-frame
  z of the centre) and how it was obtained; skipped detections dashed grey with the reason;
- ``masks.png``: the segmentation masks (the box where none was computed) over the dimmed photo;
- ``depth.png``: the depth map in metres after the fitted scale (near = warm), with its range.
"""

from __future__ import annotations

import zlib
from pathlib import Path

import cv2
import numpy as np

from pipeline.mapper import MapResult


def label_colour(label: str) -> tuple[int, int, int]:
    """A stable, saturated RGB colour for a class name."""
    hue = zlib.crc32(label.encode("utf-8")) % 180
    hsv = np.array([[[hue, 200, 255]]], dtype=np.uint8)
    r, g, b = cv2.cvtColor(hsv, cv2.COLOR_HSV2RGB)[0, 0]
    return int(r), int(g), int(b)


def _text(img: np.ndarray, text: str, org: tuple[int, int], colour: tuple[int, int, int], scale: float) -> None:
    x, y = org
    (tw, th), base = cv2.getTextSize(text, cv2.FONT_HERSHEY_SIMPLEX, scale, 1)
    y = max(th + 2, y)
    cv2.rectangle(img, (x, y - th - 2), (x + tw + 2, y + base), (0, 0, 0), -1)
    cv2.putText(img, text, (x + 1, y - 1), cv2.FONT_HERSHEY_SIMPLEX, scale, colour, 1, cv2.LINE_AA)


def draw_detections(result: MapResult, image_rgb: np.ndarray) -> np.ndarray:
    """The photo (RGB) with every detection's box and what the mapper made of it."""
    img = image_rgb.copy()
    scale = max(0.4, min(img.shape[:2]) / 900)
    thick = max(1, round(min(img.shape[:2]) / 400))
    for obj in result.objects:
        d = obj.detection
        p1, p2 = (int(d.box[0]), int(d.box[1])), (int(d.box[2]), int(d.box[3]))
        if obj.fused is None or obj.center_cam is None:
            cv2.rectangle(img, p1, p2, (160, 160, 160), thick, lineType=cv2.LINE_4)
            _text(img, f"{d.label} {d.score:.2f}: {obj.skipped or 'not placed'}", (p1[0], p1[1] - 2), (200, 200, 200), scale)
            continue
        colour = label_colour(d.label)
        cv2.rectangle(img, p1, p2, colour, thick)
        text = f"{obj.object_id or d.label} {d.score:.2f} z={obj.fused.distance:.1f}m {obj.fused.method}"
        _text(img, text, (p1[0], p1[1] - 2), colour, scale)
    return img


def draw_masks(result: MapResult, image_rgb: np.ndarray) -> np.ndarray:
    """The dimmed photo (RGB) with each object's mask (or box) in its class colour."""
    img = (image_rgb.astype(np.float32) * 0.45).astype(np.float32)
    h, w = img.shape[:2]
    for obj in result.objects:
        colour = np.array(label_colour(obj.detection.label), dtype=np.float32)
        if obj.mask is not None and obj.mask.shape == (h, w):
            m = obj.mask
        else:
            m = np.zeros((h, w), dtype=bool)
            x1, y1, x2, y2 = (int(round(v)) for v in obj.detection.box)
            m[max(0, y1):max(0, y2), max(0, x1):max(0, x2)] = True
        img[m] = img[m] * 0.4 + colour * 0.6
    return np.clip(img, 0, 255).astype(np.uint8)


def draw_depth(result: MapResult) -> np.ndarray | None:
    """The depth map (RGB, turbo colours, near = red) in metres when a scale is known, else as given."""
    if result.depth is None:
        return None
    values = np.asarray(result.depth.values, dtype=np.float64)
    unit = "m"
    if result.depth_scale is not None:
        metric = np.asarray(result.depth_scale.to_metric(values), dtype=np.float64)
    elif result.depth.kind == "metric":
        metric = values
    else:
        metric, unit = values, f"({result.depth.kind}, no scale)"
    valid = np.isfinite(metric) & (metric > 0)
    if not valid.any():
        return np.zeros((*values.shape, 3), dtype=np.uint8)
    lo, hi = np.percentile(metric[valid], [1, 99])
    hi = max(hi, lo + 1e-6)
    near = 1.0 - np.clip((np.where(valid, metric, hi) - lo) / (hi - lo), 0, 1)
    if result.depth.kind == "inverse_relative" and result.depth_scale is None:
        near = 1.0 - near  # disparity: larger = nearer
    img = cv2.applyColorMap((near * 255).astype(np.uint8), cv2.COLORMAP_TURBO)[:, :, ::-1].copy()
    img[~valid] = 0
    _text(img, f"depth {lo:.2f} .. {hi:.2f} {unit} (1-99 %)", (4, 18), (255, 255, 255), max(0.4, min(img.shape[:2]) / 900))
    return img


def write_debug_images(result: MapResult, image_rgb: np.ndarray, out_dir: str | Path) -> list[Path]:
    """Write ``detections.png``, ``masks.png`` and (with a depth map) ``depth.png`` into ``out_dir``
    (created if needed); returns the paths written.

    Raises:
        OSError: The folder cannot be created or a file cannot be written.
    """
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    pictures = {"detections.png": draw_detections(result, image_rgb), "masks.png": draw_masks(result, image_rgb),
                "depth.png": draw_depth(result)}
    written = []
    for name, rgb in pictures.items():
        if rgb is None:
            continue
        path = out / name
        if not cv2.imwrite(str(path), np.ascontiguousarray(rgb[:, :, ::-1])):
            raise OSError(f"cannot write {path}")
        written.append(path)
    return written
