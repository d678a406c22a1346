"""The scene: the one data model shared by the pipeline, the planner and the console.

A scene is a list of objects (oriented boxes) plus the captures they came from, stored as a
versioned JSON file. Every position is the geometric centre of the object's box in metres, in the
frame named by ``SceneObject.frame``:

- ``camera``: OpenCV optical frame (x right, y down, z forward), vertical axis = -y;
- ``robot``: robot body frame (x forward, y left, z up);
- ``world``: the console's frame (z up), the frame the planner works in.

``size`` is ``(w, h, l)`` [m]: ``h`` the vertical extent, ``l`` the extent along the object's
heading, ``w`` the remaining horizontal extent. ``yaw`` [rad] is the heading of the length axis,
measured counter-clockwise about the frame's vertical axis from its x axis.

Reading never trusts the file: :func:`scene_from_dict` checks every field and raises
:class:`SceneError` naming the first bad one (``objects[2].size[1]: must be > 0, got -1.0``).

This module holds the scene file's reading and writing (:func:`load_scene`, :func:`save_scene`), the
plausibility check and the atomic write, and re-exports the data classes of :mod:`pipeline.scene_model`
and the JSON functions of :mod:`pipeline.scene_json`: import them all from here.
"""

from __future__ import annotations

import json
import math
import os
import tempfile
from pathlib import Path
from typing import Sequence

from pipeline.scene_json import parse_json_text, scene_from_dict, scene_from_json, scene_to_dict
from pipeline.scene_model import (FRAMES, SCENE_VERSION, Capture, Frame, Scene, SceneError, SceneObject, Sighting,
                                  Source, Vec3)


def scene_to_json(scene: Scene) -> str:
    """The scene file's text (indented JSON, without the final newline)."""
    return json.dumps(scene_to_dict(scene), indent=1)


def save_scene(scene: Scene, path: str | os.PathLike[str]) -> Path:
    """Write a scene file atomically (a temporary file renamed into place): never a partial file."""
    return write_text_atomic(Path(path), scene_to_json(scene) + "\n")


def load_scene(path: str | os.PathLike[str]) -> Scene:
    """Read and validate a scene file; raises :class:`SceneError` naming the bad field."""
    p = Path(path)
    try:
        text = p.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise SceneError("", f"scene file not found: {p}") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise SceneError("", f"cannot read scene file {p}: {exc}") from None
    return scene_from_json(text)


MAX_OBJECT_SIZE = 50.0
"""No indoor object is larger than this along any axis [m], whatever the workspace."""

FAR_OUTSIDE = 5.0
"""A world-frame object centre more than this beyond the workspace box is implausible [m]."""


def check_plausible(
    scene: Scene,
    bounds_min: Sequence[float] | None = None,
    bounds_max: Sequence[float] | None = None,
    *,
    max_size: float = MAX_OBJECT_SIZE,
    far: float = FAR_OUTSIDE,
) -> None:
    """Refuse objects no real room holds; raises :class:`SceneError` naming the first bad field.

    Beside :func:`scene_from_dict` (which checks types and finiteness), this checks magnitudes:
    every size is at most ``max_size`` and, when the workspace box ``bounds_min..bounds_max``
    (world frame [m]) is given, at most the workspace diagonal; every world-frame centre lies
    within ``far`` metres of the box. Objects in the camera or robot frame have only their size
    checked (their world position is not known yet).
    """
    limit, why = max_size, f"max {max_size:g} m"
    box = None
    if bounds_min is not None and bounds_max is not None:
        box = [(float(bounds_min[a]) - far, float(bounds_max[a]) + far) for a in range(3)]
        diag = math.dist(bounds_min, bounds_max)
        if diag < limit:
            limit, why = diag, f"max {diag:.1f} m, the workspace diagonal"
    for i, obj in enumerate(scene.objects):
        for a, v in enumerate(obj.size):
            if not v <= limit:
                raise SceneError(f"objects[{i}].size[{a}]", f"{v:g} m is implausible ({why})")
        if box is not None and obj.frame == "world":
            for a, v in enumerate(obj.position):
                lo, hi = box[a]
                if not lo <= v <= hi:
                    raise SceneError(f"objects[{i}].position[{a}]",
                                     f"{v:g} m is far outside the workspace (allowed {lo:g}..{hi:g} m)")


def _current_umask() -> int:
    """The process umask, read without changing it where the system says it (Linux), else set and restored."""
    try:
        with open("/proc/self/status", encoding="ascii") as f:
            for line in f:
                if line.startswith("Umask:"):
                    return int(line.split()[1], 8)
    except (OSError, ValueError):
        pass
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


def write_text_atomic(path: Path, text: str) -> Path:
    """Write ``text`` to ``path`` through a temporary file in the same folder, renamed into place.

    The file gets the user's normal mode: the replaced file's mode, else ``0666`` less the umask
    (a temporary file is created ``0600``; without this every atomic write ended up ``0600``).
    """
    path.parent.mkdir(parents=True, exist_ok=True)
    try:
        mode = path.stat().st_mode & 0o7777
    except OSError:
        mode = 0o666 & ~_current_umask()
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    try:
        os.fchmod(fd, mode)
        with os.fdopen(fd, "w", encoding="utf-8") as fh:
            fh.write(text)
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
    return path


__all__ = ["FRAMES", "SCENE_VERSION", "Capture", "Frame", "Scene", "SceneError", "SceneObject", "Sighting", "Source",
           "Vec3", "check_plausible", "load_scene", "parse_json_text", "save_scene", "scene_from_dict",
           "scene_from_json", "scene_to_dict", "scene_to_json", "write_text_atomic"]
