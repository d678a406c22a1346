"""What a search is asked to do and how it ended: :class:`SearchConfig` (target, mode, budgets),
:class:`SearchResult` (``result.json``), and the small rules shared by the loop and its callers.

Budgets: captures, time [s] and battery (a fraction of the charge, 0..1). The battery budget keeps a
reserve above the console's own battery rules (:mod:`console.session.operator_state`: below
:data:`~console.session.operator_state.BATTERY_LOW` no new move may start, below
:data:`~console.session.operator_state.BATTERY_CRITICAL` the robot is landed where it is): the search
ends with a ``battery: ...`` report before either acts, so the operator can still bring the robot back.
"""

from __future__ import annotations

import json
import math
import re
from dataclasses import asdict, dataclass, field

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
        if not isinstance(self.target, str) or not self.target.strip() or len(self.target) > 200:
            raise SessionError("target: must be 1..200 characters (a catalog class or a prompt)")
        if self.mode not in MODES:
            raise SessionError(f"mode: must be one of {', '.join(MODES)}, got {self.mode!r}")
        if isinstance(self.max_captures, bool) or not isinstance(self.max_captures, int) or not 1 <= self.max_captures <= 200:
            raise SessionError(f"max_captures: must be a whole number within 1..200, got {self.max_captures!r}")
        for name, hi in (("max_time", 86400.0), ("target_height", 10.0)):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) or not 0 < v <= hi:
                raise SessionError(f"{name}: must be finite and within 0..{hi:g}, got {v!r}")
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


def target_height(target: str, default: float = 0.6) -> float:
    """The catalog's height [m] of ``target``'s class, else ``default`` (a prompt, an unknown class)."""
    try:
        from pipeline.catalog import Catalog

        entry = Catalog.load().lookup(target.strip().replace(" ", "_"))
        h = entry.height if entry is not None else None
        return float(h) if h else default
    except Exception:  # no catalog: the default
        return default


def target_matches(label: str, target: str) -> bool:
    a, b = _norm(label), _norm(target)
    return a == b or (b.endswith("s") and a == b[:-1])


__all__ = ["BATTERY_RESERVE", "CONFIRM_CAPTURES", "GAIN_MIN", "MISSION_TIMEOUT", "MODES", "SURE_SCORE", "SURE_SIGMA",
           "SearchConfig", "SearchResult", "target_height", "target_matches"]
