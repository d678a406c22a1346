"""Loading photos as ``uint8`` HxWx3 RGB arrays, with clear errors for files that are not usable.

Decoding is OpenCV's (``cv2.imdecode`` with ``IMREAD_UNCHANGED``), so JPEG, PNG, TIFF, BMP, WebP
and the other formats of the installed OpenCV are read. Conversions:

- grayscale (HxW or HxWx1) -> RGB by repeating the channel;
- 16-bit -> 8-bit by scaling 0..65535 to 0..255; float images are taken as 0..1;
- RGBA -> RGB composited on WHITE (transparent pixels become white, as viewers show them);
- EXIF orientation is NOT applied: the array is the pixel grid as stored, which is the grid the
  camera intrinsics describe.

Images larger than :data:`MAX_SIDE` px on a side are REFUSED (:class:`ImageError` with the size and
the limit) rather than downscaled: a silent downscale would invalidate the camera intrinsics, and
no robot camera produces such frames.
"""

from __future__ import annotations

import os
from pathlib import Path

import cv2
import numpy as np

MAX_SIDE = 8000
"""Largest accepted width or height [px]."""


class ImageError(ValueError):
    """An image cannot be read or used; the message names the file."""


def load_image(source: str | os.PathLike[str] | bytes | bytearray | memoryview, *, name: str | None = None,
               max_side: int = MAX_SIDE) -> np.ndarray:
    """Decode a photo from a path or from encoded bytes to a C-contiguous ``uint8`` HxWx3 RGB array.

    Args:
        source: A file path, or the encoded file contents.
        name: How to call the image in error messages (default: the path, or ``"<bytes>"``).
        max_side: Largest accepted width/height [px].

    Raises:
        ImageError: The file does not exist or cannot be read, is empty, is not a decodable image,
            has an unsupported layout or type, or is larger than ``max_side``.
    """
    if isinstance(source, (bytes, bytearray, memoryview)):
        label = name or "<bytes>"
        data = bytes(source)
    elif isinstance(source, (str, os.PathLike)):
        path = Path(source)
        label = name or str(path)
        if not path.exists():
            raise ImageError(f"{label}: no such file")
        if path.is_dir():
            raise ImageError(f"{label}: is a directory, not an image file")
        try:
            data = path.read_bytes()
        except OSError as exc:
            raise ImageError(f"{label}: cannot read: {exc.strerror or exc}") from exc
    else:
        raise ImageError(f"load_image: expected a path or bytes, got {type(source).__name__}")
    if not data:
        raise ImageError(f"{label}: file is empty")
    try:
        image = cv2.imdecode(np.frombuffer(data, dtype=np.uint8), cv2.IMREAD_UNCHANGED)
    except cv2.error as exc:
        raise ImageError(f"{label}: not a readable image ({exc.msg if hasattr(exc, 'msg') else exc})") from None
    if image is None or image.size == 0:
        raise ImageError(f"{label}: not a readable image (corrupt or unsupported format, {len(data)} bytes)")
    h, w = image.shape[:2]
    if max(h, w) > max_side:
        raise ImageError(f"{label}: image is {w}x{h} px, larger than the limit of {max_side} px on a side")
    return _to_rgb8(image, label)


def _to_rgb8(image: np.ndarray, label: str) -> np.ndarray:
    if image.dtype == np.uint8:
        img = image
    elif image.dtype == np.uint16:
        img = ((image.astype(np.uint32) * 255 + 32767) // 65535).astype(np.uint8)
    elif image.dtype in (np.float32, np.float64):
        img = (np.clip(np.nan_to_num(image), 0.0, 1.0) * 255.0 + 0.5).astype(np.uint8)
    else:
        raise ImageError(f"{label}: unsupported pixel type {image.dtype}")
    if img.ndim == 3 and img.shape[2] == 1:
        img = img[:, :, 0]
    if img.ndim == 2:
        rgb = np.repeat(img[:, :, None], 3, axis=2)
    elif img.ndim == 3 and img.shape[2] == 3:
        rgb = img[:, :, ::-1]
    elif img.ndim == 3 and img.shape[2] == 4:
        bgr = img[:, :, :3].astype(np.float32)
        alpha = img[:, :, 3:4].astype(np.float32) / 255.0
        rgb = (bgr * alpha + 255.0 * (1.0 - alpha) + 0.5).astype(np.uint8)[:, :, ::-1]
    else:
        raise ImageError(f"{label}: unsupported image layout {image.shape}")
    return np.ascontiguousarray(rgb)
