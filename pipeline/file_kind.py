"""What a file is: every file a user can point a ``morphonavi`` command at knows its kind.

Each reader checks the kind of the file it was given before it reads it as its own, so a console
session handed to ``plan`` is refused with what it is and which command reads it
(``session.json is a console session, not a scene: open it with morphonavi console --session DIR``)
instead of being read as an empty scene.

Kinds (:data:`KINDS`): scene, scene graph (``describe --json``), console session, console undo history
(``history.json``), mission, search result (``search --out``), search benchmark results
(``bench/search.py --json``), known space, camera file (``camera.toml``), dataset photo JSON (intrinsics ``K``
beside a photo), dataset index, simulator world file (``console --world``), bench report, JSON Schema
(``docs/schemas``), recording (MCAP), object catalog (TOML), photo. A JSON file is recognised from its
keys (:func:`kind_of_json`); other files from their first bytes and suffix (:func:`sniff`).

Every input is size-checked before it is parsed (:func:`read_limited`): the limits and their numbers
are in :data:`MAX_BYTES` and are stated in the refusal.
"""

from __future__ import annotations

import json
import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any

MCAP_MAGIC = b"\x89MCAP0\r\n"
"""First bytes of every MCAP file (the recording format)."""

PNG_MAGIC = b"\x89PNG\r\n\x1a\n"
JPEG_MAGIC = b"\xff\xd8\xff"

MB = 1_000_000

MAX_BYTES = {
    "scene": 100 * MB,
    "session": 50 * MB,
    "mission": 20 * MB,
    "camera_toml": 1 * MB,
    "catalog": 5 * MB,
}
"""Largest file each reader parses [bytes]: a scene of 10 000 objects with their history is about
10 MB; a session holds one such scene; a camera file is a few hundred bytes."""

MAX_SCENE_OBJECTS = 20_000
"""Most objects ``plan`` and ``describe`` read from one scene file (their work is measured at 10 000)."""


@dataclass(frozen=True)
class Kind:
    """One kind of file: its key, how to say it, and which command reads it."""

    key: str
    what: str
    """Said after "is": ``a console session``."""
    reader: str
    """Where it belongs: ``open it with `morphonavi console --session DIR```."""


KINDS: dict[str, Kind] = {k.key: k for k in (
    Kind("scene", "a scene", "read it with `morphonavi plan SCENE` or `morphonavi describe SCENE`, "
                             "or drop it into the console's watched folder (`morphonavi console --scene DIR`)"),
    Kind("scene_graph", "a scene graph (written by `morphonavi describe --json`)",
         "it is describe's output; give describe or plan the scene file it was made from"),
    Kind("session", "a console session (written by `morphonavi console`)",
         "open it with `morphonavi console --session DIR` (DIR: the folder holding it); the console's map is "
         "its \"scene\" entry"),
    Kind("history", "a console undo history (morphonavi-history, written by `morphonavi console` beside "
                    "session.json)",
         "the console reads it back with its session: open the folder holding it with "
         "`morphonavi console --session DIR`"),
    Kind("mission", "a mission (written by `morphonavi plan` or the console)",
         "it is plan's output; give the scene file it was planned on"),
    Kind("search_result", "a search result (written by `morphonavi search --out`)", "it is search's output"),
    Kind("search_bench", "a search benchmark's results (written by `bench/search.py --json`)",
         "it is the benchmark's output"),
    Kind("known_space", "a known space (morphonavi.known_space)",
         "give it to `morphonavi plan SCENE --known-space FILE`"),
    Kind("json_schema", "a JSON Schema (docs/schemas)",
         "it describes a file kind: check a file against it with `python -m console.schemas --validate KIND FILE`"),
    Kind("camera_toml", "a camera file (camera.toml)",
         "give it to `morphonavi map --camera` or `morphonavi console --camera-file`"),
    Kind("dataset_camera", "a dataset photo's camera JSON (K, width, height beside a photo)",
         "give its folder to `morphonavi console --captures DIR` or `morphonavi bench DIR`"),
    Kind("dataset_index", "a dataset index (index.json)",
         "give its folder to `morphonavi bench DIR` or `morphonavi console --captures DIR`"),
    Kind("world", "a simulator world file", "give it to `morphonavi console --world FILE`"),
    Kind("bench_report", "a bench report (written by `morphonavi bench --out`)", "it is bench's output"),
    Kind("recording", "a recording (MCAP)", "replay it with `morphonavi replay FILE.mcap`"),
    Kind("catalog", "an object catalog (TOML)", "give it to `morphonavi map --catalog` or `bench --catalog`"),
    Kind("photo", "a photo", "map it with `morphonavi map PHOTO`"),
    Kind("json", "JSON of no MorphoNavi kind", ""),
    Kind("unknown", "not a file MorphoNavi reads", ""),
)}


