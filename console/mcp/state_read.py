"""What an agent may read of the console's session, as JSON-ready values (no side effects).

Every function takes the :class:`~console.session.session.Session` and returns plain dicts,
lists and strings. Frames and units: world frame (z up) [m], yaw and headings [rad] unless the
field says ``_deg``; times [s since the epoch]; battery a fraction in [0, 1].
"""

from __future__ import annotations

import io
import math
from typing import Any

from planner.route import Route
from planner.scene_graph import build_scene_graph, position_sigma
from planner.scene_summary import summarize

from console.session import operator_state as rules


def _r(v: float, nd: int = 3) -> float | None:
    return round(float(v), nd) if v is not None and math.isfinite(float(v)) else None


def robot_pose(session: Any) -> tuple[float, float, float, float]:
    """``(x, y, z, yaw)`` of the robot's live pose, else the route start facing +y (as the Scene summary panel)."""
    robot = session.robot
    if robot is not None and robot.position_status != "unknown":
        x, y, z = robot.pose.translation
        return (float(x), float(y), float(z), float(robot.pose.yaw))
    s = session.route_snapshot().start
    return (float(s[0]), float(s[1]), float(s[2]), math.pi / 2)


def scene_graph(session: Any) -> dict[str, Any]:
    """The scene graph of the session's map seen from the robot (schema: ``planner.scene_graph_schema``)."""
    scene, grid = session.scene, session.grid
    pose = robot_pose(session)
    return build_scene_graph(scene, pose, grid, route=Route(grid, pose[:3], session.weights))


def summary(session: Any) -> str:
    """The text summary of the map, as the console's Scene summary panel shows it."""
    return summarize(scene_graph(session))


def objects(session: Any) -> list[dict[str, Any]]:
    """Every mapped object: id, label, detector score, centre, size ``[w, h, l]``, yaw, the horizontal
    1-sigma of its position (``sigma_xy``, null without sightings), the mapper's sigma along the camera
    ray (``sigma_ray``), and the captures that saw it."""
    out = []
    for o in session.scene.objects:
        captures = [h.capture for h in o.history if h.capture]
        if o.source.capture and o.source.capture not in captures:
            captures.insert(0, o.source.capture)
        out.append({
            "id": o.id, "label": o.label, "score": _r(o.score), "centre": [_r(v) for v in o.position],
            "size": [_r(v) for v in o.size], "yaw": _r(o.yaw), "sigma_xy": _r(position_sigma(o)) if o.history else None,
            "sigma_ray": _r(o.sigma) if o.sigma is not None else None, "captures": captures,
            "method": o.source.method, "pinned": o.is_pinned, "flags": list(o.flags)})
    return out


def robot_state(session: Any, has_runner: bool = True) -> dict[str, Any]:
    """The robot as the console's robot panel shows it, and which vehicle commands apply now."""
    r = session.robot
    if r is None:
        return {"known": False, "why": "no state from the robot yet (the link may still be connecting)"}
    x, y, z = (float(v) for v in r.pose.translation)
    view = session.operator_state(has_runner)
    status = r.position_status
    return {
        "known": True, "position_status": status,
        "position": [_r(x), _r(y), _r(z)] if status != "unknown" else None,
        "yaw": _r(r.pose.yaw) if status != "unknown" else None,
        "pose_age": _r(r.pose_age) if math.isfinite(r.pose_age) else None,
        "mode": r.mode, "armed": r.armed, "landed": r.landed,
        "airborne": rules.airborne(r, session.workspace) if status != "unknown" else None,
        "battery": _r(r.battery) if r.battery is not None else None,
        "battery_level": rules.battery_level(r),
        "link_healthy": r.healthy, "health": r.detail or "ok",
        "ready": r.ready, "readiness": r.readiness, "warnings": list(r.warnings),
        "messages": [text for _, text in r.messages[-5:]],
        "commands": {name: {"enabled": c.enabled, "why_not": c.reason} for name, c in view.commands.items() if c.shown},
        "launch": [_r(v) for v in view.launch] if view.launch is not None else None,
        "stamp": r.stamp,
    }


def mission_state(session: Any, has_runner: bool = True) -> dict[str, Any]:
    """The route (start, registered goals, candidate), the built mission and how its run goes."""
    snap, mission, run = session.route_snapshot(), session.mission, session.run
    view = session.operator_state(has_runner)
    return {
        "route": {"start": [_r(v) for v in snap.start],
                  "registered_goals": [[_r(v) for v in g] for g in snap.goals],
                  "candidate_goal": [_r(v) for v in snap.candidate_goal] if snap.candidate_goal is not None else None},
        "mission": mission.to_dict() if mission is not None else None,
        "run": {"state": run.state, "segment": run.segment, "fraction": _r(run.fraction), "message": run.message,
                "command": view.running or None},
        "execute_blocker": view.execute_blocker, "route_note": view.route_note,
        "ends_in_air_m": _r(view.air_end) if view.air_end is not None else None,
    }


def mission_json(session: Any) -> dict[str, Any]:
    """The built mission as JSON (``planner.mission.Mission.to_dict``), or ``{"mission": null}``."""
    m = session.mission
    return {"mission": m.to_dict() if m is not None else None}


def last_photo(session: Any, max_side: int = 960) -> tuple[bytes, dict[str, Any]] | None:
    """The last capture as JPEG bytes (longest side at most ``max_side`` px) and its metadata:
    detections (label, score, box ``[x1, y1, x2, y2]`` px in the full photo, the object it became),
    camera and robot pose (world), time; ``None`` before the first capture."""
    from PIL import Image

    rec = session.capture
    if rec is None:
        return None
    img = Image.fromarray(rec.image)
    h, w = rec.image.shape[:2]
    scale = min(1.0, max_side / max(h, w))
    if scale < 1.0:
        img = img.resize((max(1, round(w * scale)), max(1, round(h * scale))))
    buf = io.BytesIO()
    img.convert("RGB").save(buf, format="JPEG", quality=85)
    t = rec.robot_pose.translation
    meta = {
        "capture": rec.id, "time": rec.timestamp, "width": int(w), "height": int(h), "scale": _r(scale, 4),
        "backend": rec.backend,
        "robot_position": [_r(v) for v in t], "robot_yaw": _r(rec.robot_pose.yaw),
        "camera_position": [_r(v) for v in rec.camera_pose.translation],
        "detections": [{"label": d.label, "score": _r(d.score), "bbox": [_r(v, 1) for v in d.bbox],
                        "object_id": d.object_id} for d in rec.detections],
    }
    return buf.getvalue(), meta


__all__ = ["last_photo", "mission_json", "mission_state", "objects", "robot_pose", "robot_state", "scene_graph",
           "summary"]
