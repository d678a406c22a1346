"""JSON Schema (draft 2020-12) of a search's result: ``result.json`` (``morphonavi search --out``) and, with the
search's id, the recording's ``/search/result`` record.

It describes :class:`console.session.search_types.SearchResult` field by field (a test checks that every field
of the dataclass is here and nothing else), so the file and the recording cannot drift apart. Published as
``docs/schemas/search_result.schema.json`` (``python -m console.schemas``). World frame (z up) [m], seconds.
"""

from __future__ import annotations

from typing import Any

_NUM = {"type": "number"}
_NULL_VEC3 = {"type": ["array", "null"], "items": _NUM, "minItems": 3, "maxItems": 3}

RESULT_PROPERTIES: dict[str, Any] = {
    "found": {"type": "boolean", "description": "the target was mapped with confidence"},
    "target": {"type": "string", "description": "what was searched for, as the operator typed it"},
    "target_id": {"type": ["string", "null"], "description": "the found object's id in the scene"},
    "target_position": {**_NULL_VEC3, "description": "the found object's centre, world frame [m]"},
    "seen_by": {"type": "array", "items": {"type": "string"}, "description": "ids of the captures that saw it"},
    "final_position": {**_NULL_VEC3, "description": "the robot's position at the end, world frame [m]"},
    "distance_to_target": {"type": ["number", "null"], "minimum": 0,
                           "description": "robot to target in plan at the end [m]; null: not located"},
    "path_length": {"type": "number", "minimum": 0, "description": "distance travelled [m]"},
    "captures": {"type": "integer", "minimum": 0, "description": "captures taken"},
    "time": {"type": "number", "minimum": 0, "description": "duration of the search [s]"},
    "reason": {"type": "string", "description": "why it ended (found, a budget, stopped by the operator ...)"},
    "seen_share": {"type": ["number", "null"], "minimum": 0, "maximum": 1,
                   "description": "share of the workspace seen at the end [0..1]"},
    "left_unseen": {"type": "string", "description": "what was not seen and why; empty when found"},
    "battery": {"type": ["number", "null"], "minimum": 0, "maximum": 1, "description": "charge at the end [0..1]"},
    "choose_seconds": {"type": "array", "items": {"type": "number", "minimum": 0},
                       "description": "time of each next-viewpoint choice [s]"},
    "contacts": {"type": "integer", "minimum": 0,
                 "description": "moves that ended in a contact with something the map did not show (each followed "
                                "by a capture and a new plan)"},
    "steps": {"type": "array", "items": {"type": "string"}, "description": "every step, as printed"},
}
"""The result's fields (:class:`~console.session.search_types.SearchResult`)."""

RESULT_REQUIRED = list(RESULT_PROPERTIES)
"""Every field is written (``null`` where it does not apply)."""

SEARCH_RESULT_SCHEMA: dict[str, Any] = {
    "$schema": "https://json-schema.org/draft/2020-12/schema",
    "$id": "https://morphonavi.example/schemas/search_result.schema.json",
    "title": "MorphoNavi search result",
    "description": "How a search for an object ended (morphonavi search --out, the console's Find): found or not, "
                   "where, how sure, what it cost and why it ended. World frame (z up), metres, seconds.",
    "type": "object",
    "required": RESULT_REQUIRED,
    "properties": RESULT_PROPERTIES,
    "additionalProperties": False,
}
"""``result.json``'s schema."""


def recorded_result_schema() -> dict[str, Any]:
    """The ``/search/result`` record's schema parts: the result's properties with ``search_id``, all required,
    no others (``properties``, ``required``, ``additionalProperties``)."""
    return {"properties": {"search_id": {"type": "string", "description": "the search's id (its steps carry it)"},
                           **RESULT_PROPERTIES},
            "required": ["search_id", *RESULT_REQUIRED], "additionalProperties": False}


__all__ = ["RESULT_PROPERTIES", "RESULT_REQUIRED", "SEARCH_RESULT_SCHEMA", "recorded_result_schema"]
