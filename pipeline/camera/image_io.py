"""Loading photos as ``uint8`` HxWx3 RGB arrays, with clear errors for files that are not usable.

**The image convention** (one rule for every entry point: ``morphonavi map``, ``morphonavi bench``,
the console's ``--captures`` folder, live cameras): the array is the **upright** image, i.e. the
EXIF ``Orientation`` tag (phones store portrait photos sideways with Orientation = 6 or 8) is
applied, and camera intrinsics describe that upright image (``width`` x ``height`` = the upright
size). :func:`read_image` says when it applied a tag (:attr:`LoadedImage.note`).

Decoding: JPEG files are decoded by libjpeg-turbo through ``simplejpeg`` in strict mode: every
decoder warning about truncated or corrupt data is an ERROR (such a JPEG decodes "with a warning"
into garbage in most viewers, OpenCV included; a mapping pipeline must not see objects, or no
objects, in garbage). Pillow reads the headers (size, EXIF). Other formats (PNG, TIFF, BMP,
WebP, ...) are decoded by OpenCV (``cv2.imdecode`` with ``IMREAD_UNCHANGED``). Conversions:

- grayscale (HxW or HxWx1) -> RGB by repeating the channel;
- 16-bit -> 8-bit by scaling 0..65535 to 0..255 (a 16-bit file's range), except a 16-bit image whose
  values all fit in 0..255 (8-bit data stored in 16 bits; scaled it would be black): it is used as
  8-bit and the load says so (:attr:`LoadedImage.warnings`); float images are taken as 0..1;
- RGBA -> RGB composited on WHITE (transparent pixels become white, as viewers show them); an alpha
  channel that is 0 everywhere (a fully transparent picture, usually a misused channel) is ignored,
  with a warning;
- CMYK JPEGs -> RGB (Pillow's conversion).

Images larger than :data:`MAX_SIDE` px on a side are REFUSED (:class:`ImageError` with the size and
the limit) rather than downscaled: a silent downscale would invalidate the camera intrinsics, and
no robot camera produces such frames. The size is read from the header (Pillow) BEFORE decoding, so
a huge file is refused without allocating its pixels. ``min_side`` refuses images too small to use
(the mapper needs 8 px a side), naming the file. PNGs are checked with Pillow (chunk CRCs, truncation)
before OpenCV decodes them, so a broken PNG gives our error, not libpng's own stderr line.
"""

from __future__ import annotations

import io
import os
import warnings
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np

MAX_SIDE = 8000
"""Largest accepted width or height [px]."""

EXIF_ORIENTATION_TAG = 0x0112

_ORIENTATION_TEXT = {
    2: "mirrored left-right", 3: "rotated 180 deg", 4: "mirrored top-bottom",
    5: "transposed (mirrored and rotated 90 deg)", 6: "rotated 90 deg clockwise",
    7: "transversed (mirrored and rotated 90 deg)", 8: "rotated 90 deg counter-clockwise",
}
"""What applying each EXIF orientation value does to the stored pixels."""


class ImageError(ValueError):
    """An image cannot be read or used; the message names the file."""


