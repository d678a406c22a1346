"""Missions: a registered path split into typed segments (walk / take-off / fly / land).

All waypoints are in the world frame (z up) [m]. Walking waypoints sit on the floor
(``z = workspace floor``); flying waypoints are cell centres in the air.

- ``WALK``: ground waypoints, first = where the robot stands.
- ``TAKEOFF``: ``[spot on the floor, spot at the target height]``.
- ``FLY``: air waypoints, first = the take-off target, last = above the landing spot.
- ``LAND``: ``[above the spot, spot on the floor]``.
- ``TURN``: ``[where the robot stands or hovers]`` and ``yaw``, the heading to face [rad]
  (about world +z, counter-clockwise from world +x, as REP 103): a yaw in place, on the ground or
  in the air (the camera looks somewhere else; the robot does not move).
"""

from __future__ import annotations

import json
import math
import os
import time
import uuid
from dataclasses import dataclass, field
from enum import Enum
from pathlib import Path
from typing import Any

import numpy as np

from pipeline.scene import write_text_atomic

from planner.grid import CellState, PlanningGrid, Workspace
from planner.landing_spot import landing_problem

MISSION_VERSION = 1

Vec3 = tuple[float, float, float]



def count_text(n: int, word: str) -> str:
    """``n`` and ``word`` in the right number (``1 segment``, ``2 segments``): the planner's own copy of
    ``console.wording.plural``, which it may not import (data flows pipeline -> planner -> console)."""
    return f"{int(n)} {word if int(n) == 1 else word + 's'}"

class MissionError(ValueError):
    """A malformed mission or a path that cannot become a mission."""


class SegmentKind(str, Enum):
    WALK = "walk"
    TAKEOFF = "takeoff"
    FLY = "fly"
    LAND = "land"
    TURN = "turn"


@dataclass(frozen=True)
class MissionSegment:
    """One typed piece of a mission; ``waypoints`` in the world frame [m].

    ``yaw`` is the heading a ``TURN`` ends at [rad] (world frame, counter-clockwise from +x,
    wrapped into [-pi, pi)); ``None`` for every other kind.
    """

    kind: SegmentKind
    waypoints: tuple[Vec3, ...]
    yaw: float | None = None

    def __post_init__(self) -> None:
        if len(self.waypoints) < 1:
            raise MissionError(f"{self.kind.value} segment has no waypoints")
        if self.kind in (SegmentKind.TAKEOFF, SegmentKind.LAND) and len(self.waypoints) != 2:
            raise MissionError(f"{self.kind.value} segment needs exactly 2 waypoints (spot and height)")
        if self.kind is SegmentKind.TURN:
            if len(self.waypoints) != 1:
                raise MissionError("turn segment needs exactly 1 waypoint (where the robot turns)")
            y = self.yaw
            if not (isinstance(y, (int, float)) and not isinstance(y, bool) and math.isfinite(y)):
                raise MissionError(f"turn segment: yaw must be a finite number [rad], got {y!r}")
            object.__setattr__(self, "yaw", (float(y) + math.pi) % (2 * math.pi) - math.pi)
        elif self.yaw is not None:
            raise MissionError(f"{self.kind.value} segment: yaw is only for a turn segment")

    @property
    def start(self) -> Vec3:
        return self.waypoints[0]

    @property
    def end(self) -> Vec3:
        return self.waypoints[-1]

    @property
    def spot(self) -> Vec3:
        """Ground spot of a take-off or landing [m]."""
        return self.waypoints[0] if self.kind is SegmentKind.TAKEOFF else self.waypoints[-1]

    @property
    def height(self) -> float:
        """Take-off target / landing start altitude [m] (world z)."""
        return self.waypoints[-1][2] if self.kind is SegmentKind.TAKEOFF else self.waypoints[0][2]

    @property
    def length(self) -> float:
        """Path length [m]."""
        p = np.asarray(self.waypoints)
        return float(np.linalg.norm(np.diff(p, axis=0), axis=1).sum()) if len(p) > 1 else 0.0

    def to_dict(self) -> dict[str, Any]:
        out: dict[str, Any] = {"kind": self.kind.value, "waypoints": [[round(c, 4) for c in w] for w in self.waypoints]}
        if self.yaw is not None:
            out["yaw"] = round(self.yaw, 6)
        return out


def turn_segment(at: Vec3, yaw: float) -> MissionSegment:
    """A ``TURN`` in place at ``at`` (world frame [m]) to the heading ``yaw`` [rad]."""
    return MissionSegment(SegmentKind.TURN, ((float(at[0]), float(at[1]), float(at[2])),), yaw=yaw)


def heading_to(at: Vec3, target: Vec3) -> float:
    """The heading [rad] (world frame, counter-clockwise from +x) from ``at`` to ``target``
    (horizontal only); raises :class:`MissionError` when ``target`` is straight above or below."""
    dx, dy = float(target[0]) - float(at[0]), float(target[1]) - float(at[1])
    if math.hypot(dx, dy) < 1e-6:
        raise MissionError(f"({target[0]:.2f}, {target[1]:.2f}) is right at the robot: no heading to face")
    return math.atan2(dy, dx)


