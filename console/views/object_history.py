"""The object details panel's account of why an object is where it is: its pin, the map fusion's
corrections and the observations fused into it (see :mod:`pipeline.mapping.map_fusion`).

Pure text: markdown lines (HTML-escaped) appended to :func:`console.views.objects_view.describe`.
Distances and sigmas in metres, yaw sigma in degrees.
"""

from __future__ import annotations

import html
import math

from pipeline.scene import SceneObject

MAX_ROWS = 12
"""Newest observations listed; older ones are counted."""


def history_lines(obj: SceneObject) -> list[str]:
    """Markdown lines: pinned state, flags, then one table row per observation (newest last)."""
    e = html.escape
    out: list[str] = []
    if obj.is_pinned:
        out += ["", "**Pinned** (placed or moved by the operator): captures never move it (Unpin lets them)"]
    for flag in obj.flags:
        out += ["", f"⚠ {e(flag)}"]
    if not obj.history:
        return out
    used = sum(1 for h in obj.history if h.used)
    out += ["", f"**Observations** ({used} of {len(obj.history)} used)", "",
            "| capture | distance | sigma along / yaw | used |", "|---|---|---|---|"]
    rows = obj.history[-MAX_ROWS:]
    if len(obj.history) > len(rows):
        out.append(f"| … {len(obj.history) - len(rows)} older | | | |")
    for h in rows:
        dist = "—" if h.distance is None else f"{h.distance:.2f} m"
        why = "yes" if h.used else f"no: {e(h.note)}" if h.note else "no"
        out.append(f"| {e(h.capture or 'before fusion')} | {dist} | {h.sigma[0]:.2f} m / "
                   f"{math.degrees(h.sigma[2]):.0f}° | {why} |")
    return out