@dataclass(frozen=True)
class LoadedImage:
    """A decoded photo, upright.

    Attributes:
        image: ``uint8`` H x W x 3 RGB, C-contiguous, EXIF orientation applied [px].
        orientation: The EXIF Orientation tag (1..8) when the file has one, else ``None``.
        stored_size: ``(width, height)`` of the pixel grid as stored in the file [px].
        label: How the image is named in messages.
        focal_35mm: The EXIF ``FocalLengthIn35mmFilm`` [mm] when the file has it (for an assumed
            camera, see :mod:`pipeline.camera.camera_guess`), else ``None``.
        warnings: Sentences about conversions the user should know of (8-bit data in a 16-bit file,
            an alpha channel that is 0 everywhere), each naming the file; empty when none.
    """

    image: np.ndarray
    orientation: int | None
    stored_size: tuple[int, int]
    label: str
    focal_35mm: float | None = None
    warnings: tuple[str, ...] = ()

    @property
    def size(self) -> tuple[int, int]:
        """``(width, height)`` of the upright image [px]."""
        return int(self.image.shape[1]), int(self.image.shape[0])

    @property
    def note(self) -> str | None:
        """A sentence saying that an EXIF orientation was applied, or ``None`` when nothing changed."""
        if self.orientation in (None, 1):
            return None
        w, h = self.stored_size
        uw, uh = self.size
        what = _ORIENTATION_TEXT.get(self.orientation or 0, "")
        return (f"{self.label}: EXIF orientation {self.orientation} applied ({what}): stored {w}x{h} px, "
                f"used upright as {uw}x{uh} px; the intrinsics must describe the upright image")


def apply_orientation(image: np.ndarray, orientation: int | None) -> np.ndarray:
    """The stored pixel grid ``image`` (H x W [x C]) turned upright for an EXIF ``orientation``.

    Orientation values outside 2..8 (absent, 1, or invalid) leave the image as it is.
    """
    if orientation == 2:
        out = image[:, ::-1]
    elif orientation == 3:
        out = image[::-1, ::-1]
    elif orientation == 4:
        out = image[::-1]
    elif orientation == 5:
        out = np.swapaxes(image, 0, 1)
    elif orientation == 6:
        out = np.rot90(image, k=-1)
    elif orientation == 7:
        out = np.swapaxes(image, 0, 1)[::-1, ::-1]
    elif orientation == 8:
        out = np.rot90(image, k=1)
    else:
        return image
    return np.ascontiguousarray(out)


def _read_bytes(source: object, name: str | None) -> tuple[bytes, str]:
    if isinstance(source, (bytes, bytearray, memoryview)):
        return bytes(source), name or "<bytes>"
    if isinstance(source, (str, os.PathLike)):
        path = Path(source)
        label = name or str(path)
        if not path.exists():
            raise ImageError(f"{label}: no such file")
        if path.is_dir():
            raise ImageError(f"{label}: is a directory, not an image file")
        try:
            return path.read_bytes(), label
        except OSError as exc:
            raise ImageError(f"{label}: cannot read: {exc.strerror or exc}") from exc
    raise ImageError(f"load_image: expected a path or bytes, got {type(source).__name__}")


def _exif_orientation(pil_image: object) -> int | None:
    try:
        value = pil_image.getexif().get(EXIF_ORIENTATION_TAG)  # type: ignore[attr-defined]
    except Exception:  # noqa: BLE001 - a broken EXIF block is treated as no tag
        return None
    return int(value) if isinstance(value, int) and 1 <= value <= 8 else None


def _exif_focal_35mm(data: bytes) -> float | None:
    """EXIF ``FocalLengthIn35mmFilm`` [mm] (Exif IFD tag 0xA405), or ``None``."""
    try:
        from PIL import Image

        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            with Image.open(io.BytesIO(data)) as im:
                value = im.getexif().get_ifd(0x8769).get(0xA405)
    except Exception:  # noqa: BLE001 - no readable EXIF: no focal length
        return None
    try:
        f = float(value)
    except (TypeError, ValueError):
        return None
    return f if 4.0 <= f <= 2000.0 else None


def _check_side(w: int, h: int, label: str, max_side: int, min_side: int = 1) -> None:
    if max(w, h) > max_side:
        raise ImageError(f"{label}: image is {w}x{h} px, larger than the limit of {max_side} px on a side")
    if min(w, h) < min_side:
        raise ImageError(f"{label}: image is {w}x{h} px, smaller than the minimum of {min_side} px on a side "
                         "(too small to map)")


