"""The search's inputs as the operator types them, checked in one place for every door: ``morphonavi search``
(its options) and the console's Find panel (its fields).

:func:`search_config` takes the values as typed (text or numbers, in the units the door shows: the time
budget in seconds on the command line, in minutes in the panel; the battery reserve in per cent) and
returns a :class:`~console.session.search_types.SearchConfig`, or raises
:class:`~console.session.session_types.SessionError` whose message starts with the name the operator
sees (``--max-captures: ...`` or ``Capture budget: ...``) and says the same words at both doors.

The target must be something the perception can name: the mapper looks only for the catalog's classes
(by their open-vocabulary detector prompts), so a target is a catalog class, one of its synonyms or one
of its prompts (``robot dog``, ``quadruped``, ``a quadruped robot``); anything else is refused before
the search starts, with the classes it can name (:func:`check_target`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Callable

from console.session.operator_state import BATTERY_LOW
from console.session.search_types import (
    CATALOG_FILE, MAX_CAPTURES, MAX_TIME, MIN_TIME, MODES, SearchConfig, check_target, target_height,
)
from console.session.session_types import SessionError

@dataclass(frozen=True)
class InputNames:
    """What a door calls each search input, and the unit its time budget is typed in.

    Attributes:
        target: The target's name (``--target``, ``Find``).
        mode: The mode's name.
        max_captures: The capture budget's name.
        max_time: The time budget's name.
        time_unit: ``s`` or ``min``: the unit the time budget is typed in.
        battery_reserve: The battery reserve's name (typed in per cent of the charge).
    """

    target: str
    mode: str
    max_captures: str
    max_time: str
    time_unit: str
    battery_reserve: str


CLI_NAMES = InputNames("--target", "--mode", "--max-captures", "--max-time", "s", "--battery-reserve")
"""``morphonavi search``'s options."""
PANEL_NAMES = InputNames("Find", "Search mode", "Capture budget", "Time budget [min]", "min", "Battery reserve [%]")
"""The Find panel's fields."""
_UNIT_SECONDS = {"s": 1.0, "min": 60.0}


def _shown(value: Any) -> str:
    """A value as the operator typed it (text as is, numbers without trailing zeros)."""
    if isinstance(value, str):
        return repr(value) if not value.strip() else value.strip()
    if isinstance(value, float):
        return f"{value:g}"
    return repr(value)


def _number(value: Any) -> float | None:
    """``value`` as a float (text parsed), or ``None`` when it is no number (NaN and infinities are numbers here)."""
    if isinstance(value, bool):
        return None
    if isinstance(value, (int, float)):
        return float(value)
    if isinstance(value, str):
        try:
            return float(value.strip())
        except ValueError:
            return None
    return None


def search_config(names: InputNames, target: Any, *, mode: Any = "auto", max_captures: Any = 20,
                  max_time: Any = None, battery_reserve: Any = None,
                  height_of: Callable[[str], float] = target_height) -> SearchConfig:
    """The search a door asks for, every input checked naming it as the door does.

    Args:
        names: The door's names for the inputs (:data:`CLI_NAMES`, :data:`PANEL_NAMES`).
        target: What to find (see :func:`check_target`).
        mode: ``auto`` or ``step``.
        max_captures: Capture budget, a whole number within 1..:data:`MAX_CAPTURES`.
        max_time: Time budget in ``names.time_unit`` (``None``: the default 900 s).
        battery_reserve: Battery reserve [%] of the charge, at least the console's low-battery rule
            (:data:`~console.session.operator_state.BATTERY_LOW`) and below 100 (``None``: the default).
        height_of: The target's height [m] from its words (the catalog's for its class).

    Raises:
        SessionError: The first bad input, its message starting with ``names``' name for it.
    """
    words = check_target(target, names.target)
    if not isinstance(mode, str) or mode.strip() not in MODES:
        raise SessionError(f"{names.mode}: must be one of {', '.join(MODES)}, got {_shown(mode)}")
    n = _number(max_captures)
    if n is None or not math.isfinite(n) or n != int(n) or not 1 <= n <= MAX_CAPTURES:
        raise SessionError(f"{names.max_captures}: must be a whole number within 1..{MAX_CAPTURES}, "
                           f"got {_shown(max_captures)}")
    scale = _UNIT_SECONDS[names.time_unit]
    seconds = None
    if max_time is not None:
        t = _number(max_time)
        lo, hi = MIN_TIME / scale, MAX_TIME / scale
        if t is None or not math.isfinite(t) or not lo <= t <= hi:
            raise SessionError(f"{names.max_time}: must be a number within {lo:g}..{hi:g} {names.time_unit}, "
                               f"got {_shown(max_time)}")
        seconds = t * scale
    reserve = None
    if battery_reserve is not None:
        b = _number(battery_reserve)
        low = 100 * BATTERY_LOW
        if b is None or not math.isfinite(b) or not low <= b < 100:
            raise SessionError(f"{names.battery_reserve}: must be at least {low:.0f} % and below 100 % (below "
                               f"{low:.0f} % the console refuses new moves), got {_shown(battery_reserve)}")
        reserve = b / 100.0
    extra: dict[str, Any] = {}
    if seconds is not None:
        extra["max_time"] = seconds
    if reserve is not None:
        extra["min_battery"] = reserve
    return SearchConfig(words, mode=mode.strip(), max_captures=int(n), target_height=height_of(words), **extra)


__all__ = ["CATALOG_FILE", "CLI_NAMES", "InputNames", "PANEL_NAMES", "check_target", "search_config"]
