"""JSON Schema (draft 2020-12) of the mission file, version :data:`planner.mission.MISSION_VERSION`.

The mission is what ``morphonavi plan --out`` and the console write (:meth:`planner.mission.Mission.to_dict`).
Published as ``docs/schemas/mission.schema.json`` (``python -m console.schemas``). World frame (z up) [m],
headings [rad] counter-clockwise about +z from +x.
"""

from __future__ import annotations

from typing import Any

MISSION_VERSION = 1  # the same as planner.mission.MISSION_VERSION (tests check they agree)

_VEC3 = {"type": "array", "items": {"type": "number"}, "minItems": 3, "maxItems": 3}

MISSION_SCHEMA: dict[str, Any] = {
    "$schema": "https://json-schema.org/draft/2020-12/schema",
    "$id": "https://morphonavi.example/schemas/mission.schema.json",
    "title": f"MorphoNavi mission, version {MISSION_VERSION}",
    "description": "Typed segments the robot runs in order (walk, take off, fly, land, turn); world frame, z up, "
                   "metres and radians. Each segment starts where the previous one ends.",
    "type": "object",
    "required": ["version", "segments"],
    "properties": {
        "version": {"const": MISSION_VERSION},
        "id": {"type": "string", "description": "mission id (8 hex digits when made by MorphoNavi)"},
        "created": {"type": "number", "description": "creation time [s since the Unix epoch]"},
        "frame": {"const": "world"},
        "bounds": {
            "type": "object", "description": "the workspace box, used as a geofence [m]",
            "required": ["min", "max"],
            "properties": {"min": {**_VEC3, "description": "[xmin, ymin, zmin] [m]"},
                           "max": {**_VEC3, "description": "[xmax, ymax, zmax] [m]"}},
        },
        "segments": {
            "type": "array", "minItems": 1,
            "items": {
                "type": "object",
                "required": ["kind", "waypoints"],
                "properties": {
                    "kind": {"enum": ["walk", "takeoff", "fly", "land", "turn"]},
                    "waypoints": {"type": "array", "minItems": 1, "items": {**_VEC3, "description": "[x, y, z] [m]"},
                                  "description": "the path of the segment, first point = its start"},
                    "yaw": {"type": "number", "description": "turn only: the heading to face [rad], "
                                                             "counter-clockwise about +z from +x"},
                },
                "if": {"properties": {"kind": {"const": "turn"}}},
                "then": {"required": ["yaw"]},
                "else": {"not": {"required": ["yaw"]}},
            },
        },
    },
}
"""The mission file's schema (the published ``docs/schemas/mission.schema.json``)."""

__all__ = ["MISSION_SCHEMA"]
