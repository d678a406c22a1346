"""JSON Schemas of the recording's JSON channels (MCAP schema encoding ``jsonschema``).

Each JSON topic of :data:`console.recording.recording_schemas.JSON_TOPICS` is registered with the schema below,
so Foxglove (and any MCAP reader) sees typed fields it can plot (``/robot/state.battery``,
``/mission/progress.fraction`` ...). The scene, mission and session parts are the published file schemas
(``docs/schemas/``). World frame (z up) [m], radians, seconds; quaternions in the order ``[x, y, z, w]``.
"""

from __future__ import annotations

import copy
import json
from typing import Any

from pipeline.scene_schema import SCENE_SCHEMA
from planner.mission_schema import MISSION_SCHEMA

from console.recording import recording_schemas as rs
from console.session.search_report import STEP_KINDS
from console.session.search_result_schema import recorded_result_schema

_NUM = {"type": "number"}
_VEC3 = {"type": "array", "items": _NUM, "minItems": 3, "maxItems": 3}
_QUAT = {"type": "array", "items": _NUM, "minItems": 4, "maxItems": 4, "description": "rotation, order [x, y, z, w]"}
_POSE = {"type": "object", "properties": {"translation": {**_VEC3, "description": "[x, y, z] [m]"},
                                          "quaternion_xyzw": _QUAT}}
_WORKSPACE = {"type": "object", "properties": {"min": _VEC3, "max": _VEC3, "resolution": _NUM}}
_NULL_VEC3 = {"type": ["array", "null"], "items": _NUM, "minItems": 3, "maxItems": 3}
_VIEWPOINT = {"type": "object", "description": "a search viewpoint (planner.search_viewpoints.Viewpoint)", "properties": {
    "goal": {**_VEC3, "description": "where the planner goes, world frame [m]"},
    "eye": {**_VEC3, "description": "camera position, world frame [m]"},
    "yaw": {**_NUM, "description": "heading to face [rad], counter-clockwise from +x"},
    "mode": {"enum": ["walk", "fly"]}, "gain": {**_NUM, "description": "unknown volume in view [m^3], weighted"},
    "cost": {**_NUM, "description": "the planner's path cost"}, "score": _NUM, "why": {"type": "string"}},
    "required": ["goal", "eye", "yaw", "mode", "gain", "cost"]}


def _bare(schema: dict[str, Any]) -> dict[str, Any]:
    s = copy.deepcopy(schema)
    for key in ("$schema", "$id"):
        s.pop(key, None)
    return s


def _topic(title: str, description: str, properties: dict[str, Any], required: list[str] | None = None) -> dict[str, Any]:
    out = {"$schema": "https://json-schema.org/draft/2020-12/schema", "title": title, "description": description,
           "type": "object", "properties": properties}
    if required:
        out["required"] = required
    return out


