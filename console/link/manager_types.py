"""The mission manager's vocabulary: status, progress, events and its errors.

:class:`MissionProgress` says where a mission stands (fractions by path length), :class:`MissionEvent`
is what the console is told (on the manager's thread). Re-exported by :mod:`console.link.manager`.
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import Enum
from typing import Callable

from planner.mission import SegmentKind


class MissionStatus(str, Enum):
    IDLE = "idle"
    RUNNING = "running"
    PAUSED = "paused"  # held by the operator or after a failure: resume() continues
    FAILSAFE = "failsafe"  # link lost: holding / landing; resume() once the link is back
    DONE = "done"
    ABORTED = "aborted"

    @property
    def active(self) -> bool:
        return self in (MissionStatus.RUNNING, MissionStatus.PAUSED, MissionStatus.FAILSAFE)


class MissionStateError(RuntimeError):
    """The operation does not fit the manager's state (resume with nothing paused ...)."""


class GeofenceError(ValueError):
    """A mission target lies outside the geofence; the message names segment and waypoint."""


@dataclass(frozen=True)
class MissionProgress:
    """Where the mission stands.

    Attributes:
        status: Overall state.
        mission_id: Id of the mission, ``None`` before the first.
        segment: Index of the current (or interrupted) segment, ``None`` when none.
        segments: Number of segments.
        kind: Kind of the current segment.
        control: ``ground`` (walking) or ``flight`` (take-off, flight, landing) or ``""``.
        segment_fraction: Fraction of the current segment done, in [0, 1].
        fraction: Fraction of the whole mission done (by path length), in [0, 1].
        message: Latest human-readable status.
    """

    status: MissionStatus = MissionStatus.IDLE
    mission_id: str | None = None
    segment: int | None = None
    segments: int = 0
    kind: SegmentKind | None = None
    control: str = ""
    segment_fraction: float = 0.0
    fraction: float = 0.0
    message: str = ""


@dataclass(frozen=True)
class MissionEvent:
    """Something the console should show: ``level`` is ``info``, ``warning``, ``error`` or
    ``progress`` (throttled position updates)."""

    time: float
    level: str
    message: str
    progress: MissionProgress


EventListener = Callable[[MissionEvent], None]


__all__ = ["MissionStatus", "MissionProgress", "MissionEvent", "EventListener", "MissionStateError", "GeofenceError"]