class FileKindError(ValueError):
    """A file of the wrong kind, or over its size limit; the message says what it is and what to do."""


def kind_of_json(data: Any) -> str:
    """The kind key of parsed JSON: ``scene``, ``session``, ``history``, ``mission``, ``scene_graph``,
    ``search_result``, ``search_bench``, ``known_space``, ``json_schema``, ``world``, ``dataset_camera``,
    ``dataset_index``, ``bench_report`` or ``json`` (none of them)."""
    if isinstance(data, list):
        if data and all(isinstance(e, dict) and "json" in e for e in data):
            return "dataset_index"
        return "json"
    if not isinstance(data, dict):
        return "json"
    if "morphonavi_world" in data:
        return "world"
    if data.get("kind") == "morphonavi-session" or {"workspace", "route", "scene"} <= data.keys():
        return "session"
    if data.get("kind") == "morphonavi-history":
        return "history"
    if data.get("format") == "morphonavi.known_space":
        return "known_space"
    if "$schema" in data and ("properties" in data or "$defs" in data):
        return "json_schema"
    if {"found", "target", "reason", "steps"} <= data.keys():
        return "search_result"
    if {"rows", "records", "config"} <= data.keys():
        return "search_bench"
    if data.get("schema") == "morphonavi.scene_graph" or {"relations", "groups"} <= data.keys():
        return "scene_graph"
    if "segments" in data and ("bounds" in data or "id" in data):
        return "mission"
    if "K" in data and ("width" in data or "image" in data):
        return "dataset_camera"
    if {"dataset", "summary", "samples"} <= data.keys():
        return "bench_report"
    if "version" in data and (data.keys() <= {"version", "units", "objects", "captures"}
                              or data.keys() & {"objects", "captures", "known_space"}):
        return "scene"
    return "json"


def sniff(path: str | os.PathLike[str], head: bytes | None = None) -> str:
    """The kind key of a file from its first bytes and suffix, without parsing it whole.

    JSON files give ``json_file`` here (their kind needs their keys: :func:`kind_of_json`).
    """
    p = Path(path)
    if head is None:
        try:
            with open(p, "rb") as f:
                head = f.read(4096)
        except OSError:
            return "unknown"
    if head.startswith(MCAP_MAGIC):
        return "recording"
    if head.startswith(PNG_MAGIC) or head.startswith(JPEG_MAGIC):
        return "photo"
    text = head.lstrip(b"\xef\xbb\xbf \t\r\n")
    toml = p.suffix.lower() == ".toml" or b"[intrinsics]" in head or b"[[object]]" in head or b"[mount]" in head
    if text[:1] in (b"{", b"[") and not toml:
        return "json_file"
    if toml:
        if b"[[object]]" in head:
            return "catalog"
        if b"[intrinsics]" in head or b"[mount]" in head:
            return "camera_toml"
        return "unknown"
    if p.suffix.lower() in (".jpg", ".jpeg", ".png", ".bmp", ".tif", ".tiff", ".webp"):
        return "photo"
    return "unknown"


def wrong_kind(where: str, name: str, found: str, expected: str) -> str:
    """The refusal text: ``plan: session.json is a console session ..., not a scene: open it with ...``."""
    k = KINDS[found]
    want = KINDS[expected].what
    tail = f": {k.reader}" if k.reader else ""
    return f"{where}{name} is {k.what}, not {want}{tail}"


def os_error_words(exc: BaseException, path: str | os.PathLike[str]) -> str:
    """What an :class:`OSError` of writing or reading ``path`` means, in words (never ``[Errno 13] ...``)."""
    import errno

    folder = Path(path).expanduser().parent
    code = getattr(exc, "errno", None) or 0
    return {
        errno.EACCES: f"no permission to write in {folder}",
        errno.EPERM: f"no permission to write in {folder}",
        errno.EROFS: f"{folder} is on a read-only file system",
        errno.ENOSPC: "the disk is full",
        errno.EDQUOT: "the disk quota is used up",
        errno.ENOENT: f"the folder {folder} does not exist",
        errno.ENOTDIR: f"{folder} is not a folder",
        errno.EISDIR: f"{path} is a folder",
        errno.EEXIST: f"{path} exists and is not a folder",
        errno.ENAMETOOLONG: "the file name is too long",
    }.get(code, (getattr(exc, "strerror", None) or str(exc) or type(exc).__name__).lower())


