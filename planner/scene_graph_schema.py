"""JSON Schema (draft 2020-12) of the scene graph, version :data:`planner.scene_graph.GRAPH_SCHEMA_VERSION`.

The graph is what :func:`planner.scene_graph.build_scene_graph` returns and what
``morphonavi describe SCENE.json --json`` prints. Positions are world frame [m], bearings and
axes in degrees (bearings in the robot frame: 0 ahead, positive to the left), yaw in radians.
A field that needs the robot pose or the grid is ``null`` without it. A change that adds,
removes or renames a field bumps the version (the schema allows no unknown fields).

- Version 2 (:data:`SCENE_GRAPH_SCHEMA`, what ``describe --schema`` prints): each object's
  ``placement`` (``on_floor``, ``on_object``, ``floating`` or ``below_floor``: bottom more than
  0.10 m under the floor, a mapping error) and ``floor_gap`` (bottom minus floor [m], negative
  below it); each ``reach``'s ``code``, why it is unreachable (``outside_workspace``,
  ``no_free_floor``, ``start_cut_off``, ``closed_in``, ``cramped``, ``walled_off``, ``planner``,
  ``start_unusable``; ``null`` when reachable).
- Version 1 (:data:`SCENE_GRAPH_SCHEMA_V1`): the same without those three fields; an object with
  ``on: null`` was unsupported, floating or below the floor (compare ``bottom`` with the floor).
  :func:`schema_for` picks the schema of a graph's version.
"""

from __future__ import annotations

import copy
from typing import Any

_NUM = {"type": "number"}
_VEC3 = {"type": "array", "items": _NUM, "minItems": 3, "maxItems": 3}
_ID = {"type": "string", "minLength": 1}


def _nullable(schema: dict[str, Any]) -> dict[str, Any]:
    return {"anyOf": [schema, {"type": "null"}]}


_OBJECT = {
    "type": "object",
    "required": ["id", "label", "score", "centre", "size", "yaw", "bottom", "top", "on", "group", "from_robot",
                 "visibility", "reach", "uncertain"],
    "additionalProperties": False,
    "properties": {
        "id": _ID,
        "label": {"type": "string"},
        "score": {"type": "number", "minimum": 0, "maximum": 1},
        "centre": _VEC3,
        "size": {**_VEC3, "description": "[w, h, l] full extents, h vertical"},
        "yaw": _NUM,
        "bottom": _NUM,
        "top": _NUM,
        "on": {"anyOf": [_ID, {"type": "null"}],
               "description": "'floor', the id of the object it stands on, or null (unsupported)"},
        "group": _nullable(_ID),
        "from_robot": _nullable({
            "type": "object", "additionalProperties": False,
            "required": ["distance", "nearest", "bearing_deg", "direction"],
            "properties": {
                "distance": {"type": "number", "minimum": 0, "description": "horizontal, to the centre [m]"},
                "nearest": {"type": "number", "minimum": 0, "description": "horizontal, to the footprint [m]"},
                "bearing_deg": {"type": "number", "minimum": -180, "maximum": 180},
                "direction": {"enum": ["ahead", "ahead-left", "left", "behind-left", "behind", "behind-right",
                                       "right", "ahead-right"]},
            },
        }),
        "visibility": {"enum": ["visible", "partly_hidden", "hidden", None]},
        "reach": _nullable({
            "type": "object", "additionalProperties": False,
            "required": ["mode", "goal", "gap", "cost", "planned", "landing", "reason"],
            "properties": {
                "mode": {"enum": ["walk", "fly", "none", "unknown"]},
                "goal": _nullable(_VEC3),
                "gap": _nullable({"type": "number", "minimum": 0}),
                "cost": _nullable({"type": "number", "minimum": 0}),
                "planned": {"enum": ["walk", "walk+fly", None]},
                "landing": _nullable(_VEC3),
                "reason": _nullable({"type": "string"}),
            },
        }),
        "uncertain": {"type": "array", "items": {"type": "string"}},
    },
}

