"""The captures' files in the session folder: photo and depth image, and their metadata; capture ids.

``captures/<id>.jpg`` holds the RGB photo, ``captures/<id>_depth_mm.png`` the depth along the
optical axis as 16-bit millimetres (0 = unknown). Poses are ``world <- camera`` (OpenCV optical
frame) and ``world <- robot`` [m, quaternion xyzw].

Capture ids are ``cap-0001``, ``cap-0002``, ... in the order of the session's captures, continuing
after the highest number found in ``captures/`` (so a restart never gives an id twice); a photo from a
folder keeps its file name after the number (``cap-0007-IMG_0412``).
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any, Iterable, Mapping

import numpy as np

from pipeline.camera.geometry import Intrinsics, Pose

from console.session.session_types import CaptureRecord, Detection

CAPTURE_DIR = "captures"
_NUMBERED = re.compile(r"^cap-(\d{1,9})(?:[-_.]|$)")


def highest_capture_number(folder: Path, ids: Iterable[str] = ()) -> int:
    """The highest capture number (``cap-0012...`` -> 12) among the files in ``folder/captures`` and
    ``ids``; 0 when there is none (or the folder cannot be listed)."""
    names = list(ids)
    try:
        names += [p.name for p in (folder / CAPTURE_DIR).iterdir()]
    except OSError:
        pass
    found = [int(m.group(1)) for n in names if (m := _NUMBERED.match(n))]
    return max(found, default=0)


def numbered_capture_id(number: int, name: str = "", source: str = "") -> str:
    """The id of the session's ``number``-th capture: ``cap-0012``, or ``cap-0012-<file name>`` for a
    photo from a folder (``source == "captures-folder"``); a render or camera frame counter is left out
    (it restarts with the link)."""
    if isinstance(number, bool) or not isinstance(number, int) or number < 1:
        raise ValueError(f"capture number: must be a whole number >= 1, got {number!r}")
    stem = re.sub(r"[^A-Za-z0-9_\-]", "_", Path(name or "").stem)[:40] if source == "captures-folder" else ""
    return f"cap-{number:04d}" + (f"-{stem}" if stem else "")


def write_capture_files(folder: Path, rec: CaptureRecord) -> dict[str, Any]:
    """Store a capture's photo (JPEG) and depth (16-bit PNG, [mm]) under ``folder/captures``.

    Returns the capture's metadata for ``session.json`` (file names relative to ``folder``).
    Raises ``OSError`` when the files cannot be stored.
    """
    import cv2

    safe_id = re.sub(r"[^A-Za-z0-9_\-]", "_", rec.id)[:64] or "capture"
    (folder / CAPTURE_DIR).mkdir(parents=True, exist_ok=True)
    photo = f"{CAPTURE_DIR}/{safe_id}.jpg"
    cv2.imwrite(str(folder / photo), cv2.cvtColor(rec.image, cv2.COLOR_RGB2BGR))
    depth_name = None
    if rec.depth is not None:
        depth_name = f"{CAPTURE_DIR}/{safe_id}_depth_mm.png"
        mm = np.clip(np.nan_to_num(rec.depth, nan=0.0, posinf=0.0) * 1000.0, 0, 65535).astype(np.uint16)
        cv2.imwrite(str(folder / depth_name), mm)
    t, q = rec.camera_pose.translation, rec.camera_pose.quaternion
    rt, rq = rec.robot_pose.translation, rec.robot_pose.quaternion
    return {
        "id": rec.id,
        "photo": photo,
        "depth_mm": depth_name,
        "intrinsics": rec.intrinsics.to_dict(),
        "camera_pose": {"translation": list(t), "quaternion_xyzw": list(q)},
        "robot_pose": {"translation": list(rt), "quaternion_xyzw": list(rq)},
        "detections": [{"label": d.label, "score": d.score, "bbox": list(d.bbox), "object_id": d.object_id}
                       for d in rec.detections],
        "backend": rec.backend,
        "timings": dict(rec.timings),
        "timestamp": rec.timestamp,
    }


def read_capture_files(folder: Path, meta: Mapping[str, Any]) -> CaptureRecord:
    """Load a capture stored by :func:`write_capture_files` from its metadata.

    Raises ``KeyError``, ``TypeError`` or ``ValueError`` for malformed metadata, missing photos
    or files outside ``folder``.
    """
    import cv2

    def inside(rel: Any) -> Path:
        p = (folder / str(rel)).resolve()
        if not p.is_relative_to(folder):
            raise ValueError(f"{rel!r} lies outside the session folder")
        return p

    from pipeline.camera.image_io import ImageError, load_image

    try:  # the one image convention (upright, corrupt data refused), as for every other photo
        rgb = load_image(inside(meta["photo"]), name=f"photo {meta['photo']}")
    except ImageError as exc:
        raise ValueError(f"{exc} (missing or unreadable)") from None
    depth = None
    if meta.get("depth_mm"):
        d = cv2.imread(str(inside(meta["depth_mm"])), cv2.IMREAD_UNCHANGED)
        if d is not None:
            depth = d.astype(np.float32) / 1000.0
            depth[d == 0] = np.nan
    i = meta["intrinsics"]
    intr = Intrinsics(float(i["fx"]), float(i["fy"]), float(i["cx"]), float(i["cy"]),
                      int(i["width"]), int(i["height"]))
    cp, rp = meta["camera_pose"], meta["robot_pose"]
    dets = tuple(Detection(str(d["label"]), float(d["score"]), tuple(float(v) for v in d["bbox"]),  # type: ignore[arg-type]
                           d.get("object_id")) for d in meta.get("detections", []))
    return CaptureRecord(
        id=str(meta["id"]),
        image=rgb,
        intrinsics=intr,
        camera_pose=Pose(tuple(cp["translation"]), tuple(cp["quaternion_xyzw"])),  # type: ignore[arg-type]
        robot_pose=Pose(tuple(rp["translation"]), tuple(rp["quaternion_xyzw"])),  # type: ignore[arg-type]
        detections=dets,
        depth=depth,
        backend=str(meta.get("backend", "")),
        timings={str(k): float(v) for k, v in (meta.get("timings") or {}).items()},
        timestamp=float(meta.get("timestamp", 0.0)),
    )