def _header(data: bytes) -> tuple[int, int, str | None, int | None] | None:
    """``(width, height, format, EXIF orientation)`` from the file's header (Pillow, no pixel decode),
    or ``None`` when Pillow cannot read it (OpenCV may still decode the format)."""
    try:
        from PIL import Image

        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # DecompressionBombWarning: the side check below decides
            with Image.open(io.BytesIO(data)) as im:
                return int(im.width), int(im.height), im.format, _exif_orientation(im)
    except Exception:  # noqa: BLE001 - not a format Pillow knows
        return None


def _verify_png(data: bytes, label: str) -> None:
    """Refuse a truncated or corrupt PNG before OpenCV sees it (libpng would print its own error line
    on stderr, outside our message). Pillow's ``verify`` reads every chunk and checks its CRC."""
    from PIL import Image

    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            with Image.open(io.BytesIO(data)) as im:
                im.verify()
    except Exception as exc:  # noqa: BLE001 - any failure here is a broken file
        text = str(exc) or type(exc).__name__
        why = "truncated PNG" if "runcat" in text else "corrupt PNG"
        raise ImageError(f"{label}: {why} ({text}), {len(data)} bytes") from None


def _decode_jpeg(data: bytes, label: str, max_side: int, min_side: int = 1) -> tuple[np.ndarray, int | None]:
    """Strict JPEG decode: libjpeg-turbo (``simplejpeg``, ``strict=True``) turns every decoder warning
    about corrupt or truncated data into :class:`ImageError`; Pillow reads the header (size, EXIF)."""
    import simplejpeg
    from PIL import Image

    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            with Image.open(io.BytesIO(data)) as im:
                w, h, mode = im.width, im.height, im.mode
                orientation = _exif_orientation(im)
    except Exception as exc:  # noqa: BLE001 - anything Pillow cannot parse is not a usable JPEG
        raise ImageError(f"{label}: not a readable image (JPEG header: {exc}, {len(data)} bytes)") from None
    _check_side(w, h, label, max_side, min_side)
    try:
        if mode == "CMYK":  # libjpeg-turbo has no CMYK -> RGB conversion; Pillow's, strict on truncation
            with Image.open(io.BytesIO(data)) as im:
                arr = np.asarray(im.convert("RGB"))
        else:
            arr = simplejpeg.decode_jpeg(data, colorspace="RGB", strict=True)
    except (ValueError, OSError) as exc:
        text = str(exc)
        if "Premature end of JPEG file" in text or "truncated" in text:
            why = f"truncated JPEG ({text})"
        elif "Corrupt JPEG data" in text or "broken data stream" in text:
            why = f"corrupt JPEG data ({text}); the decoded picture would be garbage"
        else:
            why = f"not a readable image ({text})"
        raise ImageError(f"{label}: {why}, {len(data)} bytes") from None
    return np.ascontiguousarray(arr), orientation


def _decode_other(data: bytes, label: str, max_side: int,
                  min_side: int = 1) -> tuple[np.ndarray, int | None, tuple[str, ...]]:
    """OpenCV decode of non-JPEG formats; Pillow reads the header first (size checked before any pixel
    is decoded, EXIF orientation) and verifies PNGs."""
    header = _header(data)
    if header is not None:
        _check_side(header[0], header[1], label, max_side, min_side)
        if header[2] == "PNG":
            _verify_png(data, label)
    try:
        image = cv2.imdecode(np.frombuffer(data, dtype=np.uint8), cv2.IMREAD_UNCHANGED)
    except cv2.error as exc:
        raise ImageError(f"{label}: not a readable image ({exc.msg if hasattr(exc, 'msg') else exc})") from None
    if image is None or image.size == 0:
        raise ImageError(f"{label}: not a readable image (corrupt or unsupported format, {len(data)} bytes)")
    h, w = image.shape[:2]
    _check_side(w, h, label, max_side, min_side)
    orientation = header[3] if header is not None else None
    notes: list[str] = []
    return _to_rgb8(image, label, notes), orientation, tuple(notes)