def read_limited(path: str | os.PathLike[str], limit: int, what: str, option: str = "") -> bytes:
    """The bytes of ``path`` when it is at most ``limit`` bytes, checked before it is read.

    Raises:
        FileKindError: Missing, a folder, unreadable, or over the limit (the message names ``option``
            or the file, the size and the limit).
    """
    p = Path(path)
    label = f"{option} {p}" if option else str(p)
    try:
        st = p.stat()
    except FileNotFoundError:
        noun = what.split(" ", 1)[1] if what.startswith(("a ", "an ")) else what
        raise FileKindError(f"{noun} file not found: {label}") from None
    except OSError as exc:
        raise FileKindError(f"{label}: cannot read it ({exc.strerror or type(exc).__name__})") from None
    if p.is_dir():
        raise FileKindError(f"{label}: is a folder, not {what} file")
    if st.st_size > limit:
        raise FileKindError(f"{label}: {st.st_size / MB:.1f} MB is over the {limit / MB:g} MB limit for "
                            f"{what} file: not read")
    try:
        with open(p, "rb") as f:
            data = f.read(limit + 1)
    except OSError as exc:
        raise FileKindError(f"{label}: cannot read it ({exc.strerror or type(exc).__name__})") from None
    if len(data) > limit:  # grew since stat
        raise FileKindError(f"{label}: over the {limit / MB:g} MB limit for {what} file: not read")
    return data


def read_json_of_kind(path: str | os.PathLike[str], expected: str, where: str = "", limit: int | None = None,
                      option: str = "") -> Any:
    """Parsed JSON of ``path`` when it is a file of kind ``expected`` (``scene``, ``mission`` ...).

    The size is checked first (``limit``, default :data:`MAX_BYTES` of the kind), then the first bytes
    (a recording, photo or TOML file is named as such), then the keys of the parsed JSON.

    Args:
        path: The file the user gave.
        expected: The kind key the reader wants.
        where: Prefix of messages, e.g. ``"plan: "``.
        limit: Largest size [bytes].
        option: The option that named the file (``--scene``), for messages.

    Raises:
        FileKindError: Wrong kind (naming what it is and which command reads it), over the limit,
            unreadable, or not valid JSON (with line and column).
    """
    p = Path(path)
    limit = MAX_BYTES.get(expected, 20 * MB) if limit is None else limit
    raw = read_limited(p, limit, KINDS[expected].what, option)
    label = f"{option} {p}" if option else str(p)
    kind = sniff(p, raw[:4096])
    if kind not in ("json_file", "unknown"):
        raise FileKindError(wrong_kind(where, label, kind, expected))
    if not raw.strip():
        raise FileKindError(f"{where}{label}: is empty (0 bytes of JSON): expected {KINDS[expected].what} file")
    try:
        text = raw.decode("utf-8-sig")
    except UnicodeDecodeError:
        raise FileKindError(f"{where}{label} is {KINDS['unknown'].what} (not UTF-8 text): "
                            f"expected {KINDS[expected].what} (JSON)") from None
    try:
        data = json.loads(text)
    except json.JSONDecodeError as exc:
        raise FileKindError(f"{where}{label}: not valid JSON (line {exc.lineno}, column {exc.colno}): "
                            f"{exc.msg}") from None
    except RecursionError:
        raise FileKindError(f"{where}{label}: not usable JSON: nested too deeply") from None
    found = kind_of_json(data)
    if found != expected:
        if found == "json" and not isinstance(data, dict):  # an array, a number...: no keys to name
            raise FileKindError(f"{where}{label} is not {KINDS[expected].what}: it is {_json_value(data)}, "
                                "not a MorphoNavi file")
        if found == "json":
            keys = ", ".join(list(data)[:6]) if isinstance(data, dict) else type(data).__name__
            raise FileKindError(f"{where}{label} is not {KINDS[expected].what}: it is JSON of no MorphoNavi "
                                f"kind (keys: {keys}); {KINDS[expected].what} has \"version\" and \"objects\""
                                if expected == "scene" else
                                f"{where}{label} is not {KINDS[expected].what}: JSON of no MorphoNavi kind")
        raise FileKindError(wrong_kind(where, label, found, expected))
    return data


