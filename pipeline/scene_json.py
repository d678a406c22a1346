"""Scene JSON (version :data:`~pipeline.scene.SCENE_VERSION`): writing and validated reading.

:func:`scene_to_dict` gives the JSON-ready dict (numbers rounded: positions and sizes to 0.1 mm,
yaw to 1e-5 rad; the fusion keys ``pinned`` / ``flags`` / ``history`` / ``sigma`` / ``cut`` only
when set). :func:`scene_from_dict` / :func:`scene_from_json` never trust the input: every field is checked (type,
finite, range) and the first bad one raises :class:`~pipeline.scene_model.SceneError` with its path
(``objects[2].size[1]: must be > 0, got -1.0``). The data classes are in :mod:`pipeline.scene_model`;
:mod:`pipeline.scene` re-exports these functions and adds reading / writing files. This module never
imports :mod:`pipeline.scene`.
"""

from __future__ import annotations

import json
import math
from typing import Any, cast

from pipeline.scene_model import (FRAMES, SCENE_VERSION, Capture, Frame, Scene, SceneError, SceneObject, Sighting,
                                  Source, Vec3)


def _source_to_dict(s: Source) -> dict[str, Any]:
    out: dict[str, Any] = {"capture": s.capture, "method": s.method}
    if s.bbox is not None:
        out["bbox"] = [round(v, 2) for v in s.bbox]
    if s.mask_area is not None:
        out["mask_area"] = s.mask_area
    if s.distances:
        out["distances"] = {k: (None if v is None else round(v, 4)) for k, v in s.distances.items()}
    if s.positions:
        out["positions"] = {k: [round(c, 4) for c in v] for k, v in s.positions.items()}
    if s.down_weighted:
        out["down_weighted"] = [{"cue": c, "why": w} for c, w in s.down_weighted]
    return out


def _fusion_to_dict(o: SceneObject) -> dict[str, Any]:
    """``pinned`` / ``flags`` / ``history`` keys, written only when set (older readers ignore them)."""
    out: dict[str, Any] = {}
    if o.pinned:
        out["pinned"] = True
    if o.flags:
        out["flags"] = list(o.flags)
    if o.sigma is not None:
        out["sigma"] = round(o.sigma, 4)
    if o.cut:
        out["cut"] = list(o.cut)
    if o.history:
        out["history"] = [
            {"capture": h.capture, "position": [round(v, 4) for v in h.position], "yaw": round(h.yaw, 5),
             "size": [round(v, 4) for v in h.size], "sigma": [round(v, 5) for v in h.sigma],
             "camera": None if h.camera is None else [round(v, 4) for v in h.camera],
             "distance": None if h.distance is None else round(h.distance, 4), "used": h.used, "note": h.note}
            for h in o.history
        ]
    return out


def _fusion_from(r: _Reader) -> dict[str, Any]:
    """The ``pinned`` / ``flags`` / ``history`` fields of an object entry (all optional)."""
    pinned = r.raw("pinned", required=False)
    if pinned is not None and not isinstance(pinned, bool):
        raise SceneError(r._p("pinned"), f"must be true or false, got {pinned!r}")
    flags = r.raw("flags", required=False) or []
    if not isinstance(flags, list) or not all(isinstance(f, str) for f in flags):
        raise SceneError(r._p("flags"), "must be a list of strings")
    hist = r.raw("history", required=False) or []
    if not isinstance(hist, list):
        raise SceneError(r._p("history"), "must be a list")
    history = []
    for k, hd in enumerate(hist):
        h = _Reader(hd, r._p(f"history[{k}]"))
        used = h.raw("used", required=False)
        if used is not None and not isinstance(used, bool):
            raise SceneError(h._p("used"), f"must be true or false, got {used!r}")
        note = h.raw("note", required=False) or ""
        if not isinstance(note, str):
            raise SceneError(h._p("note"), f"must be a string, got {note!r}")
        history.append(Sighting(
            capture=h.string("capture", required=False),
            position=cast(Vec3, h.vector("position", 3)), yaw=cast(float, h.number("yaw")),
            size=cast(Vec3, h.vector("size", 3, positive=True)), sigma=cast(Vec3, h.vector("sigma", 3, positive=True)),
            camera=cast("Vec3 | None", h.vector("camera", 3, required=False)),
            distance=h.number("distance", required=False, lo=0.0), used=True if used is None else used, note=note))
    sigma = r.number("sigma", required=False, positive=True)
    cut = r.raw("cut", required=False) or []
    if not isinstance(cut, list) or not all(c in ("left", "top", "right", "bottom") for c in cut):
        raise SceneError(r._p("cut"), f"must be a list of 'left', 'top', 'right', 'bottom', got {cut!r}")
    return {"pinned": bool(pinned), "flags": tuple(flags), "history": tuple(history), "sigma": sigma,
            "cut": tuple(cut)}


