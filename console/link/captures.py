"""Real photos from a folder instead of a camera (``--captures DIR``).

The folder uses the layout of the development benchmark: every photo ``<name>.jpg`` / ``.png``
sits next to ``<name>.json`` holding its intrinsics and, optionally, ground-truth objects (the camera part is
read by :mod:`pipeline.camera.photo_camera`, which ``map --camera`` uses too)::

    {"image": "000001.jpg", "width": 730, "height": 530,
     "K": [[fx, 0, cx], [0, fy, cy], [0, 0, 1]],
     "objects": [{"label": "bed", "center_cam": [x, y, z], "size": [w, h, l], "yaw": ry,
                  "bbox2d_gt": [x1, y1, x2, y2], "bbox2d_proj": [x1, y1, x2, y2]}, ...]}

``center_cam`` is in the OpenCV camera frame (x right, y down, z forward) [m]; ``size`` is
``(w, h, l)`` [m]. ``width`` and ``height`` are REQUIRED: they are the image size ``K`` is for, so a
photo resized after calibration is refused instead of being mapped 1/scale too far. Optional
``gravity_cam`` (unit gravity-down vector, camera frame) and ``camera_height`` [m] (camera centre
above the floor) give the camera's pose for that photo (the bench format); the console then uses
it instead of the robot's mount (:attr:`FolderPhoto.mount`).

Photos are loaded by :func:`pipeline.camera.image_io.read_image`: EXIF orientation applied (logged when a
photo has the tag), ``K`` describes the upright image, truncated or corrupt JPEGs are refused.
Every entry's JSON and image size are checked when the folder is opened, so a bad folder is refused
at start, naming the file and the field. An ``index.json`` listing ``{"json": "<relative path>"}`` entries fixes the
order; without it every ``*.json`` with a matching image, in sorted order, is used (sub-folders
included). Photos are served in order and the sequence wraps around.
"""

from __future__ import annotations

import json
import logging
import math
import threading
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from pipeline.camera.geometry import CameraError, CameraMount, Intrinsics
from pipeline.camera.photo_camera import photo_intrinsics, photo_mount
from pipeline.camera.image_io import ImageError, read_image, upright_size
from pipeline.scene import SceneObject, Source

from console.link.base import GroundTruth, LinkError, VisibleObject

IMAGE_SUFFIXES = (".jpg", ".jpeg", ".png")

log = logging.getLogger(__name__)


class CapturesError(LinkError):
    """The captures folder or one of its files is unusable; the message names the file."""


@dataclass(frozen=True)
class FolderPhoto:
    """One photo of a captures folder.

    Attributes:
        name: Path of the photo relative to the folder.
        image: RGB, H x W x 3 uint8.
        intrinsics: Intrinsics of ``image`` [px].
        ground_truth: Annotated objects (camera frame) and their 2D boxes, if the file has any.
        mount: The camera's pose for this photo from its ``gravity_cam`` and ``camera_height``
            (robot body frame, robot standing level on the floor), or ``None`` to use the robot's.
        note: What was done to the image (EXIF orientation applied), or ``None``.
    """

    name: str
    image: np.ndarray
    intrinsics: Intrinsics
    ground_truth: GroundTruth | None
    mount: CameraMount | None = None
    note: str | None = None


def read_json(path: Path) -> Any:
    """The JSON value of ``path``; :class:`CapturesError` naming the file when it cannot be had."""
    try:
        return json.loads(path.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise CapturesError(f"{path}: missing") from None
    except RecursionError:
        raise CapturesError(f"{path}: JSON nested too deeply") from None
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise CapturesError(f"{path}: not readable JSON: {exc}") from None


def _photo_mount(meta: dict[str, Any], where: Path) -> CameraMount | None:
    try:
        return photo_mount(meta, where)
    except CameraError as exc:
        raise CapturesError(str(exc)) from None


def _intrinsics(meta: dict[str, Any], where: Path, size: tuple[int, int]) -> Intrinsics:
    """Intrinsics of the JSON, checked against the (upright) image ``size`` = (w, h) [px]."""
    try:
        return photo_intrinsics(meta, where, size)
    except CameraError as exc:
        raise CapturesError(str(exc)) from None


def _find_image(meta_path: Path, meta: dict[str, Any]) -> Path:
    if isinstance(meta.get("image"), str):
        p = meta_path.parent / meta["image"]
        if p.is_file():
            return p
    for suffix in IMAGE_SUFFIXES:
        p = meta_path.with_suffix(suffix)
        if p.is_file():
            return p
    raise CapturesError(f"{meta_path}: no image next to it (looked for {meta.get('image') or meta_path.stem + '.jpg/.png'})")


def _vec(value: Any, n: int, where: str) -> tuple[float, ...]:
    if (not isinstance(value, (list, tuple)) or len(value) != n
            or not all(isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v) for v in value)):
        raise CapturesError(f"{where}: expected {n} finite numbers, got {value!r}")
    return tuple(float(v) for v in value)


