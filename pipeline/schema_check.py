"""Validate a parsed JSON document against one of the published JSON Schemas, naming the bad field.

``schema_errors(schema, data)`` gives messages in the form the readers use (``objects[3].size[1]: must be > 0,
got -1``), first the shallowest; :func:`check` raises the first one as ``ValueError``. Built on ``jsonschema``
(Draft 2020-12).
"""

from __future__ import annotations

from typing import Any, Iterable

from jsonschema import Draft202012Validator
from jsonschema.exceptions import ValidationError


def field_path(parts: Iterable[Any]) -> str:
    """``['objects', 3, 'size', 1]`` -> ``objects[3].size[1]``."""
    out = ""
    for p in parts:
        out += f"[{p}]" if isinstance(p, int) else (f".{p}" if out else str(p))
    return out


def _message(err: ValidationError) -> str:
    v, inst = err.validator_value, err.instance
    kind = err.validator
    if kind == "type":
        want = " or ".join(v) if isinstance(v, list) else v
        return f"must be {'an' if str(want)[0] in 'aeiou' else 'a'} {want}, got {inst!r}"
    if kind == "exclusiveMinimum":
        return f"must be > {v:g}, got {inst!r}"
    if kind == "minimum":
        return f"must be >= {v:g}, got {inst!r}"
    if kind == "exclusiveMaximum":
        return f"must be < {v:g}, got {inst!r}"
    if kind == "maximum":
        return f"must be <= {v:g}, got {inst!r}"
    if kind in ("minItems", "maxItems"):
        return f"has {len(inst)} items, {'at least' if kind == 'minItems' else 'at most'} {v} allowed"
    if kind == "enum":
        return f"must be one of {', '.join(map(repr, v))}, got {inst!r}"
    if kind == "const":
        return f"must be {v!r}, got {inst!r}"
    if kind == "additionalProperties":
        extra = sorted(set(inst) - set(err.schema.get("properties", {})))
        return f"unknown key {', '.join(map(repr, extra))}"
    if kind == "minLength":
        return "must not be empty"
    return err.message


def schema_errors(schema: dict[str, Any], data: Any, limit: int = 20) -> list[str]:
    """Up to ``limit`` messages ``path: what is wrong``, the shallowest first ([] when ``data`` is valid)."""
    validator = Draft202012Validator(schema)
    out = []
    for err in sorted(validator.iter_errors(data), key=lambda e: (len(e.absolute_path), list(map(str, e.absolute_path)))):
        path = list(err.absolute_path)
        if err.validator == "required":
            missing = [k for k in err.validator_value if not isinstance(err.instance, dict) or k not in err.instance]
            out.append(f"{field_path([*path, missing[0]])}: is required" if missing else err.message)
        else:
            where = field_path(path)
            out.append(f"{where}: {_message(err)}" if where else _message(err))
        if len(out) >= limit:
            break
    return out


def check(schema: dict[str, Any], data: Any) -> None:
    """Raise ``ValueError`` with the first :func:`schema_errors` message when ``data`` does not validate."""
    errors = schema_errors(schema, data, limit=1)
    if errors:
        raise ValueError(errors[0])


__all__ = ["check", "field_path", "schema_errors"]
