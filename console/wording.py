"""Plain words for the operator: counts with the right plural, robot modes, ids in natural order.

Pure text helpers shared by the views (no viser, no session).
"""

from __future__ import annotations

import re
from typing import Any

_DIGITS = re.compile(r"(\d+)")


def plural(n: int, word: str, many: str | None = None) -> str:
    """``n`` and ``word`` in the right number: ``plural(1, "segment")`` -> ``"1 segment"``.

    ``many`` is the plural form when it is not ``word + "s"`` (``plural(2, "box", "boxes")``).
    """
    count = int(n)
    return f"{count} {word if count == 1 else (many if many is not None else word + 's')}"


def mode_text(mode: Any) -> str:
    """A robot mode or run state in plain words: ``taking_off`` -> ``taking off``.

    Accepts an enum (its ``value``) or a string; ``None`` or an empty string gives ``unknown``.
    """
    raw = getattr(mode, "value", mode)
    text = "" if raw is None else str(raw).strip()
    return text.replace("_", " ").replace("-", " ").lower() if text else "unknown"


def kind_text(kind: Any) -> str:
    """A mission segment kind as the operator reads it: ``takeoff`` -> ``take-off`` (others as they are)."""
    text = mode_text(kind)
    return "take-off" if text == "takeoff" else text


def natural_key(text: str) -> tuple[Any, ...]:
    """Sort key that orders the numbers inside ids by value: ``box2`` < ``box10`` (case-blind)."""
    parts = _DIGITS.split(str(text))
    return tuple((0, int(p), p) if p.isdigit() else (1, p.lower(), p) for p in parts if p != "")


def natural_sorted(items: Any) -> list[str]:
    """``items`` as strings in natural order (1, 2, 10, 11; not 1, 10, 11, 2)."""
    return sorted((str(i) for i in items), key=natural_key)
