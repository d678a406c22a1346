"""What a search records and reports: its steps as JSON-ready events, what was left unseen, the battery.

Every step of a search is announced to the session's listeners as a ``search`` event
(:data:`console.session.topics.SEARCH`): the recorder writes it to the MCAP channel ``/search/step``
and the end to ``/search/result`` (schemas in :mod:`console.recording.channel_schemas`), and replay
draws the viewpoints and the chosen paths from them. World frame (z up) [m], headings [rad],
times [s], battery as a fraction [0..1].
"""

from __future__ import annotations

import math
import time
from dataclasses import asdict
from typing import Any

import numpy as np

from planner.search_viewpoints import UNKNOWN, Viewpoint, path_costs

from console.session.operator_state import BATTERY_CRITICAL, BATTERY_LOW
from console.session.search_types import SearchResult
from console.wording import plural

STEP_KINDS = ("start", "capture", "viewpoint", "move", "turn", "seen", "paused", "resumed", "approve", "end")
"""What a step is: the search started, a capture was mapped, the next viewpoint was chosen, a move
(a mission) started or ended, a turn, the target was seen, the search paused / resumed, a move
waits for Approve, the search ended."""


def _r(v: Any, nd: int = 3) -> Any:
    if v is None:
        return None
    if isinstance(v, (list, tuple, np.ndarray)):
        return [_r(x, nd) for x in v]
    return round(float(v), nd)


def viewpoint_json(vp: Viewpoint) -> dict[str, Any]:
    """A viewpoint as JSON: goal and eye (world [m]), yaw [rad], mode, gain [m³], cost, score, why."""
    return {"goal": _r(vp.goal), "eye": _r(vp.eye), "yaw": _r(vp.yaw, 4), "mode": vp.mode, "gain": _r(vp.gain),
            "cost": _r(vp.cost), "score": _r(vp.score, 4), "why": vp.why}


def mission_json(mission: Any) -> dict[str, Any]:
    """A move's mission as JSON: its id, segment kinds and the path through its waypoints (world [m])."""
    path: list[list[float]] = []
    for seg in mission.segments:
        for p in seg.waypoints:
            q = _r(p)
            if not path or q != path[-1]:
                path.append(q)
    return {"id": str(mission.id), "kinds": list(mission.kinds()), "path": path}


def step_event(search_id: str, index: int, kind: str, text: str, **extra: Any) -> dict[str, Any]:
    """One ``/search/step`` record (``extra``: robot, captures, elapsed, battery, viewpoint, candidates,
    choose_seconds, capture_id, mission, target_id; absent ones are ``null``)."""
    if kind not in STEP_KINDS:
        raise ValueError(f"kind: must be one of {', '.join(STEP_KINDS)}, got {kind!r}")
    out: dict[str, Any] = {"search_id": search_id, "index": int(index), "kind": kind, "text": text,
                           "stamp": time.time()}
    for key in ("robot", "captures", "elapsed", "battery", "viewpoint", "candidates", "choose_seconds", "capture_id",
                "mission", "target_id"):
        out[key] = extra.get(key)
    return out


def result_event(search_id: str, result: SearchResult) -> dict[str, Any]:
    """The ``/search/result`` record: the result as in ``result.json``, with the search's id."""
    return {"search_id": search_id, **asdict(result)}


def result_headline(result: SearchResult) -> str:
    """What a search ended with, in words: ``found robot_dog-1 at 0.98 m`` (its distance [m] from the robot
    in the floor plane) when found, else the end's reason (``not found: budget of 20 captures used``)."""
    if result.found and result.distance_to_target is not None:
        return f"found {result.target_id} at {result.distance_to_target:.2f} m"
    if result.found and result.target_id:
        return f"found {result.target_id}"
    return result.reason


def result_line(result: SearchResult) -> str:
    """The end notice's line: :func:`result_headline` with the captures and the path travelled [m]:
    ``found robot_dog-1 at 0.98 m (12 captures, 39.1 m travelled)``; the console's panel says the same."""
    return (f"{result_headline(result)} ({plural(result.captures, 'capture')}, "
            f"{result.path_length:.1f} m travelled)")


def battery_low(battery: float | None, reserve: float) -> str | None:
    """The ``battery: ...`` report when the charge [0..1] is below the search's ``reserve``, else ``None``."""
    if battery is None or not math.isfinite(battery) or battery >= reserve:
        return None
    return (f"battery: {100 * battery:.0f} % left, below the search's reserve of {100 * reserve:.0f} % (the console "
            f"refuses new moves below {100 * BATTERY_LOW:.0f} % and lands the robot below {100 * BATTERY_CRITICAL:.0f} %): "
            "land or Return")


def left_unseen(state: np.ndarray | None, grid: Any, cost: np.ndarray | None, start_cell: Any, why: str) -> str:
    """What was left unseen and why: the floor area [m²] no capture has seen, how much of it the robot
    could still reach (over seen or unknown space: ``cost`` is the planner's per-cell cost with unknown
    space allowed) and why the search did not look there (``why``: the budget that ended it)."""
    if state is None:
        return f"nothing was seen ({why})"
    ws = grid.workspace
    floor = np.asarray(state)[:, :, 0] == UNKNOWN
    cell_m2 = ws.resolution ** 2
    total = floor.size * cell_m2
    area = float(floor.sum()) * cell_m2
    if area <= 0:
        return "no floor was left unseen"
    text = f"{area:.1f} m² of floor unseen ({100 * area / total:.0f} % of the workspace floor)"
    if cost is not None and start_cell is not None:
        dist = path_costs(grid, cost, start_cell)
        reach = np.isfinite(dist).any(axis=2) & floor
        near = float(reach.sum()) * cell_m2
        text += (f": {near:.1f} m² of it reachable, not looked at ({why}); {area - near:.1f} m² not reachable "
                 "(cut off by obstacles or too near them for the robot)")
    else:
        text += f" ({why})"
    return text


__all__ = ["STEP_KINDS", "battery_low", "left_unseen", "mission_json", "result_event", "step_event", "viewpoint_json"]
