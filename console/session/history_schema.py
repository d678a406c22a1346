"""JSON Schema (draft 2020-12) of the console's undo and redo history ``history.json``, version
:data:`console.session.history_file.HISTORY_VERSION`.

Written beside ``session.json`` after every map edit (:class:`console.session.history_file.HistoryWriter`) and
read back when the console starts. Its states are session states (the session file's own schema,
:data:`console.session.session_schema.SESSION_SCHEMA`, without the settings); the known spaces they share are
written once under ``known_spaces`` and named by ``known_ref``. Published as
``docs/schemas/history.schema.json`` (``python -m console.schemas``). World frame (z up) [m, rad].

On read the file is checked against this schema first (:func:`history_errors`: messages name the field,
``undo[2].label: must not be empty``), then every state through the session file's own checks.
"""

from __future__ import annotations

import copy
from typing import Any

from console.session.session_schema import SESSION_SCHEMA

HISTORY_KIND = "morphonavi-history"
HISTORY_VERSION = 1

_SESSION = copy.deepcopy(SESSION_SCHEMA)
_DEFS = _SESSION.pop("$defs")  # the scene and mission schemas: hoisted, so the session's "#/$defs/..." still resolve
for _key in ("$schema", "$id", "title"):
    _SESSION.pop(_key, None)
_SESSION["description"] = "A session state as session.json holds it (the settings are not part of the history)."

_ENTRY: dict[str, Any] = {
    "type": "object",
    "description": "One step of the history: what it did and the map as it was.",
    "required": ["label", "state"],
    "properties": {
        "label": {"type": "string", "minLength": 1, "description": "what the step did (\"move crate-b\")"},
        "key": {"type": "string", "description": "groups repeated edits of one thing into one step"},
        "known_ref": {"type": ["string", "null"], "description": "the key of its known space in known_spaces"},
        "state": {"$ref": "#/$defs/session_state"},
    },
}

HISTORY_SCHEMA: dict[str, Any] = {
    "$schema": "https://json-schema.org/draft/2020-12/schema",
    "$id": "https://morphonavi.example/schemas/history.schema.json",
    "title": f"MorphoNavi console undo and redo history, version {HISTORY_VERSION}",
    "description": "The console's undo and redo stacks, oldest first, saved beside session.json.",
    "type": "object",
    "required": ["kind", "version", "undo", "redo"],
    "$defs": {**_DEFS, "session_state": _SESSION, "step": _ENTRY},
    "properties": {
        "kind": {"const": HISTORY_KIND},
        "version": {"const": HISTORY_VERSION},
        "known_spaces": {"type": "object", "description": "known spaces (seen / unseen cells) by key, each "
                         "written once and shared by the states naming it",
                         "additionalProperties": {"type": "object"}},
        "undo": {"type": "array", "items": {"$ref": "#/$defs/step"}, "description": "undo steps, oldest first"},
        "redo": {"type": "array", "items": {"$ref": "#/$defs/step"}, "description": "redo steps, oldest first"},
    },
}
"""The history file's schema (the published ``docs/schemas/history.schema.json``)."""


_OUTLINE: dict[str, Any] = {**HISTORY_SCHEMA, "properties": {
    **HISTORY_SCHEMA["properties"], "undo": {"type": "array"}, "redo": {"type": "array"}}}
_SHALLOW_STATE = copy.deepcopy(_SESSION)
_SHALLOW_STATE["properties"].update(scene={"type": "object"}, mission={"type": ["object", "null"]})
_STEP: dict[str, Any] = {"$defs": {**HISTORY_SCHEMA["$defs"], "session_state": _SHALLOW_STATE}, "$ref": "#/$defs/step"}
"""One step as checked on read: its scene and mission only as objects here (a jsonschema pass over every
object of 20 states of a large map takes seconds); the session file's reader checks them next, field by field."""


def history_errors(data: Any, limit: int = 20) -> list[str]:
    """Up to ``limit`` messages ``field: what is wrong`` for a parsed ``history.json`` ([] when it is valid),
    the shallowest first."""
    from pipeline.schema_check import schema_errors

    return schema_errors(HISTORY_SCHEMA, data, limit=limit)


def outline_errors(data: Any, limit: int = 5) -> list[str]:
    """:func:`history_errors` of the file's outline only (kind, version, known_spaces, undo and redo being
    lists), not of the steps in them."""
    from pipeline.schema_check import schema_errors

    return schema_errors(_OUTLINE, data, limit=limit)


def step_errors(step: Any, where: str, limit: int = 3) -> list[str]:
    """:func:`history_errors` of one step of a stack, each message starting with ``where`` (``undo[3]``)."""
    from pipeline.schema_check import schema_errors

    return [f"{where}.{m}" if not m.startswith("must") else f"{where}: {m}" for m in schema_errors(_STEP, step, limit)]


__all__ = ["HISTORY_KIND", "HISTORY_SCHEMA", "HISTORY_VERSION", "history_errors", "outline_errors", "step_errors"]