_GROUP = {
    "type": "object", "additionalProperties": False,
    "required": ["id", "kind", "label", "members", "columns", "centre", "length", "width", "height", "axis_deg",
                 "crosses_workspace"],
    "properties": {
        "id": {"type": "string", "pattern": "^group-.+$",
               "description": "'group-' and the first member id in natural order (group-1 in graphs written before "
                              "group names were kept from capture to capture)"},
        "kind": {"enum": ["line", "stack", "cluster"]},
        "label": {"type": "string"},
        "members": {"type": "array", "items": _ID, "minItems": 2},
        "columns": {"type": "integer", "minimum": 1},
        "centre": _VEC3,
        "length": {"type": "number", "minimum": 0},
        "width": {"type": "number", "minimum": 0},
        "height": {"type": "number", "minimum": 0},
        "axis_deg": {"type": "number", "minimum": 0, "maximum": 180},
        "crosses_workspace": {"type": "boolean"},
    },
}

SCENE_GRAPH_SCHEMA_V1: dict[str, Any] = {
    "$schema": "https://json-schema.org/draft/2020-12/schema",
    "$id": "https://morphonavi.example/scene_graph/v1.json",
    "title": "MorphoNavi scene graph, version 1",
    "type": "object",
    "additionalProperties": False,
    "required": ["schema", "version", "frame", "units", "robot", "workspace", "objects", "relations", "groups",
                 "uncertainties"],
    "properties": {
        "schema": {"const": "morphonavi.scene_graph"},
        "version": {"const": 1},
        "frame": {"const": "world"},
        "units": {"type": "string"},
        "robot": _nullable({
            "type": "object", "additionalProperties": False, "required": ["position", "yaw_deg"],
            "properties": {"position": _VEC3, "yaw_deg": _NUM},
        }),
        "workspace": _nullable({
            "type": "object", "additionalProperties": False, "required": ["min", "max", "resolution", "margin"],
            "properties": {"min": _VEC3, "max": _VEC3, "resolution": {"type": "number", "exclusiveMinimum": 0},
                           "margin": {"type": "number", "minimum": 0}},
        }),
        "objects": {"type": "array", "items": _OBJECT},
        "relations": {"type": "array", "items": {
            "type": "object", "additionalProperties": False, "required": ["subject", "relation", "object"],
            "properties": {
                "subject": _ID,
                "relation": {"enum": ["on_top_of", "under", "next_to", "behind", "in_front_of", "left_of",
                                      "right_of"]},
                "object": _ID,
            },
        }},
        "groups": {"type": "array", "items": _GROUP},
        "uncertainties": {"type": "array", "items": {"type": "string"}},
    },
}
"""Version 1 (kept to read older graphs); subjects and objects of relations are object ids or group ids."""

REASON_CODES = ["outside_workspace", "no_free_floor", "start_cut_off", "closed_in", "cramped", "walled_off",
                "planner", "start_unusable"]
"""``reach.code`` values (the same as :data:`planner.object_goal.REASONS`)."""


def _version_2() -> dict[str, Any]:
    s = copy.deepcopy(SCENE_GRAPH_SCHEMA_V1)
    s["$id"] = "https://morphonavi.example/scene_graph/v2.json"
    s["title"] = "MorphoNavi scene graph, version 2"
    s["properties"]["version"] = {"const": 2}
    obj = s["properties"]["objects"]["items"]
    obj["required"] += ["placement", "floor_gap"]
    obj["properties"]["placement"] = {
        "enum": ["on_floor", "on_object", "floating", "below_floor"],
        "description": "below_floor: bottom more than 0.10 m under the floor (sunk into it or wholly under it, "
                       "a mapping error), whatever it rests on; floating: nothing under it, bottom above the floor"}
    obj["properties"]["floor_gap"] = {"type": "number",
                                      "description": "bottom minus the floor height [m], negative below the floor"}
    reach = obj["properties"]["reach"]["anyOf"][0]
    reach["required"] += ["code"]
    reach["properties"]["code"] = {"enum": [*REASON_CODES, None],
                                   "description": "why it is unreachable; null when it can be reached"}
    return s


SCENE_GRAPH_SCHEMA: dict[str, Any] = _version_2()
"""The current schema (version 2); subjects and objects of relations are object ids or group ids
(``group-`` and the group's first member id, e.g. ``group-cardboard_box-3``; ``group-N`` in older graphs)."""


def schema_for(graph: dict[str, Any]) -> dict[str, Any]:
    """The schema of ``graph``'s ``version`` (1 or 2; the current one for anything else, which then fails)."""
    return SCENE_GRAPH_SCHEMA_V1 if graph.get("version") == 1 else SCENE_GRAPH_SCHEMA


__all__ = ["REASON_CODES", "SCENE_GRAPH_SCHEMA", "SCENE_GRAPH_SCHEMA_V1", "schema_for"]
