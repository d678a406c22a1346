"""One parser for every comma-separated list of numbers a user types (command-line options, pose
strings): finite numbers only, a stated count, and errors that name the option.

``parse_numbers("-1,2,0,90", "--pose", (2, 3, 4), "x,y[,z[,yaw_deg]]")`` -> ``[-1.0, 2.0, 0.0, 90.0]``.
Negative values are fine here; :func:`console.cli.main` makes sure argparse hands them over (an
option value starting with ``-`` is otherwise taken for an option).
"""

from __future__ import annotations

import math
from typing import Sequence


class ValueListError(ValueError):
    """A list of numbers that cannot be used; the message names the option and the expected form."""


def parse_numbers(text: str, where: str, counts: Sequence[int], form: str) -> list[float]:
    """The finite numbers of ``text`` (comma-separated, spaces ignored).

    Args:
        text: What the user typed, e.g. ``"2.5,0.7,0"``.
        where: Name of the option or field for error messages, e.g. ``"--start"``.
        counts: Accepted numbers of values, e.g. ``(3,)``.
        form: The expected form for error messages, e.g. ``"x,y,z"`` (units belong here).

    Raises:
        ValueListError: Empty text, a non-number, a NaN/infinite value, or a wrong count.
    """
    if not isinstance(text, str):
        raise ValueListError(f"{where}: expected '{form}', got {text!r}")
    stripped = text.replace(" ", "")
    if not stripped:
        raise ValueListError(f"{where}: empty value; expected '{form}'")
    parts = stripped.split(",")
    values: list[float] = []
    for i, part in enumerate(parts):
        try:
            v = float(part)
        except ValueError:
            raise ValueListError(f"{where}: value {i + 1} ({part!r}) is not a number; expected '{form}'") from None
        if not math.isfinite(v):
            raise ValueListError(f"{where}: value {i + 1} must be finite, got {part!r}")
        values.append(v)
    if len(values) not in counts:
        n = " or ".join(str(c) for c in counts)
        raise ValueListError(f"{where}: expected {n} numbers '{form}', got {len(values)} in {text!r}")
    return values


def looks_like_negative_value(token: str) -> bool:
    """True for a command-line token that is a (list of) negative number(s), such as ``-1,2,0,90``,
    ``-.5`` or ``-inf``, and so can never be an option name."""
    if len(token) < 2 or token[0] != "-" or token[1] == "-":
        return False
    head = token[1:].split(",", 1)[0].lower()
    return bool(head) and (head[0].isdigit() or head[0] == "." or head in ("inf", "nan", "infinity"))


__all__ = ["ValueListError", "looks_like_negative_value", "parse_numbers"]