class CapturesFolder:
    """Serves the photos of a folder one after the other (thread-safe).

    Raises:
        CapturesError: The folder does not exist or holds no usable photo.
    """

    def __init__(self, folder: str | Path) -> None:
        self.folder = Path(folder).expanduser()
        if not self.folder.is_dir():
            raise CapturesError(f"captures folder not found: {self.folder}")
        self.entries: list[Path] = self._list()
        if not self.entries:
            raise CapturesError(
                f"captures folder {self.folder} holds no photo with a .json next to it "
                "(see the --captures format in the README)")
        self._next = 0
        self._lock = threading.Lock()
        self.check()

    def _meta(self, i: int) -> tuple[Path, dict[str, Any], Path]:
        meta_path = self.entries[i]
        if not meta_path.is_file():
            raise CapturesError(f"{meta_path}: listed in index.json but missing")
        meta = read_json(meta_path)
        if not isinstance(meta, dict):
            raise CapturesError(f"{meta_path}: must hold a JSON object")
        return meta_path, meta, _find_image(meta_path, meta)

    def check(self) -> None:
        """Check every entry without decoding the photos: its JSON (``K``, ``width``, ``height``,
        the optional camera pose) against the image's upright size read from its header.

        Raises:
            CapturesError: The first bad entry, naming the file and the field.
        """
        for i in range(len(self.entries)):
            meta_path, meta, img_path = self._meta(i)
            size = upright_size(img_path)
            if size is None:
                continue  # unreadable header: load() decodes and names the problem
            _intrinsics(meta, meta_path, size)
            _photo_mount(meta, meta_path)

    def _list(self) -> list[Path]:
        index = self.folder / "index.json"
        if index.is_file():
            items = read_json(index)
            if not isinstance(items, list):
                raise CapturesError(f"{index}: must be a list of {{'json': path}} entries")
            out = []
            for i, item in enumerate(items):
                rel = item.get("json") if isinstance(item, dict) else None
                if not isinstance(rel, str):
                    raise CapturesError(f"{index}[{i}]: missing 'json' path")
                out.append(self.folder / rel)
            return out
        return sorted(p for p in self.folder.rglob("*.json") if p.name != "index.json" and self._has_image(p))

    @staticmethod
    def _has_image(p: Path) -> bool:
        if any(p.with_suffix(s).is_file() for s in IMAGE_SUFFIXES):
            return True
        try:
            meta = json.loads(p.read_text(encoding="utf-8"))
        except (OSError, UnicodeDecodeError, json.JSONDecodeError, RecursionError):
            return False
        return isinstance(meta, dict) and isinstance(meta.get("image"), str) and (p.parent / meta["image"]).is_file()

    def __len__(self) -> int:
        return len(self.entries)

    def next(self) -> FolderPhoto:
        """The next photo (wrapping around)."""
        with self._lock:
            i = self._next
            self._next = (self._next + 1) % len(self.entries)
        return self.load(i)

    def load(self, i: int) -> FolderPhoto:
        """Photo number ``i`` (in folder order), upright.

        Raises:
            CapturesError: Unreadable JSON or image (corrupt, truncated), intrinsics that do not fit
                the image, or a bad per-photo camera pose; the message names the file.
        """
        meta_path, meta, img_path = self._meta(i)
        try:
            loaded = read_image(img_path)
        except ImageError as exc:
            raise CapturesError(str(exc)) from None
        if loaded.note:
            log.info("%s", loaded.note)
        h, w = loaded.image.shape[:2]
        intr = _intrinsics(meta, meta_path, (w, h))
        name = str(img_path.relative_to(self.folder))
        return FolderPhoto(name, loaded.image, intr, self._truth(meta, meta_path, name),
                           _photo_mount(meta, meta_path), loaded.note)

    @staticmethod
    def _truth(meta: dict[str, Any], where: Path, name: str) -> GroundTruth | None:
        raw = meta.get("objects")
        if not isinstance(raw, list):
            return None
        objects: list[SceneObject] = []
        visible: list[VisibleObject] = []
        stem = Path(name).with_suffix("").as_posix()
        for k, o in enumerate(raw):
            at = f"{where}: objects[{k}]"
            if not isinstance(o, dict) or not isinstance(o.get("label"), str):
                raise CapturesError(f"{at}: needs a 'label'")
            centre = _vec(o.get("center_cam"), 3, f"{at}.center_cam")
            size = _vec(o.get("size"), 3, f"{at}.size")
            if min(size) <= 0:
                raise CapturesError(f"{at}.size: extents must be > 0 m, got {size}")
            yaw = float(o.get("yaw", 0.0) or 0.0)
            oid = f"{stem}#{k}"
            box = o.get("bbox2d_gt") or o.get("bbox2d_proj")
            objects.append(SceneObject(oid, o["label"], centre, size, yaw, "camera",  # type: ignore[arg-type]
                                       source=Source(method="ground_truth",
                                                     bbox=None if box is None else _vec(box, 4, f"{at}.bbox"))))  # type: ignore[arg-type]
            if box is not None:
                b = _vec(box, 4, f"{at}.bbox")
                w, h = meta.get("width"), meta.get("height")
                cut = bool(b[0] <= 1 or b[1] <= 1 or (isinstance(w, (int, float)) and b[2] >= w - 1)
                           or (isinstance(h, (int, float)) and b[3] >= h - 1))
                visible.append(VisibleObject(-1, oid, o["label"], b, 0, cut))  # type: ignore[arg-type]
        return GroundTruth(objects=tuple(objects), visible=tuple(visible))


__all__ = ["CapturesFolder", "CapturesError", "FolderPhoto"]