@dataclass(frozen=True)
class Mission:
    """An ordered list of segments, plus the workspace bounds used as a geofence."""

    segments: tuple[MissionSegment, ...]
    bounds_min: Vec3 = (0.0, 0.0, 0.0)
    bounds_max: Vec3 = (5.0, 8.0, 3.0)
    id: str = field(default_factory=lambda: uuid.uuid4().hex[:8])
    created: float = field(default_factory=time.time)

    def __post_init__(self) -> None:
        if not self.segments:
            raise MissionError("a mission needs at least one segment")
        for i in range(1, len(self.segments)):
            a, b = self.segments[i - 1].end, self.segments[i].start
            if math.dist(a, b) > 1e-6:
                raise MissionError(f"segment {i} starts at {b}, but segment {i - 1} ends at {a}")

    @property
    def length(self) -> float:
        return sum(s.length for s in self.segments)

    def kinds(self) -> list[str]:
        return [s.kind.value for s in self.segments]

    def summary(self) -> str:
        """One line per segment, for people."""
        lines = [f"mission {self.id}: {count_text(len(self.segments), 'segment')}, {self.length:.2f} m"]
        for i, s in enumerate(self.segments):
            a, b = s.start, s.end
            extra = f", {count_text(len(s.waypoints), 'waypoint')}" if s.kind in (SegmentKind.WALK, SegmentKind.FLY) else ""
            if s.kind is SegmentKind.TURN and s.yaw is not None:
                extra = f", to heading {math.degrees(s.yaw):.0f} deg"
            lines.append(
                f"  {i + 1}. {s.kind.value.upper():8s} ({a[0]:.2f}, {a[1]:.2f}, {a[2]:.2f}) -> "
                f"({b[0]:.2f}, {b[1]:.2f}, {b[2]:.2f})  {s.length:.2f} m{extra}"
            )
        return "\n".join(lines)

    def to_dict(self) -> dict[str, Any]:
        return {
            "version": MISSION_VERSION,
            "id": self.id,
            "created": self.created,
            "frame": "world",
            "bounds": {"min": list(self.bounds_min), "max": list(self.bounds_max)},
            "segments": [s.to_dict() for s in self.segments],
        }

    def save(self, path: str | os.PathLike[str]) -> Path:
        return write_text_atomic(Path(path), json.dumps(self.to_dict(), indent=1) + "\n")

    @staticmethod
    def from_dict(data: Any) -> "Mission":
        """Validate and build; raises :class:`MissionError` naming the bad field."""
        if not isinstance(data, dict):
            raise MissionError("mission: must be a JSON object")
        if data.get("version") != MISSION_VERSION:
            raise MissionError(f"version: expected {MISSION_VERSION}, got {data.get('version')!r}")
        segs_raw = data.get("segments")
        if not isinstance(segs_raw, list):
            raise MissionError("segments: must be a list")
        segs: list[MissionSegment] = []
        for i, s in enumerate(segs_raw):
            if not isinstance(s, dict):
                raise MissionError(f"segments[{i}]: must be an object")
            try:
                kind = SegmentKind(s.get("kind"))
            except ValueError:
                raise MissionError(f"segments[{i}].kind: must be one of {'/'.join(k.value for k in SegmentKind)}, "
                                   f"got {s.get('kind')!r}") from None
            wps = s.get("waypoints")
            if not isinstance(wps, list):
                raise MissionError(f"segments[{i}].waypoints: must be a list")
            pts: list[Vec3] = []
            for j, w in enumerate(wps):
                if (not isinstance(w, list) or len(w) != 3
                        or not all(isinstance(c, (int, float)) and not isinstance(c, bool) and math.isfinite(c) for c in w)):
                    raise MissionError(f"segments[{i}].waypoints[{j}]: must be 3 finite numbers [m], got {w!r}")
                pts.append((float(w[0]), float(w[1]), float(w[2])))
            yaw = s.get("yaw")
            if kind is SegmentKind.TURN and not (isinstance(yaw, (int, float)) and not isinstance(yaw, bool)
                                                 and math.isfinite(yaw)):
                raise MissionError(f"segments[{i}].yaw: must be a finite number [rad], got {yaw!r}")
            if kind is not SegmentKind.TURN and yaw is not None:
                raise MissionError(f"segments[{i}].yaw: only a turn segment has a yaw")
            try:
                segs.append(MissionSegment(kind, tuple(pts), yaw=None if yaw is None else float(yaw)))
            except MissionError as exc:
                raise MissionError(f"segments[{i}]: {exc}") from None
        bounds = data.get("bounds") or {}
        try:
            bmin = tuple(float(v) for v in bounds.get("min", (0, 0, 0)))
            bmax = tuple(float(v) for v in bounds.get("max", (5, 8, 3)))
            assert len(bmin) == 3 and len(bmax) == 3
        except (TypeError, ValueError, AssertionError, AttributeError):
            raise MissionError("bounds: expected {'min': [x,y,z], 'max': [x,y,z]}") from None
        return Mission(tuple(segs), bmin, bmax, str(data.get("id", uuid.uuid4().hex[:8])),  # type: ignore[arg-type]
                       float(data.get("created", time.time())))

    @staticmethod
    def load(path: str | os.PathLike[str]) -> "Mission":
        try:
            return Mission.from_dict(json.loads(Path(path).read_text(encoding="utf-8")))
        except json.JSONDecodeError as exc:
            raise MissionError(f"{path}: not valid JSON: {exc}") from None
        except OSError as exc:
            raise MissionError(f"cannot read mission {path}: {exc}") from None


