"""Which boxes may have their floor contact hidden by another object in front.

Ground-contact ranging (:mod:`pipeline.ranging.ground_contact`) reads the distance off the row of a box's
bottom edge. When a nearer object covers that edge (a nightstand behind the foot of a bed, a person
behind a parked car), the visible bottom is *higher* in the image than the real contact, so the ray
through it meets the floor *farther* away: the reading is no longer a measurement but an upper bound
on the distance (the real contact lies at or below the visible bottom, hence nearer). A bound is
always valid, but it holds less than a measurement, and a box's rectangle overlapping another's is
weak evidence of occlusion (a sofa's box cut by the photo's bottom border covers the table standing
beyond it without hiding its legs). So the reading becomes a bound (:func:`pipeline.ranging.fusion.fuse_cues`'s
``upper_bound``) only when both say so: a box may hide the bottom edge, *and* the reading puts the
object farther than the other cues by more than ``sigmas`` combined standard deviations (the
direction an occlusion errs in; :func:`contact_as_bound`).

Image frame: pixels, ``(x1, y1, x2, y2)``, y down.

A box ``O`` may hide the bottom edge of a box ``B`` when all of these hold:

- ``O``'s bottom is below ``B``'s by more than ``margin`` (``O`` stands nearer on the floor; with
  ``margin = max(min_px, margin_frac * height of B)``),
- ``O`` reaches above ``B``'s bottom edge by more than ``margin`` (it covers that row),
- ``O`` spans at least ``min_cover`` of ``B``'s width (an occluder covering only a part of the edge
  leaves the rest, and the box's bottom, visible).
"""

from __future__ import annotations

import math
from typing import Sequence

from pipeline.ranging.fusion import Cue, combine_log

Box = tuple[float, float, float, float]

MIN_COVER = 0.6
"""Fraction of the lower box's width an occluder must span."""
MARGIN_FRAC = 0.05
"""Vertical margin as a fraction of the box's height."""
MIN_MARGIN_PX = 2.0
"""Vertical margin at least this many pixels."""


def _check(box: Sequence[float], where: str) -> Box:
    try:
        x1, y1, x2, y2 = (float(v) for v in box)
    except (TypeError, ValueError):
        raise ValueError(f"{where}: must be 4 numbers (x1, y1, x2, y2) [px], got {box!r}") from None
    if not all(math.isfinite(v) for v in (x1, y1, x2, y2)) or x2 <= x1 or y2 <= y1:
        raise ValueError(f"{where}: must be finite with x2 > x1 and y2 > y1 [px], got {box!r}")
    return x1, y1, x2, y2


def hides_bottom(occluder: Sequence[float], box: Sequence[float], *, min_cover: float = MIN_COVER,
                 margin_frac: float = MARGIN_FRAC, min_px: float = MIN_MARGIN_PX) -> bool:
    """Whether ``occluder`` may hide the bottom edge of ``box`` (module docstring). Boxes [px].

    Raises:
        ValueError: A box is not 4 finite numbers with positive width and height.
    """
    ox1, oy1, ox2, oy2 = _check(occluder, "occluder")
    x1, y1, x2, y2 = _check(box, "box")
    margin = max(min_px, margin_frac * (y2 - y1))
    if not (oy2 > y2 + margin and oy1 < y2 - margin):
        return False
    cover = max(0.0, min(x2, ox2) - max(x1, ox1))
    return cover >= min_cover * (x2 - x1)


def bottom_occluders(boxes: Sequence[Sequence[float]], **kwargs: float) -> list[int | None]:
    """For each box, the index of one box among ``boxes`` that may hide its bottom edge (the one
    reaching lowest), or ``None``. ``kwargs`` as for :func:`hides_bottom`."""
    checked = [_check(b, f"boxes[{i}]") for i, b in enumerate(boxes)]
    out: list[int | None] = []
    for i, b in enumerate(checked):
        found = [j for j, o in enumerate(checked) if j != i and hides_bottom(o, b, **kwargs)]
        out.append(max(found, key=lambda j: checked[j][3]) if found else None)
    return out


FARTHER_SIGMAS = 1.0
"""A possibly hidden contact farther than the other cues by more than this [sigmas] becomes a bound."""


def contact_as_bound(cues: Sequence[Cue], sigmas: float = FARTHER_SIGMAS
                     ) -> tuple[list[Cue], tuple[float, float] | None]:
    """``(cues to fuse, upper bound)`` for an object whose floor contact may be hidden: the
    ``ground_contact`` cue is moved into a bound ``(distance, sigma)`` [m] when it is farther than the
    inverse-variance fusion of the other cues by more than ``sigmas`` (log distance, combined sigma; the
    others' sigma grown by their Birge ratio when they disagree among themselves, as the fusion does);
    otherwise the cues unchanged and no bound. Without other cues nothing changes."""
    gc = next((c for c in cues if c.name == "ground_contact"), None)
    others = [c for c in cues if c is not gc]
    if gc is None or not others:
        return list(cues), None
    l_o, s_o = combine_log(others)
    if len(others) >= 2:  # others that disagree among themselves know less than their sigmas say (Birge ratio)
        chi2 = sum(((math.log(c.distance) - l_o) / c.rel_sigma) ** 2 for c in others)
        s_o *= max(1.0, math.sqrt(chi2 / (len(others) - 1)))
    r = (math.log(gc.distance) - l_o) / math.sqrt(gc.rel_sigma**2 + s_o**2)
    if r <= sigmas:
        return list(cues), None
    return others, (gc.distance, gc.sigma)


def mark_hidden_contacts(objects: Sequence[object]) -> None:
    """Note on every measured object (:class:`pipeline.ranging.ranger.MappedObject`) with a floor contact a
    detection that may hide its bottom edge (:func:`bottom_occluders`), or ``"image border"`` for a box a
    side border cuts (it hides the bottom's part beyond it, often the nearest: an object off-axis); the
    fusion then may take the contact for an upper bound (:func:`contact_as_bound`)."""
    live = [o for o in objects if not o.skipped]  # type: ignore[attr-defined]
    for obj, occ in zip(live, bottom_occluders([o.detection.box for o in live])):  # type: ignore[attr-defined]
        if obj.cue("ground_contact") is not None and (occ is not None or obj.truncation.horizontal_cut):  # type: ignore[attr-defined]
            obj.contact_hidden_by = live[occ].detection.label if occ is not None else "image border"  # type: ignore[attr-defined]


__all__ = ["FARTHER_SIGMAS", "mark_hidden_contacts", "MARGIN_FRAC", "contact_as_bound", "MIN_COVER", "MIN_MARGIN_PX", "bottom_occluders", "hides_bottom"]
