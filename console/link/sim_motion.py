"""The simulated robot's motion plan: a mission segment turned into timed phases.

A segment becomes a list of :class:`Phase` (turn to face the way, move, spool the motors up,
climb, descend, settle; a ``TURN`` segment is one turn in place) that :class:`~console.link.sim.SimRobot` runs in simulated time. The
plan checks that the segment starts where the robot is, that no waypoint leaves the workspace and
that the segment fits the robot's state (no walking in the air, no flying on the ground). Hidden
objects are not checked up front: the robot finds them by touching them while it moves.

Frames: world (z up) [m]; yaw about +z [rad].
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable, Sequence

import numpy as np

from planner.mission import MissionSegment, SegmentKind

from console.link.base import LinkError, Mode
from console.link.sim_config import SimConfig

Vec3 = tuple[float, float, float]


@dataclass
class Phase:
    """One step of a segment: ``turn``, ``move``, ``spool``, ``climb``, ``descend`` or ``settle``.

    Attributes:
        kind: The step.
        mode: The robot's mode while it runs.
        target: Where a straight motion ends (world frame [m]).
        yaw: The heading a turn ends at [rad].
        speed: Straight-motion speed [m/s].
        duration: Time left of a ``spool`` or ``settle`` [s].
        waypoint: Index of the segment's waypoint the step heads for (progress reports).
        stop: A ``descend`` that ends on a face the body cannot stand on: why it stops there
            (``contact below at ...``), ``""`` when it touches down.
        forced: Part of the empty battery's descent: it lands on whatever it meets and Hold / Abort
            do not stop it.
    """

    kind: str
    mode: Mode
    target: Vec3 | None = None
    yaw: float | None = None
    speed: float = 0.0
    duration: float = 0.0
    waypoint: int | None = None
    stop: str = ""
    forced: bool = False


def wrap_angle(a: float) -> float:
    """``a`` [rad] wrapped into [-pi, pi)."""
    return (a + math.pi) % (2 * math.pi) - math.pi


def verb(ph: Phase) -> str:
    """What a phase's motion is called in messages (``walking``, ``flight`` ...)."""
    return {Mode.WALKING: "walking", Mode.FLYING: "flight", Mode.TAKING_OFF: "take-off",
            Mode.LANDING: "landing", Mode.FAILSAFE: "failsafe landing"}.get(ph.mode, "motion")


def path_length(start: np.ndarray, phases: Sequence[Phase]) -> float:
    """Length [m] of the straight motions of ``phases`` from ``start`` (world frame)."""
    total, p = 0.0, start.copy()
    for ph in phases:
        if ph.target is not None:
            q = np.asarray(ph.target)
            total += float(np.linalg.norm(q - p))
            p = q
    return total


def plan_segment(seg: MissionSegment, here: np.ndarray, yaw: float, landed: bool, floor: float,
                 cfg: SimConfig, blocker: Callable[[np.ndarray], str | None]) -> list[Phase]:
    """The phases that run ``seg`` from the robot's state.

    Args:
        seg: The segment (world frame [m]).
        here: The robot's position (world frame [m], shape (3,); not modified).
        yaw: The robot's heading about +z [rad].
        landed: Whether the robot is on the ground.
        floor: Ground height [m].
        cfg: Speeds, rates and the start tolerance.
        blocker: Why a point is not allowed (outside the workspace), or ``None``.

    Returns:
        The phases in order (empty: nothing to do, e.g. a landing on the ground).

    Raises:
        LinkError: The segment does not start at the robot, a waypoint is blocked, or the
            segment does not fit the robot's state (walking in the air ...).
    """
    wps = [np.asarray(w, dtype=np.float64) for w in seg.waypoints]
    here = here.copy()
    first = wps[0]
    kind = seg.kind
    if kind is SegmentKind.LAND and landed:
        return []
    gap = float(np.linalg.norm((first - here)[:2]))
    if gap > cfg.start_tolerance:
        raise LinkError(f"the {kind.value} segment starts at ({first[0]:.2f}, {first[1]:.2f}) but the robot "
                        f"is at ({here[0]:.2f}, {here[1]:.2f}), {gap:.2f} m away")
    if kind is SegmentKind.WALK:
        wps = [np.array([w[0], w[1], floor]) for w in wps]
    for i, w in enumerate(wps):
        if kind is SegmentKind.TAKEOFF and i == 0:
            w = np.array([w[0], w[1], floor])
        why = None if kind is SegmentKind.LAND and i == 1 else blocker(w)
        if why is not None:
            raise LinkError(f"{kind.value} waypoint {i}: {why}")
    phases: list[Phase] = []

    def go(points: list[np.ndarray], mode: Mode, speed: float, first_index: int) -> None:
        nonlocal yaw
        for i, w in enumerate(points):
            d = w - (points[i - 1] if i else here)
            if float(np.hypot(d[0], d[1])) > 0.05:
                heading = math.atan2(d[1], d[0])
                if abs(wrap_angle(heading - yaw)) > 1e-3:
                    phases.append(Phase("turn", mode, yaw=heading, waypoint=first_index + i))
                    yaw = heading
            if float(np.linalg.norm(d)) > 1e-6:
                phases.append(Phase("move", mode, target=tuple(w), speed=speed, waypoint=first_index + i))

    if kind is SegmentKind.WALK:
        if not landed:
            raise LinkError("cannot walk: the robot is in the air (land first)")
        go(wps, Mode.WALKING, cfg.walk_speed, 0)
    elif kind is SegmentKind.FLY:
        if landed:
            raise LinkError("cannot fly: the robot is on the ground (take off first)")
        go(wps, Mode.FLYING, cfg.fly_speed, 0)
    elif kind is SegmentKind.TAKEOFF:
        top = wps[1]
        if top[2] <= here[2] + 1e-6:
            raise LinkError(f"take-off height {top[2]:.2f} m is not above the robot ({here[2]:.2f} m)")
        if landed:
            phases.append(Phase("spool", Mode.TAKING_OFF, duration=cfg.spool_time, waypoint=1))
        phases.append(Phase("climb", Mode.TAKING_OFF, target=(here[0], here[1], float(top[2])),
                          speed=cfg.climb_rate, waypoint=1))
        if float(np.hypot(*(top - here)[:2])) > 1e-6:
            phases.append(Phase("move", Mode.TAKING_OFF, target=tuple(top), speed=cfg.fly_speed, waypoint=1))
    elif kind is SegmentKind.TURN:  # yaw in place, on the ground or hovering
        assert seg.yaw is not None
        if abs(wrap_angle(seg.yaw - yaw)) > 1e-3:
            phases.append(Phase("turn", Mode.WALKING if landed else Mode.FLYING, yaw=seg.yaw, waypoint=0))
    elif kind is SegmentKind.LAND:
        above, spot = wps
        if float(np.linalg.norm(above - here)) > 1e-6:
            phases.append(Phase("move", Mode.LANDING, target=tuple(above), speed=cfg.fly_speed, waypoint=0))
        phases.append(Phase("descend", Mode.LANDING, target=(float(spot[0]), float(spot[1]), floor),
                          speed=cfg.descent_rate, waypoint=1))
        phases.append(Phase("settle", Mode.LANDING, duration=cfg.settle_time, waypoint=1))
    return phases


__all__ = ["Phase", "plan_segment", "path_length", "verb", "wrap_angle"]
