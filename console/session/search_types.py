"""What a search is asked to do and how it ended: :class:`SearchConfig` (target, mode, budgets),
:class:`SearchResult` (``result.json``), and the small rules shared by the loop and its callers.

Budgets: captures, time [s] and battery (a fraction of the charge, 0..1). The battery budget keeps a
reserve above the console's own battery rules (:mod:`console.session.operator_state`: below
:data:`~console.session.operator_state.BATTERY_LOW` no new move may start, below
:data:`~console.session.operator_state.BATTERY_CRITICAL` the robot is landed where it is): the search
ends with a ``battery: ...`` report before either acts, so the operator can still bring the robot back.
"""

from __future__ import annotations

import difflib
import json
import math
import re
from dataclasses import asdict, dataclass, field
from typing import Any

from console.session.operator_state import BATTERY_LOW
from console.session.session_types import SessionError

CONFIRM_CAPTURES = 2
SURE_SCORE = 0.8
SURE_SIGMA = 0.15
"""[m]"""
GAIN_MIN = 0.25
"""Least weighted unknown volume [m³] a seen-space viewpoint must show before the search looks into unknown space."""
MODES = ("auto", "step")
MISSION_TIMEOUT = 900.0
"""Longest wait for one move [s]."""
MAX_CAPTURES = 200
"""Largest capture budget."""
MIN_TIME, MAX_TIME = 30.0, 86400.0
"""Time budget's range [s]."""
TARGET_MAX_CHARS = 200
CATALOG_FILE = "assets/catalog.toml"
"""Where a new class (name, detector prompts, size) is added so the perception looks for it."""
BATTERY_RESERVE = BATTERY_LOW + 0.05
"""Default battery budget: the search ends below this charge [0..1] (the console refuses new moves
below :data:`~console.session.operator_state.BATTERY_LOW`; the reserve is left to Return or land)."""


def _norm(text: str) -> str:
    return re.sub(r"[\s_\-]+", "_", text.strip().lower())


@dataclass(frozen=True)
class SearchConfig:
    """What to find and how.

    Attributes:
        target: A catalog class or the operator's words (``robot dog`` = ``robot_dog``).
        mode: ``auto`` (moves on its own) or ``step`` (each move waits for Approve).
        max_captures: Capture budget.
        max_time: Time budget [s].
        target_height: Height of the target [m] (the catalog's for its class; unknown space up to it counts fully).
        min_battery: Battery budget: the search ends when the charge [0..1] is below this, before the
            console's battery rules act; at least :data:`~console.session.operator_state.BATTERY_LOW`.
    """

    target: str
    mode: str = "auto"
    max_captures: int = 20
    max_time: float = 900.0
    target_height: float = 0.6
    min_battery: float = BATTERY_RESERVE

    def __post_init__(self) -> None:
        check_target(self.target, "target")
        if self.mode not in MODES:
            raise SessionError(f"mode: must be one of {', '.join(MODES)}, got {self.mode!r}")
        n = self.max_captures
        if isinstance(n, bool) or not isinstance(n, int) or not 1 <= n <= MAX_CAPTURES:
            raise SessionError(f"max_captures: must be a whole number within 1..{MAX_CAPTURES}, got {n!r}")
        for name, lo, hi in (("max_time", MIN_TIME, MAX_TIME), ("target_height", 0.0, 10.0)):
            v = getattr(self, name)
            ok = isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v) and v <= hi
            if not ok or not (v >= lo if lo > 0 else v > lo):
                raise SessionError(f"{name}: must be finite and within {lo:g}..{hi:g}, got {v!r}")
        b = self.min_battery
        if isinstance(b, bool) or not isinstance(b, (int, float)) or not math.isfinite(b) or not BATTERY_LOW <= b < 1:
            raise SessionError(f"min_battery: must be finite and within {BATTERY_LOW:g}..1 (a fraction of the charge; "
                               f"below {BATTERY_LOW:g} the console refuses new moves), got {b!r}")


