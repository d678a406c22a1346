"""JSON Schema (draft 2020-12) of the console's session file ``session.json``, version
:data:`console.session.session_store.SESSION_VERSION`.

Written by the console's autosave and Save (:func:`console.session.session_store.session_dict`); it embeds a scene
(:data:`pipeline.scene_schema.SCENE_SCHEMA`) and a mission (:data:`planner.mission_schema.MISSION_SCHEMA`).
Published as ``docs/schemas/session.schema.json`` (``python -m console.schemas``). World frame (z up) [m, rad].
"""

from __future__ import annotations

import copy
from typing import Any

from pipeline.scene_schema import SCENE_SCHEMA
from planner.mission_schema import MISSION_SCHEMA

SESSION_VERSION = 1  # as console.session.session_store.SESSION_VERSION (tests check they agree)

_VEC3 = {"type": "array", "items": {"type": "number"}, "minItems": 3, "maxItems": 3}
_POSE = {"type": "object", "required": ["translation", "quaternion_xyzw"],
         "properties": {"translation": {**_VEC3, "description": "[x, y, z] [m]"},
                        "quaternion_xyzw": {"type": "array", "items": {"type": "number"}, "minItems": 4,
                                            "maxItems": 4, "description": "rotation, order [x, y, z, w]"}}}


def _embedded(schema: dict[str, Any]) -> dict[str, Any]:
    s = copy.deepcopy(schema)
    s.pop("$schema", None)
    s.pop("$id", None)
    return s


SESSION_SCHEMA: dict[str, Any] = {
    "$schema": "https://json-schema.org/draft/2020-12/schema",
    "$id": "https://morphonavi.example/schemas/session.schema.json",
    "title": f"MorphoNavi console session, version {SESSION_VERSION}",
    "description": "The console's state: workspace, scene, route, mission, settings and the last capture's files.",
    "type": "object",
    "required": ["version", "kind", "workspace", "scene"],
    "$defs": {"scene": _embedded(SCENE_SCHEMA), "mission": _embedded(MISSION_SCHEMA)},
    "properties": {
        "version": {"const": SESSION_VERSION},
        "kind": {"const": "morphonavi-session"},
        "saved": {"type": "number", "description": "save time [s since the Unix epoch]"},
        "frame": {"const": "world"},
        "workspace": {"type": "object", "required": ["min", "max", "resolution"],
                      "properties": {"min": {**_VEC3, "description": "[xmin, ymin, zmin] [m]"},
                                     "max": {**_VEC3, "description": "[xmax, ymax, zmax] [m]"},
                                     "resolution": {"type": "number", "exclusiveMinimum": 0,
                                                    "description": "grid cell size [m]"}}},
        "margin": {"type": "number", "minimum": 0, "description": "robot radius: the dangerous margin [m]"},
        "scene": {"$ref": "#/$defs/scene"},
        "route": {"type": "object", "description": "the planned route",
                  "properties": {"start": {**_VEC3, "description": "start [x, y, z] [m]"},
                                 "registered": {"type": "array", "description": "registered path segments as grid "
                                                "cells [[i, j, k], ...]",
                                                "items": {"type": "array", "items": {
                                                    "type": "array", "items": {"type": "integer"},
                                                    "minItems": 3, "maxItems": 3}}},
                                 "candidate_goal": {"anyOf": [_VEC3, {"type": "null"}]}}},
        "mission": {"anyOf": [{"$ref": "#/$defs/mission"}, {"type": "null"}]},
        "settings": {"type": "object", "properties": {
            "goal_mode": {"enum": ["ground", "altitude"], "description": "goals on the floor or at the altitude"},
            "altitude": {"type": "number", "description": "flight altitude above the floor [m]"}}},
        "last_capture": {"anyOf": [{"type": "null"}, {
            "type": "object", "description": "the last capture's files in the session folder",
            "properties": {"id": {"type": "string"}, "photo": {"type": "string"},
                           "depth_mm": {"type": ["string", "null"], "description": "16-bit PNG depth [mm]"},
                           "intrinsics": {"type": "object"}, "camera_pose": _POSE, "robot_pose": _POSE}}]},
    },
}
"""The session file's schema (the published ``docs/schemas/session.schema.json``)."""

__all__ = ["SESSION_SCHEMA"]
