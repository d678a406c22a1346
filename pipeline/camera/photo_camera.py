"""The camera of one photo as the development benchmark and ``--captures`` folders give it: ``<photo>.json``.

One reader for both uses: ``morphonavi map --camera-file photo.json`` (through
:func:`pipeline.camera.camera_file.load_camera_file`) and the console's ``--captures DIR``
(:mod:`console.link.captures`)::

    {"image": "000001.jpg", "width": 730, "height": 530,
     "K": [[fx, 0, cx], [0, fy, cy], [0, 0, 1]],   # camera matrix [px] for an image of width x height
     "dist": [k1, k2, p1, p2, k3],                  # optional OpenCV distortion coefficients
     "gravity_cam": [gx, gy, gz],                   # optional: unit gravity-down vector, camera frame
     "camera_height": 1.2}                          # optional: camera centre above the floor [m]

Camera frame OpenCV (x right, y down, z forward). ``gravity_cam`` and ``camera_height`` go together and give
the camera's pose for the photo as a :class:`~pipeline.camera.geometry.CameraMount` (robot standing level
on the floor, camera above its origin): pitch > 0 looks down, roll > 0 rolls the camera clockwise seen from
behind it (see :mod:`pipeline.camera.camera_schema`). Errors are :class:`~pipeline.camera.geometry.CameraError`
naming the file (``where``) and the key.
"""

from __future__ import annotations

import math
from typing import Any, Mapping

from pipeline.camera.geometry import CameraConfig, CameraError, CameraMount, Intrinsics, mount_from_gravity_height


def _vec(value: Any, n: int, where: str) -> tuple[float, ...]:
    if (not isinstance(value, (list, tuple)) or len(value) != n
            or not all(isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v) for v in value)):
        raise CameraError(f"{where}: expected {n} finite numbers, got {value!r}")
    return tuple(float(v) for v in value)


def photo_mount(meta: Mapping[str, Any], where: object) -> CameraMount | None:
    """The camera's pose for the photo from ``gravity_cam`` + ``camera_height``, ``None`` when neither is given."""
    g, h = meta.get("gravity_cam"), meta.get("camera_height")
    if g is None and h is None:
        return None
    if g is None or h is None:
        raise CameraError(f"{where}: 'gravity_cam' and 'camera_height' go together (the camera's pose "
                          "for this photo); give both or neither")
    gv = _vec(g, 3, f"{where}: gravity_cam")
    n = math.sqrt(sum(v * v for v in gv))
    if abs(n - 1.0) > 0.05:
        raise CameraError(f"{where}: gravity_cam must be a unit vector (camera frame), got length {n:.3g}")
    if isinstance(h, bool) or not isinstance(h, (int, float)) or not math.isfinite(h) or not 0.0 < h <= 10.0:
        raise CameraError(f"{where}: camera_height must be a number within 0..10 m, got {h!r}")
    return mount_from_gravity_height(tuple(v / n for v in gv), float(h))


def photo_intrinsics(meta: Mapping[str, Any], where: object, size: tuple[int, int] | None = None) -> Intrinsics:
    """Intrinsics from ``K``, ``width``, ``height`` (and ``dist``); checked against the upright image ``size``
    = (w, h) [px] when it is given."""
    K = meta.get("K")
    if not (isinstance(K, list) and len(K) == 3 and all(isinstance(r, list) and len(r) == 3 for r in K)
            and all(isinstance(v, (int, float)) and not isinstance(v, bool) for r in K for v in r)):
        raise CameraError(f"{where}: 'K' must be a 3x3 list of numbers (the camera matrix [px])")
    for key in ("width", "height"):
        v = meta.get(key)
        if v is None:
            this = f"this image is {size[0]}x{size[1]}; " if size else ""
            raise CameraError(
                f"{where}: '{key}' is required: 'width' and 'height' give the image size K is for "
                f"({this}a resized photo needs K scaled by the same factor)")
        if isinstance(v, bool) or not isinstance(v, int) or v <= 0:
            raise CameraError(f"{where}: '{key}' must be a whole number of pixels > 0, got {v!r}")
    dist = meta.get("dist", [])
    if not isinstance(dist, list) or not all(isinstance(d, (int, float)) and not isinstance(d, bool) for d in dist):
        raise CameraError(f"{where}: 'dist' must be a list of numbers")
    try:
        intr = Intrinsics.from_K(K, meta["width"], meta["height"], [float(d) for d in dist])
        if size is not None:
            intr.check_image(*size)
    except (CameraError, TypeError, ValueError) as exc:
        raise CameraError(f"{where}: {exc}") from None
    return intr


def camera_config_from_photo_json(meta: Any, where: object) -> CameraConfig:
    """A :class:`CameraConfig` from a photo's JSON (the mount from ``gravity_cam`` / ``camera_height``, else the
    default mount)."""
    if not isinstance(meta, dict):
        raise CameraError(f"{where}: must be a JSON object, got {type(meta).__name__}")
    intr = photo_intrinsics(meta, where)
    mount = photo_mount(meta, where)
    return CameraConfig(intr, mount_given=False) if mount is None else CameraConfig(intr, mount)


__all__ = ["camera_config_from_photo_json", "photo_intrinsics", "photo_mount"]