def read_image(source: str | os.PathLike[str] | bytes | bytearray | memoryview, *, name: str | None = None,
               max_side: int = MAX_SIDE, min_side: int = 1) -> LoadedImage:
    """Decode a photo from a path or encoded bytes: the upright RGB image and what was done to it.

    Args:
        source: A file path, or the encoded file contents.
        name: How to call the image in error messages (default: the path, or ``"<bytes>"``).
        max_side: Largest accepted width/height [px] (checked on the header, before decoding).
        min_side: Smallest accepted width/height [px] (``map`` and ``bench`` ask for the mapper's 8).

    Raises:
        ImageError: The file does not exist or cannot be read, is empty, is not a decodable image,
            is a truncated or corrupt JPEG or PNG, has an unsupported layout or type, or is larger than
            ``max_side`` or smaller than ``min_side``.
    """
    data, label = _read_bytes(source, name)
    if not data:
        raise ImageError(f"{label}: file is empty")
    notes: tuple[str, ...] = ()
    if data[:2] == b"\xff\xd8":
        stored, orientation = _decode_jpeg(data, label, max_side, min_side)
    else:
        stored, orientation, notes = _decode_other(data, label, max_side, min_side)
    upright = np.ascontiguousarray(apply_orientation(stored, orientation))
    return LoadedImage(upright, orientation, (int(stored.shape[1]), int(stored.shape[0])), label,
                       _exif_focal_35mm(data), notes)


def load_image(source: str | os.PathLike[str] | bytes | bytearray | memoryview, *, name: str | None = None,
               max_side: int = MAX_SIDE) -> np.ndarray:
    """Decode a photo to a C-contiguous ``uint8`` HxWx3 RGB array, upright (see :func:`read_image`)."""
    return read_image(source, name=name, max_side=max_side).image


def upright_size(path: str | os.PathLike[str]) -> tuple[int, int] | None:
    """``(width, height)`` [px] of a photo file once its EXIF orientation is applied, from its header
    only (no decoding); ``None`` when the header cannot be read (the full decode then reports why)."""
    try:
        from PIL import Image

        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            with Image.open(path) as im:
                w, h = im.size
                orientation = _exif_orientation(im)
    except Exception:  # noqa: BLE001 - the full decode names the problem
        return None
    return (h, w) if orientation in (5, 6, 7, 8) else (w, h)


def _to_rgb8(image: np.ndarray, label: str, notes: list[str] | None = None) -> np.ndarray:
    """``image`` (OpenCV's BGR / BGRA / gray, 8 or 16 bit or float) as uint8 RGB; warnings go to ``notes``."""
    notes = [] if notes is None else notes
    if image.dtype == np.uint8:
        img = image
    elif image.dtype == np.uint16:
        top = int(image.max())
        if 0 < top <= 255:  # 0..65535 scaling would make it black
            notes.append(f"{label}: a 16-bit image whose values all lie within 0..255 (max {top}): it looks like "
                         "8-bit data stored in 16 bits, so it is used as 8-bit (not scaled from 0..65535)")
            img = image.astype(np.uint8)
        else:
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
    elif img.ndim == 3 and img.shape[2] == 4 and not img[:, :, 3].any():
        notes.append(f"{label}: the alpha channel is 0 everywhere (a fully transparent picture): the alpha is "
                     "ignored and the colour channels are used as they are")
        rgb = img[:, :, 2::-1]
    elif img.ndim == 3 and img.shape[2] == 4:
        bgr = img[:, :, :3].astype(np.float32)
        alpha = img[:, :, 3:4].astype(np.float32) / 255.0
        rgb = (bgr * alpha + 255.0 * (1.0 - alpha) + 0.5).astype(np.uint8)[:, :, ::-1]
    else:
        raise ImageError(f"{label}: unsupported image layout {image.shape}")
    return np.ascontiguousarray(rgb)
