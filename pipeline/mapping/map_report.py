"""What the map fusion was asked and what it did: its thresholds and its report, per observation.

Data classes of :func:`pipeline.mapping.map_fusion.fuse` (re-exported there). Distances [m], world frame.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal

Action = Literal["added", "updated", "recorded", "rejected"]

EXTENT_NOTE = "seen in part along the viewing ray: its centre, a guess from the class size, not used"
"""Why a partial view joined by its extent does not move the object (history note, capture notice)."""


@dataclass(frozen=True)
class FusionConfig:
    """Thresholds of :func:`~pipeline.mapping.map_fusion.fuse`.

    Attributes:
        gate: Largest squared Mahalanobis distance of an association (11.34: chi-square, 3 degrees
            of freedom, 99 %).
        min_overlap: Footprint overlap (over the smaller footprint) that associates whatever the gate
            says, when the heights overlap by at least ``min_vertical``.
        min_vertical: Height-range overlap (over the shorter object) for the footprint rule.
        check_consistency: Hold back a capture that disagrees with the map everywhere.

    Raises:
        ValueError: A threshold not a finite number > 0 (names it).
    """

    gate: float = 11.34
    min_overlap: float = 0.3
    min_vertical: float = 0.5
    check_consistency: bool = True

    def __post_init__(self) -> None:
        for name in ("gate", "min_overlap", "min_vertical"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) or v <= 0:
                raise ValueError(f"FusionConfig.{name}: must be a finite number > 0, got {v!r}")


@dataclass(frozen=True)
class Outcome:
    """What happened to one observation.

    Attributes:
        observation: Its id in the new capture.
        label: Its class.
        action: ``added`` (a new object), ``updated`` (fused into ``object_id``), ``recorded`` (matched
            the pinned ``object_id``, or joined it by extent only: kept in its history, ``reason``
            says why) or ``rejected`` (``reason`` says why).
        object_id: The map object it became or matched, if any.
        reason: Why rejected (or recorded only).
        sigma: Its along-ray 1-sigma [m].
        detection: Its place in the capture's detections, 1-based (0: not known).
        score: Its detector confidence in [0, 1] (NaN: not known).
    """

    observation: str
    label: str
    action: Action
    object_id: str | None = None
    reason: str = ""
    sigma: float = math.nan
    detection: int = 0
    score: float = math.nan

    @property
    def name(self) -> str:
        """The observation as the photo names it, never by a map-like id (the capture's own ids, such as
        ``cardboard_box-1``, may be a map object's too): ``detection 3 (cardboard_box, 0.81)``, else
        ``a cardboard_box``."""
        if self.detection <= 0:
            return f"a {self.label}"
        score = f", {self.score:.2f}" if math.isfinite(self.score) else ""
        return f"detection {self.detection} ({self.label}{score})"


@dataclass(frozen=True)
class FusionReport:
    """What :func:`~pipeline.mapping.map_fusion.fuse` did: one :class:`Outcome` per observation,
    corrections, hold-back."""

    outcomes: tuple[Outcome, ...] = ()
    corrections: tuple[tuple[str, str], ...] = ()
    """``(object id, what was corrected)`` for objects moved onto their support."""
    held_back: str | None = None
    """Why the capture was not merged (the map is unchanged), ``None`` if it was."""
    merged: tuple[tuple[str, str], ...] = ()
    """``(kept id, removed id)``: two objects of one class that overlapped, merged (one object mapped twice)."""
    removed: tuple[tuple[str, str], ...] = ()
    """``(id, why)``: objects seen by one capture only that later captures did not see where they should have."""

    def ids(self, action: Action) -> list[str]:
        """Map object ids (``observation`` ids for ``rejected``) with this outcome."""
        return [o.object_id or o.observation for o in self.outcomes if o.action == action]

    @property
    def added(self) -> list[str]:
        return self.ids("added")

    @property
    def updated(self) -> list[str]:
        return self.ids("updated")

    @property
    def rejected(self) -> list[Outcome]:
        return [o for o in self.outcomes if o.action == "rejected"]

    @property
    def not_added(self) -> set[str]:
        """Observation ids rejected without a map object (outside the workspace, a sliver...): a caller
        that merges the capture again (the console's spawn) leaves them out."""
        return {o.observation for o in self.outcomes if o.action == "rejected" and o.object_id is None}

    def notes(self) -> list[str]:
        """Operator-facing lines: rejections, pinned objects seen again, corrections, hold-back."""
        out = [f"{o.name} not used: {o.reason}" for o in self.rejected]
        out += [f"{o.object_id} is pinned: seen again at the capture, not moved" if o.reason != EXTENT_NOTE
                else f"{o.object_id}: {o.reason}" for o in self.outcomes if o.action == "recorded"]
        out += [f"{oid}: {what}" for oid, what in self.corrections]
        out += [f"{gone} merged into {kept}: they overlapped (one object mapped twice)" for kept, gone in self.merged]
        out += [f"{oid}: {why}" for oid, why in self.removed]
        if self.held_back:
            out.insert(0, f"capture held back: {self.held_back}")
        return out


__all__ = ["EXTENT_NOTE", "Action", "FusionConfig", "FusionReport", "Outcome"]
