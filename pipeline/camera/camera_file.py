"""``camera.toml``: reading with field-by-field validation, and writing (``morphonavi calibrate``).

Format::

    [intrinsics]            # pixels, for the UPRIGHT image (EXIF orientation applied)
    fx = 525.0
    fy = 525.0
    cx = 319.5
    cy = 239.5
    width = 640
    height = 480
    dist = []               # optional OpenCV distortion coefficients (0, 4, 5, 8, 12 or 14)

    [mount]                 # optional; robot body frame (x fwd, y left, z up)
    position = [0.15, 0.0, 0.35]   # metres
    pitch_deg = 10.0        # optical axis tilted down
    yaw_deg = 0.0
    roll_deg = 0.0

    [calibration]           # optional, informational (written by morphonavi calibrate)

Every value is checked and an error names the key (``mount.pitch_deg: must be finite, got nan``):
numbers must be numbers and finite, ``width``/``height`` integers of 1..8000 px, focal lengths give a
field of view of 0.5..179 deg, the principal point lies in the image, ``dist`` has a valid count of
finite coefficients within +-1000, ``position`` 3 finite numbers within +-10 m, ``pitch_deg``
within +-90 deg, ``yaw_deg`` and ``roll_deg`` within +-180 deg. Unknown keys are refused (typos).
"""

from __future__ import annotations

import json
import math
import sys
from pathlib import Path
from typing import Any, Mapping, Sequence

from pipeline.camera.geometry import CameraConfig, CameraError, CameraMount, Intrinsics
from pipeline.camera.photo_camera import camera_config_from_photo_json

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover - exercised on Python 3.10 only
    import tomli as tomllib

MAX_SIDE = 8000
"""Largest image width / height [px] (as :data:`pipeline.camera.image_io.MAX_SIDE`)."""
MAX_DIST_COEFF = 1000.0
MAX_MOUNT_OFFSET = 10.0
"""Largest distance of the camera from the robot's origin on each axis [m]."""
FOV_RANGE_DEG = (0.5, 179.0)

INTRINSICS_KEYS = ("fx", "fy", "cx", "cy", "width", "height", "dist")
MOUNT_KEYS = ("position", "pitch_deg", "yaw_deg", "roll_deg")
TABLES = ("intrinsics", "mount", "calibration")


def _number(value: Any, where: str) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise CameraError(f"{where}: must be a number, got {value!r}")
    v = float(value)
    if not math.isfinite(v):
        raise CameraError(f"{where}: must be finite, got {value!r}")
    return v


def _in_range(value: Any, where: str, lo: float, hi: float, unit: str) -> float:
    v = _number(value, where)
    if not lo <= v <= hi:
        raise CameraError(f"{where}: must be within {lo:g}..{hi:g} {unit}, got {v:g}")
    return v


def _side(value: Any, where: str) -> int:
    if isinstance(value, bool) or not isinstance(value, int):
        raise CameraError(f"{where}: must be a whole number of pixels, got {value!r}")
    if not 1 <= value <= MAX_SIDE:
        raise CameraError(f"{where}: must be within 1..{MAX_SIDE} px, got {value}")
    return int(value)


def _list(value: Any, where: str, counts: Sequence[int], what: str) -> list[Any]:
    if not isinstance(value, list):
        raise CameraError(f"{where}: must be a list of {what}, got {value!r}")
    if len(value) not in counts:
        n = ", ".join(str(c) for c in counts)
        raise CameraError(f"{where}: expected {n} {what}, got {len(value)}")
    return value


def _unknown_keys(table: Mapping[str, Any], known: Sequence[str], where: str) -> None:
    for key in table:
        if key not in known:
            raise CameraError(f"{where}.{key}: unknown key (expected {', '.join(known)})")


def _focal(value: Any, where: str, side: int) -> float:
    f = _number(value, where)
    if f <= 0:
        raise CameraError(f"{where}: must be > 0 px, got {f:g}")
    fov = math.degrees(2.0 * math.atan2(side / 2.0, f))
    lo, hi = FOV_RANGE_DEG
    if not lo <= fov <= hi:
        raise CameraError(f"{where}: {f:g} px gives a {fov:.3g} deg field of view over {side} px; "
                          f"expected {lo:g}..{hi:g} deg")
    return f


def intrinsics_from_table(t: Any, where: str = "intrinsics") -> Intrinsics:
    """Validated :class:`Intrinsics` from an ``[intrinsics]`` mapping (errors name ``where.key``)."""
    if not isinstance(t, dict):
        raise CameraError(f"[{where}]: table is required")
    _unknown_keys(t, INTRINSICS_KEYS, where)
    for key in ("fx", "fy", "cx", "cy", "width", "height"):
        if key not in t:
            raise CameraError(f"{where}.{key}: is required")
    width = _side(t["width"], f"{where}.width")
    height = _side(t["height"], f"{where}.height")
    fx = _focal(t["fx"], f"{where}.fx", width)
    fy = _focal(t["fy"], f"{where}.fy", height)
    cx = _in_range(t["cx"], f"{where}.cx", 0.0, float(width), "px (inside the image)")
    cy = _in_range(t["cy"], f"{where}.cy", 0.0, float(height), "px (inside the image)")
    dist_raw = _list(t.get("dist", []), f"{where}.dist", (0, 4, 5, 8, 12, 14), "distortion coefficients")
    dist = tuple(_in_range(d, f"{where}.dist[{i}]", -MAX_DIST_COEFF, MAX_DIST_COEFF, "")
                 for i, d in enumerate(dist_raw))
    return Intrinsics(fx, fy, cx, cy, width, height, dist)