def scene_to_dict(scene: Scene) -> dict[str, Any]:
    """The JSON-ready dict of a scene (format version :data:`SCENE_VERSION`)."""
    return {
        "version": SCENE_VERSION,
        "units": "metres, radians, seconds",
        "objects": [
            {
                "id": o.id,
                "label": o.label,
                "score": round(o.score, 4),
                "frame": o.frame,
                "position": [round(v, 4) for v in o.position],
                "size": [round(v, 4) for v in o.size],
                "yaw": round(o.yaw, 5),
                "size_known": o.size_known,
                "source": _source_to_dict(o.source),
                **_fusion_to_dict(o),
            }
            for o in scene.objects
        ],
        "captures": [
            {
                "id": c.id,
                "timestamp": c.timestamp,
                "image": c.image,
                "intrinsics": dict(c.intrinsics),
                "robot_pose": dict(c.robot_pose),
                "camera_position": None if c.camera_position is None else list(c.camera_position),
                "camera_quaternion": None
                if c.camera_quaternion is None
                else list(c.camera_quaternion),
                "timings": {k: round(v, 4) for k, v in c.timings.items()},
                "models": dict(c.models),
            }
            for c in scene.captures
        ],
        **({"last_ids": dict(scene.last_ids)} if scene.last_ids else {}),
    }


def parse_json_text(text: str) -> Any:
    """``json.loads`` of a scene file's text; :class:`SceneError` saying where it is not valid JSON."""
    try:
        return json.loads(text)
    except json.JSONDecodeError as exc:
        raise SceneError("", f"not valid JSON (line {exc.lineno}, column {exc.colno}): {exc.msg}") from None
    except RecursionError:
        raise SceneError("", "not usable JSON: nested too deeply") from None


class _Reader:
    """Typed field access that reports the full path of a bad field."""

    def __init__(self, data: Any, path: str) -> None:
        if not isinstance(data, dict):
            raise SceneError(path, f"must be an object, got {type(data).__name__}")
        self.data = cast(dict[str, Any], data)
        self.path = path

    def _p(self, key: str) -> str:
        return f"{self.path}.{key}" if self.path else key

    def has(self, key: str) -> bool:
        return self.data.get(key) is not None

    def raw(self, key: str, required: bool = True) -> Any:
        if key not in self.data or self.data[key] is None:
            if required:
                raise SceneError(self._p(key), "is required")
            return None
        return self.data[key]

    def string(self, key: str, required: bool = True) -> str | None:
        v = self.raw(key, required)
        if v is None:
            return None
        if not isinstance(v, str) or not v.strip():
            raise SceneError(self._p(key), f"must be a non-empty string, got {v!r}")
        return v

    def number(self, key: str, required: bool = True, *, lo: float | None = None,
               hi: float | None = None, positive: bool = False) -> float | None:
        v = self.raw(key, required)
        if v is None:
            return None
        return _number(v, self._p(key), lo=lo, hi=hi, positive=positive)

    def vector(self, key: str, n: int, required: bool = True, *, positive: bool = False) -> tuple[float, ...] | None:
        v = self.raw(key, required)
        if v is None:
            return None
        if not isinstance(v, list) or len(v) != n:
            raise SceneError(self._p(key), f"must be a list of {n} numbers, got {v!r}")
        return tuple(_number(x, f"{self._p(key)}[{i}]", positive=positive) for i, x in enumerate(v))

    def number_map(self, key: str, *, nullable: bool = False) -> dict[str, Any]:
        v = self.raw(key, required=False) or {}
        if not isinstance(v, dict):
            raise SceneError(self._p(key), "must be an object of numbers")
        out: dict[str, Any] = {}
        for k, x in v.items():
            out[str(k)] = None if (x is None and nullable) else _number(x, f"{self._p(key)}.{k}")
        return out


def _number(v: Any, path: str, *, lo: float | None = None, hi: float | None = None,
            positive: bool = False) -> float:
    if isinstance(v, bool) or not isinstance(v, (int, float)):
        raise SceneError(path, f"must be a number, got {v!r}")
    f = float(v)
    if not math.isfinite(f):
        raise SceneError(path, f"must be finite, got {v!r}")
    if positive and f <= 0:
        raise SceneError(path, f"must be > 0, got {f}")
    if lo is not None and f < lo:
        raise SceneError(path, f"must be >= {lo}, got {f}")
    if hi is not None and f > hi:
        raise SceneError(path, f"must be <= {hi}, got {f}")
    return f


def _source_from(r: _Reader) -> Source:
    bbox = r.vector("bbox", 4, required=False)
    area = r.number("mask_area", required=False, lo=0)
    positions_raw = r.raw("positions", required=False) or {}
    if not isinstance(positions_raw, dict):
        raise SceneError(f"{r.path}.positions", "must be an object keyed by frame")
    pr = _Reader(positions_raw, f"{r.path}.positions")
    positions: dict[str, Vec3] = {}
    for k in positions_raw:
        if k not in FRAMES:
            raise SceneError(f"{r.path}.positions.{k}", f"unknown frame, expected one of {FRAMES}")
        positions[k] = cast(Vec3, pr.vector(k, 3))
    return Source(
        capture=r.string("capture", required=False),
        method=r.string("method", required=False) or "manual",
        bbox=cast("tuple[float, float, float, float] | None", bbox),
        mask_area=None if area is None else int(area),
        distances=r.number_map("distances", nullable=True),
        positions=positions,
        down_weighted=_reasons_from(r.raw("down_weighted", required=False) or [], f"{r.path}.down_weighted"),
    )


