"""Why an object's distance cues were down-weighted, in a few words each, for the scene file.

Each reason is a pair ``(cue, why)``: ``cue`` is ``size_prior``, ``ground_contact``, ``depth`` or
``fused`` (the fused sigma itself); ``why`` a short phrase. They come from what the ranging stage
(:class:`pipeline.ranging.ranger.Ranger`) recorded on the object:

- a cue's own ``down_weighted`` (:class:`pipeline.ranging.fusion.Cue`): a box implausibly wide for its class,
  a box cut at the top or bottom (the width used), a floor at odds with the given camera pose or uneven
  under the objects (:mod:`pipeline.ranging.photo_floor`);
- a floor contact read only as an upper bound: the bottom border cuts the box, or a nearer detection or
  the side border may hide its bottom edge (:mod:`pipeline.ranging.occlusion`);
- a cue the fusion dropped as an outlier (:func:`pipeline.ranging.fusion.fuse_cues`), and a fused sigma
  widened because the kept cues scatter more than their sigmas allow (Birge ratio above
  :data:`BIRGE_REPORTED`).
"""

from __future__ import annotations

from typing import Any

BIRGE_REPORTED = 1.2
"""A fused sigma widened by more than this factor (the cues disagree within the gate) is reported."""


def down_weight_reasons(obj: Any) -> tuple[tuple[str, str], ...]:
    """``((cue, why), ...)`` for one measured object (:class:`pipeline.ranging.ranger.MappedObject`),
    in the order: the cues' own reasons, bounds, outliers, the fused sigma; empty when nothing was
    down-weighted."""
    out: list[tuple[str, str]] = []
    for cue in getattr(obj, "cues", ()):
        if cue.down_weighted:
            out.append((cue.name, cue.down_weighted))
    if getattr(obj, "bound", None) is not None and obj.truncation.bottom:
        out.append(("ground_contact", "bottom cut by the image border: the floor there only bounds the distance"))
    hidden = getattr(obj, "contact_hidden_by", None)
    if hidden is not None:
        out.append(("ground_contact", f"its bottom edge may be hidden by the {hidden}: read as an upper bound only"))
    fusion = getattr(obj, "fusion", None)
    if fusion is not None:
        for name, why in fusion.rejected:
            out.append((name, f"not used: {why}"))
        if fusion.birge > BIRGE_REPORTED:
            out.append(("fused", f"the cues scatter more than their sigmas allow: sigma x{fusion.birge:.1f}"))
    return tuple(out)


__all__ = ["BIRGE_REPORTED", "down_weight_reasons"]