def mount_from_table(t: Any, where: str = "mount") -> CameraMount:
    """Validated :class:`CameraMount` from a ``[mount]`` mapping; missing keys take the defaults."""
    if not isinstance(t, dict):
        raise CameraError(f"[{where}]: must be a table, got {t!r}")
    _unknown_keys(t, MOUNT_KEYS, where)
    default = CameraMount()
    pos_raw = _list(t.get("position", list(default.position)), f"{where}.position", (3,), "numbers [m]")
    pos = tuple(_in_range(v, f"{where}.position[{i}]", -MAX_MOUNT_OFFSET, MAX_MOUNT_OFFSET, "m")
                for i, v in enumerate(pos_raw))
    pitch = _in_range(t.get("pitch_deg", 0.0), f"{where}.pitch_deg", -90.0, 90.0, "deg")
    yaw = _in_range(t.get("yaw_deg", 0.0), f"{where}.yaw_deg", -180.0, 180.0, "deg")
    roll = _in_range(t.get("roll_deg", 0.0), f"{where}.roll_deg", -180.0, 180.0, "deg")
    return CameraMount((pos[0], pos[1], pos[2]), math.radians(pitch), math.radians(yaw), math.radians(roll))


def camera_config_from_dict(data: Mapping[str, Any]) -> CameraConfig:
    """Build a validated :class:`CameraConfig` from a parsed ``camera.toml`` mapping."""
    if not isinstance(data, Mapping):
        raise CameraError(f"camera file: must be a table, got {type(data).__name__}")
    for key in data:
        if key not in TABLES:
            raise CameraError(f"[{key}]: unknown table (expected [intrinsics], optional [mount], [calibration])")
    intr = intrinsics_from_table(data.get("intrinsics"))
    mount = mount_from_table(data.get("mount", {}))
    return CameraConfig(intr, mount, mount_given="mount" in data)


def load_camera_file(path: str | Path) -> CameraConfig:
    """Read and validate a camera file: ``camera.toml`` (format in the module docstring) or a photo's JSON
    (``K``, ``width``, ``height``, optional ``dist``, ``gravity_cam`` + ``camera_height``: the development
    benchmark's and ``--captures`` folders' form, :mod:`pipeline.camera.photo_camera`), told apart by content
    (JSON starts with ``{``).

    Raises:
        CameraError: Missing or unreadable file, invalid TOML / JSON, or a bad value (the message names it).
    """
    p = Path(path)
    try:
        text = p.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise CameraError(f"camera file not found: {p}") from None
    except IsADirectoryError:
        raise CameraError(f"camera file {p}: is a directory") from None
    except UnicodeDecodeError as exc:
        raise CameraError(f"camera file {p} is not valid TOML: {exc}") from None
    except OSError as exc:
        raise CameraError(f"camera file {p}: cannot read: {exc.strerror or exc}") from None
    if text.lstrip().startswith("{"):
        try:
            meta = json.loads(text)
        except (json.JSONDecodeError, RecursionError) as exc:
            raise CameraError(f"camera file {p} is not valid JSON: {exc}") from None
        return camera_config_from_photo_json(meta, p)
    try:
        data = tomllib.loads(text)
    except (tomllib.TOMLDecodeError, RecursionError) as exc:
        raise CameraError(f"camera file {p} is not valid TOML: {exc}") from None
    try:
        return camera_config_from_dict(data)
    except CameraError as exc:
        raise CameraError(f"{p}: {exc}") from None


load_camera_toml = load_camera_file
"""The former name of :func:`load_camera_file` (it reads the photo JSON form too)."""


def _fmt(v: float) -> str:
    return repr(float(v))


def camera_toml_text(intr: Intrinsics, mount: CameraMount | None = None,
                     calibration: Mapping[str, float | int | str] | None = None) -> str:
    """The ``camera.toml`` text for these intrinsics (and mount, and calibration facts)."""
    lines = ["[intrinsics]  # pixels, for the upright image (EXIF orientation applied)",
             f"fx = {_fmt(intr.fx)}", f"fy = {_fmt(intr.fy)}", f"cx = {_fmt(intr.cx)}", f"cy = {_fmt(intr.cy)}",
             f"width = {int(intr.width)}", f"height = {int(intr.height)}",
             "dist = [" + ", ".join(_fmt(d) for d in intr.dist) + "]  # OpenCV k1, k2, p1, p2[, k3 ...]", ""]
    if mount is not None:
        p = mount.position
        lines += ["[mount]  # robot body frame: x forward, y left, z up [m]; pitch positive looks down",
                  f"position = [{_fmt(p[0])}, {_fmt(p[1])}, {_fmt(p[2])}]",
                  f"pitch_deg = {_fmt(math.degrees(mount.pitch))}", f"yaw_deg = {_fmt(math.degrees(mount.yaw))}",
                  f"roll_deg = {_fmt(math.degrees(mount.roll))}", ""]
    if calibration:
        lines.append("[calibration]  # informational")
        for k, v in calibration.items():
            lines.append(f"{k} = {json.dumps(v)}")
        lines.append("")
    return "\n".join(lines)


def write_camera_toml(path: str | Path, intr: Intrinsics, mount: CameraMount | None = None,
                      calibration: Mapping[str, float | int | str] | None = None) -> Path:
    """Write ``camera.toml`` atomically (temporary file + rename); returns the path."""
    import os

    p = Path(path)
    text = camera_toml_text(intr, mount, calibration)
    camera_config_from_dict(tomllib.loads(text))  # never write a file we would refuse to read
    tmp = p.with_name(p.name + ".tmp")
    tmp.write_text(text, encoding="utf-8")
    os.replace(tmp, p)
    return p


__all__ = ["camera_config_from_dict", "camera_toml_text", "intrinsics_from_table", "load_camera_file", "load_camera_toml",
           "mount_from_table", "write_camera_toml"]
