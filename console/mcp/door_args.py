"""The agent's request arguments checked at the door: texts and numbers, refused with the field's name.

Shared by :mod:`console.mcp.door` (reads and safe commands) and :mod:`console.mcp.door_proposals`
(proposals). Every refusal is an :class:`AgentError` whose message starts with the field's name
(``why: at most 2000 characters, got 2301``).
"""

from __future__ import annotations

import math
from typing import Any, Mapping

WHY_MAX = 2000
"""Longest reason an agent may give [characters]."""
NAME_MAX = 200
"""Longest object name [characters]."""


class AgentError(ValueError):
    """A request refused; the message says why (naming the bad field)."""


def text_arg(args: Mapping[str, Any], name: str, limit: int, required: bool = False) -> str:
    """``args[name]`` as stripped text (missing or ``None``: ``""``), at most ``limit`` characters.

    Raises:
        AgentError: Not text, longer than ``limit``, or empty when ``required``.
    """
    v = args.get(name, "")
    if v is None:
        v = ""
    if not isinstance(v, str):
        raise AgentError(f"{name}: must be text, got {type(v).__name__}")
    v = v.strip()
    if required and not v:
        raise AgentError(f"{name}: must not be empty: say why, for the operator")
    if len(v) > limit:
        raise AgentError(f"{name}: at most {limit} characters, got {len(v)}")
    return v


def number_arg(args: Mapping[str, Any], name: str, default: float | None = None) -> float:
    """``args[name]`` (missing: ``default``) as a finite float.

    Raises:
        AgentError: Not a number (a bool is not one), or not finite.
    """
    v = args.get(name, default)
    if isinstance(v, bool) or not isinstance(v, (int, float)):
        raise AgentError(f"{name}: must be a number, got {v!r}")
    if not math.isfinite(float(v)):
        raise AgentError(f"{name}: must be finite, got {v!r}")
    return float(v)


__all__ = ["AgentError", "NAME_MAX", "WHY_MAX", "number_arg", "text_arg"]