def simplify(points: np.ndarray, tol: float = 1e-6) -> np.ndarray:
    """Drop waypoints that lie on the straight line between their neighbours."""
    p = np.asarray(points, dtype=np.float64)
    if len(p) <= 2:
        return p
    keep = [0]
    for i in range(1, len(p) - 1):
        a, b, c = p[keep[-1]], p[i], p[i + 1]
        d1, d2 = b - a, c - b
        if np.linalg.norm(np.cross(d1, d2)) > tol * max(1.0, np.linalg.norm(d1) * np.linalg.norm(d2)) or np.dot(d1, d2) < 0:
            keep.append(i)
    keep.append(len(p) - 1)
    return p[keep]


def check_landing(grid: PlanningGrid, spot: tuple[float, float]) -> None:
    """Raise :class:`MissionError` when the robot may not land at ``spot`` (world [m]; free ground under its
    whole footprint: :func:`planner.landing_spot.landing_problem`, the one rule for every landing)."""
    problem = landing_problem(grid, spot, clear=True)
    if problem is not None:
        raise MissionError(f"cannot land at ({spot[0]:.2f}, {spot[1]:.2f}): {problem}")


def mission_from_cells(cells: np.ndarray, grid: PlanningGrid) -> Mission:
    """Split a path of grid cells (K x 3, start..goal) into mission segments.

    The path leaves the ground where a ground cell is followed by an air cell: that ground cell
    is the take-off spot and the first air cell's height the take-off target. It returns to the
    ground at the first ground cell after air: the landing spot. Take-off and landing spots must
    be on free ground (not dangerous) and the column above them passable; a landing spot also passes
    :func:`check_landing` (the robot's whole footprint: no mapped object of any height, no obstacle cell,
    no unseen floor).
    """
    cells = np.asarray(cells, dtype=np.int64).reshape(-1, 3)
    if len(cells) == 0:
        raise MissionError("the path is empty")
    ws: Workspace = grid.workspace
    centres = ws.centers(cells)
    floor = ws.floor
    on_ground = cells[:, 2] == 0
    segments: list[MissionSegment] = []

    def ground_pt(i: int) -> Vec3:
        return (float(centres[i, 0]), float(centres[i, 1]), floor)

    def check_spot(i: int, what: str) -> None:
        st = grid.state_at(cells[i])
        x, y, _ = ground_pt(i)
        if what == "landing":
            check_landing(grid, (x, y))
        if st is not CellState.FREE:
            raise MissionError(f"{what} spot ({x:.2f}, {y:.2f}) is on {st.name.lower()} ground")
        above = (int(cells[i, 0]), int(cells[i, 1]), 1)
        if ws.shape[2] > 1 and grid.state_at(above) is CellState.OCCUPIED:  # e.g. under a shelf board
            raise MissionError(f"{what} spot ({x:.2f}, {y:.2f}) has an obstacle right above it")

    i, n = 0, len(cells)
    if not on_ground[0]:
        raise MissionError("the path must start on the ground (the robot stands on the floor)")
    while i < n:
        j = i
        while j + 1 < n and on_ground[j + 1]:
            j += 1
        walk = [ground_pt(t) for t in range(i, j + 1)]
        if len(walk) > 1 or not segments:
            if len(walk) > 1:
                segments.append(MissionSegment(SegmentKind.WALK, tuple(map(tuple, simplify(np.array(walk))))))  # type: ignore[arg-type]
        if j + 1 >= n:
            break
        # air run j+1 .. k-1, landing at k (or the path ends in the air)
        k = j + 1
        while k < n and not on_ground[k]:
            k += 1
        check_spot(j, "take-off")
        spot = ground_pt(j)
        first_air = centres[j + 1]
        up = (spot[0], spot[1], float(first_air[2]))
        segments.append(MissionSegment(SegmentKind.TAKEOFF, (spot, up)))
        air = [up] + [tuple(map(float, centres[t])) for t in range(j + 1, k)]
        if k < n:
            check_spot(k, "landing")
            land_spot = ground_pt(k)
            above = (land_spot[0], land_spot[1], air[-1][2])
            air.append(above)
        fly = simplify(np.array(air))
        if len(fly) > 1:
            segments.append(MissionSegment(SegmentKind.FLY, tuple(map(tuple, fly))))  # type: ignore[arg-type]
        if k >= n:
            break
        segments.append(MissionSegment(SegmentKind.LAND, (tuple(map(float, fly[-1])), land_spot)))  # type: ignore[arg-type]
        i = k
    if not segments:  # start == goal on the ground
        segments.append(MissionSegment(SegmentKind.WALK, (ground_pt(0),)))
    return Mission(tuple(segments), ws.min, ws.max)