def _json_value(data: Any) -> str:
    """What a JSON document that is not an object holds, in words (``a JSON array``, ``a JSON number``)."""
    if isinstance(data, list):
        return "a JSON array"
    if isinstance(data, bool):
        return "a JSON true/false"
    if isinstance(data, (int, float)):
        return "a JSON number"
    if isinstance(data, str):
        return "a JSON string"
    return "JSON null" if data is None else "JSON of no MorphoNavi kind"


def check_scene_ranges(scene: Any) -> None:
    """Every position and pose in a scene within the ranges a command-line pose has
    (:func:`pipeline.option_values.check_pose_range`: ``|x|, |y|`` <= 10 000 m, ``|z|`` <= 1 000 m,
    ``|yaw|`` <= 360 deg), and every camera quaternion of non-zero length.

    Raises:
        pipeline.scene.SceneError: Naming the field, the value and the range.
    """
    import math

    from pipeline.option_values import POSE_XY_LIMIT_M, POSE_YAW_LIMIT_DEG, POSE_Z_LIMIT_M
    from pipeline.scene import SceneError

    limits = (POSE_XY_LIMIT_M, POSE_XY_LIMIT_M, POSE_Z_LIMIT_M)

    def check(v: float, limit: float, field: str, unit: str = "m") -> None:
        if not abs(v) <= limit:
            raise SceneError(field, f"{v:g} {unit} is outside {-limit:g}..{limit:g} {unit}, the range of a pose: "
                                    "a mapping error or a wrong unit; fix or remove it")

    for i, o in enumerate(scene.objects):
        for a, v in enumerate(o.position):
            check(v, limits[a], f"objects[{i}].position[{a}]")
    yaw_limit = math.radians(POSE_YAW_LIMIT_DEG) + 1e-6
    for i, c in enumerate(scene.captures):
        for a, key in enumerate(("x", "y", "z")):
            if key in c.robot_pose:
                check(float(c.robot_pose[key]), limits[a], f"captures[{i}].robot_pose.{key}")
        if "yaw" in c.robot_pose:
            check(float(c.robot_pose["yaw"]), yaw_limit, f"captures[{i}].robot_pose.yaw", "rad")
        if c.camera_position is not None:
            for a, v in enumerate(c.camera_position):
                check(v, limits[a], f"captures[{i}].camera_position[{a}]")
        if c.camera_quaternion is not None and math.fsum(q * q for q in c.camera_quaternion) < 1e-12:
            raise SceneError(f"captures[{i}].camera_quaternion",
                             "is all zero: a rotation quaternion (x, y, z, w) has length 1, e.g. [0, 0, 0, 1] "
                             "for no rotation; fix it or remove the key")


def load_scene_file(path: str | os.PathLike[str], where: str = "", option: str = "",
                    max_objects: int = MAX_SCENE_OBJECTS) -> Any:
    """A validated :class:`pipeline.scene.Scene` from a scene file: its size, kind and object count
    checked before its objects are (:func:`read_json_of_kind`).

    Raises:
        FileKindError: Wrong kind, over a limit, unreadable or not JSON.
        pipeline.scene.SceneError: A bad field (named).
    """
    from pipeline.scene import SceneError, scene_from_dict

    data = read_json_of_kind(path, "scene", where, option=option)
    objs = data.get("objects")
    if isinstance(objs, list) and len(objs) > max_objects:
        raise SceneError("objects", f"{len(objs)} objects is over the limit of {max_objects} for one scene file")
    scene = scene_from_dict(data)
    check_scene_ranges(scene)
    return scene


def describe_file(path: str | os.PathLike[str], limit: int = 100 * MB) -> str:
    """The kind key of any file (JSON files parsed, up to ``limit`` bytes; larger ones give ``json``)."""
    kind = sniff(path)
    if kind != "json_file":
        return kind
    try:
        if Path(path).stat().st_size > limit:
            return "json"
        return kind_of_json(json.loads(Path(path).read_text(encoding="utf-8-sig")))
    except (OSError, ValueError, RecursionError):
        return "json"


__all__ = ["FileKindError", "check_scene_ranges", "os_error_words", "KINDS", "Kind", "MAX_BYTES", "MAX_SCENE_OBJECTS", "MCAP_MAGIC", "describe_file",
           "kind_of_json", "load_scene_file", "read_json_of_kind", "read_limited", "sniff", "wrong_kind"]