@dataclass
class SearchResult:
    """How a search ended (``result.json``).

    ``left_unseen``: what was not seen when it ended and why (``""`` when found); ``choose_seconds``:
    the time of each next-viewpoint choice [s]; ``contacts``: moves that ended in a contact with something
    the map did not show (each followed by a capture and a new plan, never the same route again).
    """

    found: bool = False
    target: str = ""
    target_id: str | None = None
    target_position: list[float] | None = None
    seen_by: list[str] = field(default_factory=list)
    final_position: list[float] | None = None
    distance_to_target: float | None = None
    path_length: float = 0.0
    captures: int = 0
    time: float = 0.0
    reason: str = ""
    seen_share: float | None = None
    left_unseen: str = ""
    battery: float | None = None
    choose_seconds: list[float] = field(default_factory=list)
    contacts: int = 0
    steps: list[str] = field(default_factory=list)

    def to_json(self) -> str:
        return json.dumps(asdict(self), indent=1)


def check_target(target: Any, name: str = "target") -> str:
    """The target's words, stripped, when the perception can name them; :class:`SessionError` naming ``name``.

    A target resolves to a catalog class by name, synonym or detector prompt (case, spaces, hyphens, a
    plural and a leading article ignored: :meth:`pipeline.catalog.Catalog.lookup`).
    """
    if not isinstance(target, str) or not target.strip() or len(target.strip()) > TARGET_MAX_CHARS:
        got = (repr(target) if not isinstance(target, str) else f"{len(target.strip())} characters" if target.strip()
               else "nothing")
        raise SessionError(f"{name}: must be 1..{TARGET_MAX_CHARS} characters (what to find, e.g. 'robot dog'), "
                           f"got {got}")
    text = target.strip()
    if target_class(text) is not None:
        return text
    from pipeline.catalog import default_catalog, normalize_label

    names = [n.replace("_", " ") for n in default_catalog().names]
    key = normalize_label(text)
    near = [n for n in names if key and key in normalize_label(n)]
    near += [n for n in difflib.get_close_matches(text.lower(), names, n=3, cutoff=0.6) if n not in near]
    hint = f" (did you mean {' or '.join(repr(n) for n in near[:3])}?)" if near else ""
    raise SessionError(  # the first clause is the summary a short notice shows; "; " parts its details
        f"{name}: {text!r} is not an object the perception can name{hint}; it looks for the catalog's classes, "
        f"by a class, one of its synonyms or detector prompts (e.g. 'robot dog', 'quadruped', 'a quadruped robot'): "
        f"{', '.join(names)}; to find something else, add it to the catalog ({CATALOG_FILE}: a name, the "
        f"open-vocabulary prompts the detector looks for, a size)")


def target_class(target: str) -> Any:
    """The catalog class (:class:`pipeline.catalog.CatalogEntry`) ``target`` resolves to, or ``None``."""
    from pipeline.catalog import default_catalog

    return default_catalog().lookup(target)


def target_height(target: str, default: float = 0.6) -> float:
    """The catalog's height [m] of ``target``'s class, else ``default`` (a prompt, an unknown class)."""
    try:
        entry = target_class(target)
        h = entry.height if entry is not None else None
        return float(h) if h else default
    except Exception:  # no catalog: the default
        return default


def target_matches(label: str, target: str) -> bool:
    """Whether an object labelled ``label`` (a catalog class name) is what ``target`` asks for: the same
    words, or the class the target's words resolve to (``quadruped`` finds ``robot_dog``)."""
    a, b = _norm(label), _norm(target)
    if a == b or (b.endswith("s") and a == b[:-1]):
        return True
    entry = target_class(target)
    return entry is not None and _norm(entry.name) == a


__all__ = ["BATTERY_RESERVE", "CATALOG_FILE", "CONFIRM_CAPTURES", "GAIN_MIN", "MAX_CAPTURES", "MAX_TIME", "MIN_TIME",
           "MISSION_TIMEOUT", "MODES", "SURE_SCORE", "SURE_SIGMA", "TARGET_MAX_CHARS", "SearchConfig", "SearchResult",
           "check_target", "target_class", "target_height", "target_matches"]