def _reasons_from(raw: Any, path: str) -> tuple[tuple[str, str], ...]:
    """``source.down_weighted``: a list of ``{"cue": str, "why": str}``."""
    if not isinstance(raw, list):
        raise SceneError(path, "must be a list of {cue, why} objects")
    out = []
    for i, item in enumerate(raw):
        if not (isinstance(item, dict) and isinstance(item.get("cue"), str) and item["cue"]
                and isinstance(item.get("why"), str)):
            raise SceneError(f"{path}[{i}]", "must be an object with a non-empty string 'cue' and a string 'why'")
        out.append((item["cue"], item["why"]))
    return tuple(out)


def scene_from_dict(data: Any) -> Scene:
    """Validate a parsed scene dict and build the :class:`~pipeline.scene_model.Scene`."""
    root = _Reader(data, "")
    version = root.number("version")
    assert version is not None
    if int(version) != version or version < 1:
        raise SceneError("version", f"must be a positive integer, got {version}")
    if version > SCENE_VERSION:
        raise SceneError("version", f"file has version {int(version)}, this MorphoNavi reads up to {SCENE_VERSION}")
    objs_raw = root.raw("objects", required=False) or []
    if not isinstance(objs_raw, list):
        raise SceneError("objects", "must be a list")
    objects: list[SceneObject] = []
    seen: set[str] = set()
    for i, od in enumerate(objs_raw):
        r = _Reader(od, f"objects[{i}]")
        oid = cast(str, r.string("id"))
        if oid in seen:
            raise SceneError(f"objects[{i}].id", f"duplicate id {oid!r}")
        seen.add(oid)
        frame = r.string("frame", required=False) or "world"
        if frame not in FRAMES:
            raise SceneError(f"objects[{i}].frame", f"must be one of {FRAMES}, got {frame!r}")
        size_known = r.raw("size_known", required=False)
        if size_known is not None and not isinstance(size_known, bool):
            raise SceneError(f"objects[{i}].size_known", f"must be true or false, got {size_known!r}")
        src = _source_from(_Reader(r.raw("source", required=False) or {}, f"objects[{i}].source"))
        objects.append(
            SceneObject(
                id=oid,
                label=cast(str, r.string("label")),
                position=cast(Vec3, r.vector("position", 3)),
                size=cast(Vec3, r.vector("size", 3, positive=True)),
                yaw=cast(float, r.number("yaw", required=False) or 0.0),
                frame=cast(Frame, frame),
                score=cast(float, r.number("score", required=False, lo=0.0, hi=1.0) if r.has("score") else 1.0),
                size_known=True if size_known is None else size_known,
                source=src,
                **_fusion_from(r),
            )
        )
    caps_raw = root.raw("captures", required=False) or []
    if not isinstance(caps_raw, list):
        raise SceneError("captures", "must be a list")
    captures: list[Capture] = []
    for i, cd in enumerate(caps_raw):
        r = _Reader(cd, f"captures[{i}]")
        quat = r.vector("camera_quaternion", 4, required=False)
        models = r.raw("models", required=False) or {}
        if not isinstance(models, dict):
            raise SceneError(f"captures[{i}].models", "must be an object")
        captures.append(
            Capture(
                id=cast(str, r.string("id")),
                timestamp=cast(float, r.number("timestamp", required=False) or 0.0),
                image=r.string("image", required=False),
                intrinsics=r.number_map("intrinsics"),
                robot_pose=r.number_map("robot_pose"),
                camera_position=cast("Vec3 | None", r.vector("camera_position", 3, required=False)),
                camera_quaternion=cast("tuple[float, float, float, float] | None", quat),
                timings=r.number_map("timings"),
                models={str(k): str(v) for k, v in models.items()},
            )
        )
    return Scene(objects=tuple(objects), captures=tuple(captures), version=SCENE_VERSION,
                 last_ids=_last_ids_from(root.raw("last_ids", required=False)))


def _last_ids_from(raw: Any) -> dict[str, int]:
    """``last_ids``: class name -> highest id number it has had (a non-negative integer); ``{}`` if absent."""
    if raw is None:
        return {}
    if not isinstance(raw, dict):
        raise SceneError("last_ids", f"must be an object of class name -> integer, got {type(raw).__name__}")
    out: dict[str, int] = {}
    for k, v in raw.items():
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) or v < 0 or int(v) != v:
            raise SceneError(f"last_ids.{k}", f"must be a non-negative integer, got {v!r}")
        out[str(k)] = int(v)
    return out


def scene_from_json(text: str) -> Scene:
    """Parse and validate scene JSON text."""
    return scene_from_dict(parse_json_text(text))


__all__ = ["parse_json_text", "scene_to_dict", "scene_from_dict", "scene_from_json"]
