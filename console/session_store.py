"""Session files: the ``session.json`` format, reading, checking and writing it, and safe file names.

A session file holds the scene, route, mission, settings and the last capture's metadata, all in the
world frame [m]. Names typed by the operator are resolved with :func:`resolve_name`, which refuses
anything that would land outside the session folder.
"""

from __future__ import annotations

import json
import re
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from pipeline.scene import Scene, SceneError, scene_from_dict, scene_to_dict, write_text_atomic
from planner.grid import Workspace
from planner.mission import Mission, MissionError
from planner.route import Route

from .session_types import SessionError, Settings

SESSION_VERSION = 1
SESSION_FILE = "session.json"

_NAME_OK = re.compile(r"^[A-Za-z0-9_.\-/ ]+$")


def resolve_name(folder: Path, name: str) -> Path:
    """The file in the session ``folder`` a typed name refers to (``.json`` added if missing).

    Raises :class:`SessionError` for empty names, absolute paths, odd characters, and any name
    that resolves (through ``..`` or symbolic links) outside the session folder.
    """
    text = (name or "").strip()
    if not text:
        raise SessionError("type a file name (it is saved in the session folder)")
    if len(text) > 120:
        raise SessionError("file name too long (120 characters at most)")
    if text.startswith(("/", "~")) or re.match(r"^[A-Za-z]:", text) or "\\" in text:
        raise SessionError(f"{text!r}: give a name inside the session folder, not an absolute path")
    if not _NAME_OK.match(text):
        raise SessionError(f"{text!r}: use letters, digits, spaces, '_', '-', '.' and '/' only")
    if any(part in ("..", ".") for part in Path(text).parts) or text in (".", ".."):
        raise SessionError(f"{text!r}: '..' and '.' are not allowed; names stay inside the session folder")
    if any(part.startswith(".") for part in Path(text).parts):
        raise SessionError(f"{text!r}: names may not start with '.'")
    if not text.endswith(".json"):
        text += ".json"
    target = (folder / text).resolve()
    if not target.is_relative_to(folder) or target == folder:
        raise SessionError(f"{name!r} resolves outside the session folder {folder}")
    return target


def list_saves(folder: Path) -> list[str]:
    """Names of the session files in ``folder`` (newest first)."""
    files = [p for p in folder.glob("*.json") if not p.name.startswith(".")]
    files.sort(key=lambda p: p.stat().st_mtime, reverse=True)
    return [p.name for p in files]


def session_to_dict(
    workspace: Workspace,
    margin: float,
    scene: Scene,
    route: Route,
    mission: Mission | None,
    settings: Settings,
    last_capture: dict[str, Any] | None,
) -> dict[str, Any]:
    """The persistent session state as a JSON-ready dict (the ``session.json`` format)."""
    ws = workspace
    return {
        "version": SESSION_VERSION,
        "kind": "morphonavi-session",
        "saved": time.time(),
        "frame": "world",
        "workspace": {"min": list(ws.min), "max": list(ws.max), "resolution": ws.resolution},
        "margin": margin,
        "scene": scene_to_dict(scene),
        "route": route.to_dict(),
        "mission": None if mission is None else mission.to_dict(),
        "settings": {"goal_mode": settings.goal_mode, "altitude": settings.altitude},
        "last_capture": last_capture,
    }


def write_session_file(path: Path, data: dict[str, Any]) -> None:
    """Write a session dict to ``path`` atomically; raises ``OSError``, ``TypeError`` or ``ValueError``."""
    write_text_atomic(path, json.dumps(data, indent=1) + "\n")


def read_session_file(path: Path, folder: Path) -> Any:
    """The parsed JSON of the session file ``path`` in ``folder``; :class:`SessionError` if unreadable."""
    try:
        return json.loads(path.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise SessionError(f"no saved session {path.name!r} in {folder}") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise SessionError(f"cannot read {path.name}: {exc}") from None
    except json.JSONDecodeError as exc:
        raise SessionError(f"{path.name} is not valid JSON (line {exc.lineno}): {exc.msg}") from None


@dataclass(frozen=True)
class SavedSession:
    """The checked parts of a session file; route, workspace and capture are still raw JSON.

    Attributes:
        scene: Scene (world frame).
        mission: Saved mission, or ``None``.
        goal_mode: ``ground`` or ``altitude``.
        altitude: Goal altitude above the floor [m] (as saved: int or float).
        route: Raw ``route`` entry (restored onto the rebuilt grid by the session).
        workspace: Raw ``workspace`` entry (``{}`` if absent).
        last_capture: Raw ``last_capture`` metadata, or ``None``.
    """

    scene: Scene
    mission: Mission | None
    goal_mode: str
    altitude: float
    route: Any
    workspace: dict[str, Any]
    last_capture: Any


def parse_saved(data: Any, where: str) -> SavedSession:
    """Check a loaded session file; raises :class:`SessionError` naming the bad field (``where`` names the file)."""
    if not isinstance(data, dict) or data.get("kind") != "morphonavi-session":
        raise SessionError(f"{where} is not a MorphoNavi session file")
    if data.get("version") != SESSION_VERSION:
        raise SessionError(f"{where}: version {data.get('version')!r} is not supported (expected {SESSION_VERSION})")
    try:
        scene = scene_from_dict(data.get("scene") or {"version": 1})
    except SceneError as exc:
        raise SessionError(f"{where}: scene.{exc}") from None
    for o in scene.objects:
        if o.frame != "world":
            raise SessionError(f"{where}: scene object {o.id!r} is in the {o.frame} frame, expected world")
    mission: Mission | None = None
    if data.get("mission") is not None:
        try:
            mission = Mission.from_dict(data["mission"])
        except MissionError as exc:
            raise SessionError(f"{where}: mission.{exc}") from None
    settings = data.get("settings") or {}
    mode = settings.get("goal_mode", "ground")
    alt = settings.get("altitude", 1.5)
    if mode not in ("ground", "altitude") or isinstance(alt, bool) or not isinstance(alt, (int, float)):
        raise SessionError(f"{where}: settings must hold goal_mode 'ground'/'altitude' and a numeric altitude")
    return SavedSession(scene, mission, mode, alt, data.get("route"), data.get("workspace") or {},
                        data.get("last_capture"))


def same_workspace(saved: dict[str, Any], ws: Workspace) -> bool:
    """Whether a saved ``workspace`` entry describes ``ws`` exactly (bounds and resolution)."""
    return (saved.get("min") == list(ws.min) and saved.get("max") == list(ws.max)
            and saved.get("resolution") == ws.resolution)
