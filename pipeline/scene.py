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
"""

from __future__ import annotations

import json
import math
import os
import tempfile
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any, Literal, Mapping, Sequence, cast

SCENE_VERSION = 1
"""Version written into every scene file; files with a newer version are rejected."""

Frame = Literal["camera", "robot", "world"]
FRAMES: tuple[Frame, ...] = ("camera", "robot", "world")

Vec3 = tuple[float, float, float]


class SceneError(ValueError):
    """A scene file or dict is malformed; ``field`` names the offending field path."""

    def __init__(self, field: str, message: str) -> None:
        self.field = field
        super().__init__(f"{field}: {message}" if field else message)


@dataclass(frozen=True)
class Source:
    """Where an object came from and how its position was estimated.

    Attributes:
        capture: Id of the capture (photo) the object was mapped from, ``None`` if manual.
        method: Estimate that produced the position: ``fused`` (size prior + depth),
            ``geometric`` (size prior only), ``depth`` (depth map only), ``manual``,
            ``ground_truth`` or ``demo``.
        bbox: 2D box ``(x1, y1, x2, y2)`` [px] in the capture's image.
        mask_area: Segmentation mask area [px].
        distances: Distance estimates along the optical axis [m], keyed ``geometric``,
            ``depth`` and ``fused`` (``None`` where not available).
        positions: The object's centre in the other frames, keyed by frame name [m].
    """

    capture: str | None = None
    method: str = "manual"
    bbox: tuple[float, float, float, float] | None = None
    mask_area: int | None = None
    distances: Mapping[str, float | None] = field(default_factory=dict)
    positions: Mapping[str, Vec3] = field(default_factory=dict)


@dataclass(frozen=True)
class Sighting:
    """One observation of an object by a capture, as the map fusion weighed it (world frame).

    Attributes:
        capture: Id of the capture that saw it (``None``: the object as it was before fusion kept
            history, e.g. loaded from a file).
        position: The observation's box centre [m].
        yaw: Its heading of the length axis about +z [rad].
        size: Its ``(w, h, l)`` [m].
        sigma: 1-sigma errors ``(along the camera ray [m], across it [m], yaw [rad])``.
        camera: Camera centre at capture [m], ``None`` if unknown (then ``sigma`` is isotropic).
        distance: Camera-to-object-centre distance [m], ``None`` if unknown.
        used: Whether it moved the object (``False``: rejected, or the object is pinned).
        note: Why not used, or what was corrected.
    """

    capture: str | None
    position: Vec3
    yaw: float
    size: Vec3
    sigma: Vec3
    camera: Vec3 | None = None
    distance: float | None = None
    used: bool = True
    note: str = ""


@dataclass(frozen=True)
class SceneObject:
    """One object: an oriented box with a label.

    Attributes:
        id: Unique id within the scene.
        label: Catalog class name (e.g. ``office_chair``).
        position: Box centre [m] in ``frame``.
        size: ``(w, h, l)`` full extents [m]; ``h`` vertical.
        yaw: Heading of the length axis about the frame's vertical axis [rad].
        frame: Frame of ``position`` and ``yaw``.
        score: Detector confidence in [0, 1] (1 for manual or ground-truth objects).
        size_known: Whether ``size`` comes from the catalog (True) or was measured/guessed.
        source: Provenance of the estimate.
        pinned: The operator moved, typed or confirmed it: observations never move it (see
            :attr:`is_pinned`, which also counts ``source.method == "manual"``).
        history: The observations fused into it, oldest first (see :mod:`pipeline.map_fusion`).
        flags: Corrections made by the map fusion, for the operator (``set on the floor: ...``).
        sigma: The mapper's 1-sigma [m] of the centre along the camera ray (inverse-variance fusion of
            its distance cues, :mod:`pipeline.fusion`), ``None`` when not estimated.
        cut: Sides of the 2D box the image border cuts (``left``, ``top``, ``right``, ``bottom``).
    """

    id: str
    label: str
    position: Vec3
    size: Vec3
    yaw: float = 0.0
    frame: Frame = "world"
    score: float = 1.0
    size_known: bool = True
    source: Source = field(default_factory=Source)
    pinned: bool = False
    history: tuple[Sighting, ...] = ()
    flags: tuple[str, ...] = ()
    sigma: float | None = None
    cut: tuple[str, ...] = ()

    @property
    def is_pinned(self) -> bool:
        """Placed, moved or confirmed by the operator: the map fusion never moves it."""
        return self.pinned or self.source.method == "manual"

    def moved(self, position: Vec3, yaw: float | None = None) -> "SceneObject":
        """A copy at a new position (and optionally heading), marked as manually placed."""
        return replace(
            self,
            position=position,
            yaw=self.yaw if yaw is None else yaw,
            source=replace(self.source, method="manual"),
        )


@dataclass(frozen=True)
class Capture:
    """One photo the scene was mapped from.

    Attributes:
        id: Unique id within the scene.
        timestamp: Capture time [s since the Unix epoch].
        image: Image file name (relative to the scene file) or ``None``.
        intrinsics: ``fx, fy, cx, cy`` [px] and ``width, height`` [px].
        robot_pose: Robot pose at capture in the world frame: ``x, y, z`` [m], ``yaw`` [rad].
        camera_position: Camera centre in the world frame [m].
        camera_quaternion: Camera-to-world rotation as quaternion ``(x, y, z, w)``.
        timings: Per-stage wall time [s] (``detect``, ``segment``, ``depth``, ``total`` ...).
        models: Names of the models used, keyed by stage.
    """

    id: str
    timestamp: float = 0.0
    image: str | None = None
    intrinsics: Mapping[str, float] = field(default_factory=dict)
    robot_pose: Mapping[str, float] = field(default_factory=dict)
    camera_position: Vec3 | None = None
    camera_quaternion: tuple[float, float, float, float] | None = None
    timings: Mapping[str, float] = field(default_factory=dict)
    models: Mapping[str, str] = field(default_factory=dict)


@dataclass(frozen=True)
class Scene:
    """A set of objects and the captures they were mapped from."""

    objects: tuple[SceneObject, ...] = ()
    captures: tuple[Capture, ...] = ()
    version: int = SCENE_VERSION

    def __post_init__(self) -> None:
        ids = [o.id for o in self.objects]
        if len(set(ids)) != len(ids):
            dup = next(i for i in ids if ids.count(i) > 1)
            raise SceneError("objects", f"duplicate object id {dup!r}")

    def object(self, object_id: str) -> SceneObject:
        """The object with this id (KeyError if absent)."""
        for obj in self.objects:
            if obj.id == object_id:
                return obj
        raise KeyError(object_id)

    def with_objects(self, objects: Sequence[SceneObject]) -> "Scene":
        """A copy holding ``objects`` instead."""
        return replace(self, objects=tuple(objects))

    def to_dict(self) -> dict[str, Any]:
        return scene_to_dict(self)

    def to_json(self) -> str:
        return json.dumps(scene_to_dict(self), indent=1)

    def save(self, path: str | os.PathLike[str]) -> Path:
        """Write atomically (a temporary file renamed into place): never a partial file."""
        return write_text_atomic(Path(path), self.to_json() + "\n")

    @staticmethod
    def load(path: str | os.PathLike[str]) -> "Scene":
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


def write_text_atomic(path: Path, text: str) -> Path:
    """Write ``text`` to ``path`` through a temporary file in the same folder."""
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    try:
        with os.fdopen(fd, "w", encoding="utf-8") as fh:
            fh.write(text)
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
    return path


# --- serialisation ---------------------------------------------------------------------------


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
    }


def scene_from_json(text: str) -> Scene:
    """Parse and validate scene JSON text."""
    try:
        data = json.loads(text)
    except json.JSONDecodeError as exc:
        raise SceneError("", f"not valid JSON (line {exc.lineno}, column {exc.colno}): {exc.msg}") from None
    except RecursionError:
        raise SceneError("", "not usable JSON: nested too deeply") from None
    return scene_from_dict(data)


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
    )


def scene_from_dict(data: Any) -> Scene:
    """Validate a parsed scene dict and build the :class:`Scene`."""
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
    return Scene(objects=tuple(objects), captures=tuple(captures), version=SCENE_VERSION)