CHANNEL_SCHEMAS: dict[str, dict[str, Any]] = {
    rs.ROBOT_STATE: _topic("morphonavi.RobotState", "the robot's state as the console saw it", {
        "translation": {**_VEC3, "description": "robot position, world frame [m]"},
        "quaternion_xyzw": {**_QUAT, "description": "world <- robot rotation, order [x, y, z, w]"},
        "mode": {"type": "string", "description": "flight / walk mode (ArduPilot mode name on a MAVLink link)"},
        "armed": {"type": "boolean"}, "battery": {"type": ["number", "null"], "description": "battery [%]"},
        "healthy": {"type": "boolean"}, "detail": {"type": "string"},
        "stamp": {"type": "number", "description": "time of the state [s since the Unix epoch]"},
        "messages": {"type": "array", "items": {"type": "array"}, "description": "autopilot status texts"},
        "landed": {"type": ["boolean", "null"]}, "position_valid": {"type": "boolean"},
        "pose_age": {"type": ["number", "null"], "description": "age of the position [s], null: never known"},
        "ready": {"type": "boolean"}, "readiness": {"type": "string"},
        "warnings": {"type": "array", "items": {"type": "string"}},
        "link_quality": {"type": "string"}, "vehicle_control": {"type": "string"},
    }),
    rs.CAPTURE_META: _topic("morphonavi.Capture", "a capture's metadata (the photo is on /camera/image)", {
        "id": {"type": "string"}, "intrinsics": {"type": "object", "additionalProperties": _NUM},
        "camera_pose": {**_POSE, "description": "world <- camera (OpenCV: x right, y down, z forward)"},
        "robot_pose": {**_POSE, "description": "world <- robot"},
        "detections": {"type": "array", "items": {"type": "object", "properties": {
            "label": {"type": "string"}, "score": _NUM,
            "bbox": {"type": "array", "items": _NUM, "description": "[x1, y1, x2, y2] [px]"},
            "object_id": {"type": ["string", "null"]}}}},
        "backend": {"type": "string"}, "timings": {"type": "object", "additionalProperties": _NUM},
        "timestamp": {"type": "number", "description": "[s since the Unix epoch]"},
    }),
    rs.PROGRESS: _topic("morphonavi.MissionProgress", "the running mission", {
        "state": {"type": "string", "description": "idle, running, paused, done, failed ..."},
        "segment": {"type": ["integer", "null"], "description": "index of the running segment (null: none)"},
        "fraction": {"type": "number", "minimum": 0, "maximum": 1, "description": "share of the mission done"},
        "message": {"type": "string"},
    }),
    rs.SCENE_JSON: {**_bare(SCENE_SCHEMA), "$schema": "https://json-schema.org/draft/2020-12/schema",
                    "title": "morphonavi.Scene"},
    rs.ROUTE_JSON: _topic("morphonavi.Route", "the route being planned, world frame [m]", {
        "start": _VEC3,
        "registered": {"type": "array", "items": {"type": "array", "items": _VEC3}},
        "candidate": {"type": ["array", "null"], "items": _VEC3},
        "candidate_goal": {"type": ["array", "null"], "items": _NUM},
        "goals": {"type": "array", "items": _VEC3},
    }),
    rs.MISSION_JSON: _topic("morphonavi.Mission", "the mission built from the route, or null",
                            {"mission": {"anyOf": [_bare(MISSION_SCHEMA), {"type": "null"}]}}),
    rs.SESSION_INFO: _topic("morphonavi.Session", "what replay needs to rebuild the grid", {
        "workspace": _WORKSPACE, "margin": {"type": "number", "description": "robot radius [m]"},
        "start": _VEC3,
    }),
    rs.AGENT_EVENTS: _topic("morphonavi.AgentEvent", "a language-model agent's tool call, proposal or the "
                                                     "operator's decision", {
        "text": {"type": "string"}, "level": {"type": "string"},
    }),
    rs.KNOWN_SPACE: _topic("morphonavi.KnownSpace", "the known space grid (compact JSON form) and its cell counts", {
        "known_space": {"type": ["object", "null"]}, "free": {"type": "integer"}, "occupied": {"type": "integer"},
        "unknown": {"type": "integer"}, "unlabelled": {"type": "integer"}, "plan_unknown": {"type": "string"},
    }),
    rs.SEARCH_STEP: _topic("morphonavi.SearchStep", "one step of a search (console.session.search_report)", {
        "search_id": {"type": "string"}, "index": {"type": "integer", "minimum": 1},
        "kind": {"enum": list(STEP_KINDS)}, "text": {"type": "string"},
        "stamp": {"type": "number", "description": "[s since the Unix epoch]"},
        "robot": {**_NULL_VEC3, "description": "robot position, world frame [m]"},
        "captures": {"type": ["integer", "null"], "description": "captures so far"},
        "elapsed": {"type": ["number", "null"], "description": "[s] since the search started"},
        "battery": {"type": ["number", "null"], "description": "charge [0..1]"},
        "viewpoint": {"anyOf": [_VIEWPOINT, {"type": "null"}], "description": "the viewpoint chosen"},
        "candidates": {"type": ["array", "null"], "items": _VIEWPOINT, "description": "the best few, chosen first"},
        "choose_seconds": {"type": ["number", "null"], "description": "time of the choice [s]"},
        "capture_id": {"type": ["string", "null"]}, "target_id": {"type": ["string", "null"]},
        "mission": {"anyOf": [{"type": "object", "properties": {
            "id": {"type": "string"}, "kinds": {"type": "array", "items": {"type": "string"}},
            "path": {"type": "array", "items": _VEC3, "description": "waypoints, world frame [m]"}},
            "required": ["id", "kinds", "path"]}, {"type": "null"}], "description": "the move's mission"},
    }, required=["search_id", "index", "kind", "text"]),
    rs.SEARCH_RESULT: {**_topic("morphonavi.SearchResult", "how a search ended (result.json, "
                                "docs/schemas/search_result.schema.json, with the search's id)", {}),
                       **recorded_result_schema()},
}
"""Schema of each JSON topic (a topic without one here gets a bare object schema)."""


def schema_bytes(topic: str) -> bytes:
    """The MCAP schema data of a JSON topic (compact JSON)."""
    schema = CHANNEL_SCHEMAS.get(topic, {"type": "object"})
    return json.dumps(schema, separators=(",", ":")).encode("utf-8")


__all__ = ["CHANNEL_SCHEMAS", "schema_bytes"]
