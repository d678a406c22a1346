"""What a capture says about the pinned objects it saw again, for the capture's notice.

A pinned object (moved, typed or confirmed by the operator) is never moved by a capture
(:mod:`pipeline.mapping.map_fusion` records the view only). The notice counts those views ("1 kept
pinned") and names a pinned object the capture sees more than :data:`PIN_FAR` from where it was pinned,
so the operator can move it there or delete it (the next capture maps it again). World frame, metres.
"""

from __future__ import annotations

import math

from pipeline.mapping.map_report import EXTENT_NOTE, FusionReport
from pipeline.scene import Scene

PIN_FAR = 0.3
"""Distance [m] between a pinned object's centre and the capture's view of it above which the notice says so."""


def pinned_views(report: FusionReport) -> list[tuple[str, str]]:
    """``(observation id, pinned object id)`` for each view the fusion recorded on a pinned object."""
    return [(o.observation, o.object_id) for o in report.outcomes
            if o.action == "recorded" and o.reason != EXTENT_NOTE and o.object_id is not None]


def pinned_far(report: FusionReport, observed: Scene, mapped: Scene, far: float = PIN_FAR) -> list[str]:
    """Notes for pinned objects seen more than ``far`` [m] (centre to centre, 3-D) from where they are pinned.

    Args:
        report: The fusion's report for the capture.
        observed: The capture's own objects (ids as in ``report``'s observations).
        mapped: The map the capture was fused into (the pinned objects' positions).
        far: Threshold [m].
    """
    seen = {o.id: o for o in observed.objects}
    pinned = {o.id: o for o in mapped.objects}
    out = []
    for obs_id, oid in pinned_views(report):
        if obs_id not in seen or oid not in pinned:
            continue
        d = math.dist(seen[obs_id].position, pinned[oid].position)
        if d > far:
            out.append(f"{oid} is pinned {d:.1f} m from where this capture sees it: move it there, or delete it to let the map follow")
    return out


__all__ = ["PIN_FAR", "pinned_far", "pinned_views"]
