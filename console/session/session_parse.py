"""Reading a saved session (``session.json``): every part checked, naming the field, into :class:`SavedSession`.

:func:`parse_saved` refuses a file that is not a session, or whose scene is malformed or implausible, as a whole;
a bad route, mission, settings or last capture is dropped with the reason (the valid parts are kept). World
frame [m]. :mod:`console.session.session_store` writes the format and restores what this module reads.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from typing import Any

from pipeline.scene import Scene, SceneError, check_plausible, scene_from_dict
from planner.grid import Workspace
from planner.mission import Mission, MissionError

from console.session.session_types import SessionError

SESSION_VERSION = 1
"""Version written into ``session.json``; the reader refuses other versions."""


def _non_finite(value: Any, path: str) -> str | None:
    """The path of the first non-finite number inside ``value`` (``route.start[2]``), or ``None``."""
    if isinstance(value, float) and not math.isfinite(value):
        return path
    if isinstance(value, dict):
        for k, v in value.items():
            found = _non_finite(v, f"{path}.{k}")
            if found:
                return found
    elif isinstance(value, list):
        for i, v in enumerate(value):
            found = _non_finite(v, f"{path}[{i}]")
            if found:
                return found
    return None


def _check_finite(value: Any, path: str) -> None:
    bad = _non_finite(value, path)
    if bad is not None:
        raise SceneError(bad, "must be finite")


def _is_number(v: Any) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)


def check_route(route: Any, workspace: Workspace | None = None) -> None:
    """Check a saved ``route`` entry (points inside ``workspace``); raises :class:`SceneError` naming the bad field."""
    if not isinstance(route, dict):
        raise SceneError("route", f"must be an object, got {type(route).__name__}")
    _check_finite(route, "route")
    start = route.get("start")
    if not isinstance(start, list) or len(start) != 3 or not all(_is_number(v) for v in start):
        raise SceneError("route.start", f"must be 3 finite numbers [m], got {start!r}")
    segs = route.get("registered", [])
    if not isinstance(segs, list):
        raise SceneError("route.registered", "must be a list of segments")
    for i, seg in enumerate(segs):
        if not isinstance(seg, list):
            raise SceneError(f"route.registered[{i}]", "must be a list of [i, j, k] cells")
        for j, cell in enumerate(seg):
            if (not isinstance(cell, list) or len(cell) != 3
                    or not all(isinstance(c, int) and not isinstance(c, bool) and c >= 0 for c in cell)):
                raise SceneError(f"route.registered[{i}][{j}]", f"must be 3 cell indices >= 0, got {cell!r}")
    goal = route.get("candidate_goal")
    if goal is not None and (not isinstance(goal, list) or len(goal) != 3 or not all(_is_number(v) for v in goal)):
        raise SceneError("route.candidate_goal", f"must be 3 finite numbers [m] or null, got {goal!r}")
    if workspace is not None:
        for name, p in (("start", start), ("candidate_goal", goal)):
            if p is not None and not workspace.contains(p):
                raise SceneError(f"route.{name}", f"{p} lies outside the workspace {list(workspace.min)}..{list(workspace.max)} [m]")


@dataclass(frozen=True)
class SavedSession:
    """The checked parts of a session file.

    Attributes:
        scene: Scene (world frame), checked and plausible for the workspace.
        mission: Saved mission, or ``None`` (none saved, or dropped: see ``problems``).
        goal_mode: ``ground`` or ``altitude``.
        altitude: Goal altitude above the floor [m].
        route: Checked ``route`` entry (restored onto the rebuilt grid by the session), or ``None``.
        last_capture: Checked ``last_capture`` metadata, or ``None``.
        problems: Why parts were dropped (bad values, the field named); the file deserves keeping aside.
        notes: Other things the operator should know (e.g. a route for another workspace dropped).
    """

    scene: Scene
    mission: Mission | None
    goal_mode: str
    altitude: float
    route: dict[str, Any] | None
    last_capture: dict[str, Any] | None
    problems: tuple[str, ...] = ()
    notes: tuple[str, ...] = ()
    known: Any = None  # known space (console.session.known_space_state), None: none saved
    plan_unknown: str = "closed"


def parse_saved(data: Any, where: str, workspace: Workspace | None = None) -> SavedSession:
    """Check a loaded session file part by part (``where`` names the file).

    Raises :class:`SessionError` naming the bad field when the file is not a session or its scene is
    malformed or implausible for ``workspace``; other bad parts are dropped and listed in ``problems``.
    """
    if not isinstance(data, dict) or data.get("kind") != "morphonavi-session":
        raise SessionError(f"{where} is not a MorphoNavi session file")
    if data.get("version") != SESSION_VERSION:
        raise SessionError(f"{where}: version {data.get('version')!r} is not supported (expected {SESSION_VERSION})")
    try:
        scene = scene_from_dict(data.get("scene") or {"version": 1})
        if workspace is not None:
            check_plausible(scene, workspace.min, workspace.max)
    except SceneError as exc:
        raise SessionError(f"{where}: scene.{exc}") from None
    for o in scene.objects:
        if o.frame != "world":
            raise SessionError(f"{where}: scene object {o.id!r} is in the {o.frame} frame, expected world")
    problems: list[str] = []
    notes: list[str] = []

    route: dict[str, Any] | None = None
    route_raw = data.get("route")
    if route_raw is not None:
        try:
            check_route(route_raw, workspace)
            route = route_raw
        except SceneError as exc:
            problems.append(f"{exc}: the route was not restored")
    ws_raw = data.get("workspace") or {}
    if route is not None and workspace is not None and not same_workspace(ws_raw if isinstance(ws_raw, dict) else {}, workspace):
        route = None
        notes.append("the saved route was planned on a different workspace grid and was dropped")

    mission: Mission | None = None
    if data.get("mission") is not None:
        try:
            _check_finite(data["mission"], "mission")
            mission = Mission.from_dict(data["mission"])
        except SceneError as exc:
            problems.append(f"{exc}: the mission was not restored (build it again)")
        except MissionError as exc:
            problems.append(f"mission.{exc}: the mission was not restored (build it again)")
        except (TypeError, ValueError) as exc:  # e.g. a 'created' time that is not a number
            problems.append(f"mission: {exc}: the mission was not restored (build it again)")
    if mission is not None and route is None:
        mission = None
        notes.append("the mission was dropped with its route")

    mode, alt = "ground", 1.5
    settings = data.get("settings") or {}
    top = None if workspace is None else workspace.max[2] - workspace.floor
    s_mode = settings.get("goal_mode", mode) if isinstance(settings, dict) else None
    s_alt = settings.get("altitude", alt) if isinstance(settings, dict) else None
    if s_mode not in ("ground", "altitude"):
        problems.append(f"settings.goal_mode: must be 'ground' or 'altitude', got {s_mode!r}: ground goals are used")
    else:
        mode = s_mode
    if not _is_number(s_alt) or not (s_alt > 0 and (top is None or s_alt < top)):
        problems.append(f"settings.altitude: must be a finite height above the floor [m]"
                        f"{'' if top is None else f' below {top:g}'}, got {s_alt!r}: {alt} m is used")
    else:
        alt = float(s_alt)

    capture: dict[str, Any] | None = None
    cap_raw = data.get("last_capture")
    if cap_raw is not None:
        bad = _non_finite(cap_raw, "last_capture")
        if not isinstance(cap_raw, dict):
            problems.append("last_capture: must be an object: the last capture was not restored")
        elif bad is not None:
            problems.append(f"{bad}: must be finite: the last capture was not restored")
        else:
            capture = cap_raw
    from console.session.known_space_state import known_from_saved

    known, plan_unknown, known_problems = known_from_saved(data, workspace)
    problems += known_problems
    return SavedSession(scene, mission, mode, alt, route, capture, tuple(problems), tuple(notes), known, plan_unknown)


def same_workspace(saved: dict[str, Any], ws: Workspace) -> bool:
    """Whether a saved ``workspace`` entry describes ``ws`` exactly (bounds and resolution)."""
    return (saved.get("min") == list(ws.min) and saved.get("max") == list(ws.max)
            and saved.get("resolution") == ws.resolution)
