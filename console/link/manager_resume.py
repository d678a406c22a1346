"""Where a mission segment starts again: the parts to run from the robot's state now.

After a pause, a failure or the failsafe the robot may be elsewhere than the segment expected (on
the ground for a flight, in the air for a walk, part way along). :func:`segment_parts` turns the
segment into the link segments to run from where the robot is (recovery steps first: take off
again, land first), trimmed to the waypoints still ahead; :func:`original_index` maps progress in
a trimmed part back to the original segment's waypoints.

Positions are world frame (z up) [m].
"""

from __future__ import annotations

import math

import numpy as np

from planner.mission import MissionSegment, SegmentKind

from console.link.base import LinkError, RobotState


def segment_parts(seg: MissionSegment, st: RobotState, floor: float, next_wp: int | None, fresh: bool,
                  tolerance: float) -> list[tuple[MissionSegment, bool]] | None:
    """The segment (trimmed to ``waypoints[next_wp:]`` after an interruption) plus recovery
    steps, or None if nothing is left. A ``fresh`` segment must start where the robot is.

    Args:
        seg: The mission's segment.
        st: The robot's state now (position, landed).
        floor: Ground height [m] (the mission's lower bound).
        next_wp: Waypoint of ``seg`` to continue from after an interruption, ``None`` for all.
        fresh: The segment was not interrupted before: it must start within ``tolerance``.
        tolerance: How far the robot may be from the segment's start [m].

    Returns:
        ``[(link segment, is the segment itself (not a recovery step)), ...]`` in order, or
        ``None`` when nothing is left to do.

    Raises:
        LinkError: A fresh segment does not start where the robot is.
    """
    here = np.asarray(st.position, dtype=np.float64)
    out: list[tuple[MissionSegment, bool]] = []
    wps = [tuple(map(float, w)) for w in seg.waypoints]
    k = seg.kind
    if k in (SegmentKind.WALK, SegmentKind.FLY):
        rest = wps[max(next_wp or 1, 1):]
        if not rest:
            return None
        if k is SegmentKind.WALK and not st.landed:
            out.append((MissionSegment(SegmentKind.LAND, (tuple(here), (here[0], here[1], floor))), False))
            here = np.array([here[0], here[1], floor])
        if k is SegmentKind.FLY and st.landed:
            top = (here[0], here[1], rest[0][2])
            out.append((MissionSegment(SegmentKind.TAKEOFF, ((here[0], here[1], floor), top)), False))
            here = np.asarray(top)
        start = (float(here[0]), float(here[1]), floor if k is SegmentKind.WALK else float(here[2]))
        if fresh and math.dist(start[:2], wps[0][:2]) > tolerance:
            raise LinkError(f"the robot is {math.dist(start[:2], wps[0][:2]):.2f} m from the start of the "
                            f"{k.value} segment")
        out.append((MissionSegment(k, (start,) + tuple(rest)), True))
    elif k is SegmentKind.TAKEOFF:
        top = wps[1]
        if fresh and st.landed and math.dist(here[:2], wps[0][:2]) > tolerance:
            raise LinkError(f"the robot is {math.dist(here[:2], wps[0][:2]):.2f} m from the take-off spot")
        if st.landed:
            out.append((MissionSegment(k, ((here[0], here[1], floor), (here[0], here[1], top[2]))), True))
        else:
            out.append((MissionSegment(SegmentKind.FLY, (tuple(here), top)), True))
    elif k is SegmentKind.TURN:  # yaw in place wherever the robot is now (ground or air)
        if fresh and math.dist(here[:2], wps[0][:2]) > tolerance:
            raise LinkError(f"the robot is {math.dist(here[:2], wps[0][:2]):.2f} m from where it should turn")
        out.append((MissionSegment(k, (tuple(map(float, here)),), yaw=seg.yaw), True))
    else:  # LAND
        above, spot = wps
        if st.landed:
            if math.dist(here[:2], spot[:2]) <= tolerance:
                return None
            top = (here[0], here[1], above[2])
            out.append((MissionSegment(SegmentKind.TAKEOFF, ((here[0], here[1], floor), top)), False))
            out.append((MissionSegment(SegmentKind.FLY, (top, above)), False))
            out.append((MissionSegment(k, (above, spot)), True))
        else:
            out.append((MissionSegment(k, ((spot[0], spot[1], max(float(here[2]), spot[2])), spot)), True))
    return out


def original_index(original: MissionSegment, part: MissionSegment, next_in_part: int) -> int | None:
    """Index in the original segment of the waypoint a (trimmed) part was heading for."""
    if part.kind is not original.kind or original.kind not in (SegmentKind.WALK, SegmentKind.FLY):
        return None
    # the part is (robot position,) + original.waypoints[k:]
    k = len(original.waypoints) - (len(part.waypoints) - 1)
    return max(1, k + max(next_in_part, 1) - 1)


__all__ = ["segment_parts", "original_index"]
