"""One object mapped once: duplicates merged, second detections of one object not added.

Pure helpers of :func:`pipeline.mapping.map_fusion.fuse`. World frame (z up) [m]; boxes are centre,
size ``(w, h, l)`` and yaw about +z [rad] (see :mod:`pipeline.scene`).

- :func:`taken_overlap`: an observation that matched nothing may not become a new object when it is
  another view of an object a detection of the same capture updated: it overlaps that object (in
  footprint and height). A detector's second, smaller box on one chair (or a false one next to it) used
  to start a second chair that later captures then split their views between.
- :func:`merge_overlapping`: two map objects of one class that overlap in footprint and height are one
  object mapped twice (two solid objects cannot share the space): the older one (first in the map)
  keeps its id and takes the other's observations; the other is removed. Pinned objects are left alone
  (the operator placed them). The same overlap associates an observation with an object, so a map the
  fusion keeps never holds a pair an observation could not tell apart.
"""

from __future__ import annotations

import math
from typing import Any, Callable, Sequence

from pipeline.mapping.map_support import footprint_overlap, vertical_overlap
from pipeline.mapping.observation_sigma import CUT_YAW_SIGMA
from pipeline.scene import SceneObject


def overlapping(a: SceneObject, b: SceneObject, min_overlap: float, min_vertical: float) -> bool:
    """Whether the two boxes overlap in height (``>= min_vertical`` of the shorter) and footprint
    (``>= min_overlap`` of the smaller)."""
    return vertical_overlap(a, b) >= min_vertical and footprint_overlap(a, b) >= min_overlap


def _whole_views(obj: SceneObject) -> set[str]:
    """Captures with a used view of ``obj`` neither cut by the border nor occluded (its box the
    object's whole extent: a yaw sigma under :data:`~pipeline.mapping.observation_sigma.CUT_YAW_SIGMA`)."""
    return {s.capture for s in obj.history if s.used and s.capture and s.sigma[2] < CUT_YAW_SIGMA}


def _views(obj: SceneObject) -> set[str]:
    return {s.capture for s in obj.history if s.used and s.capture}


def seen_apart(a: SceneObject, b: SceneObject) -> bool:
    """Whether one capture detected both as separate whole objects: each has a used view from a capture
    in which the other has a used view, both whole there (a cut or occluded box, only part of an
    object, may be a second box on the same one)."""
    return bool((_whole_views(a) & _whole_views(b)) if (_views(a) & _views(b)) else False)


def taken_overlap(o: SceneObject, objects: Sequence[SceneObject], taken: set[int], keys: dict[str, str],
                  min_overlap: float, min_vertical: float) -> str | None:
    """Why ``o`` may not become a new object (``None``: it may).

    Args:
        o: An observation no map object took.
        objects: The map's objects.
        taken: Indices into ``objects`` that other observations of the same capture updated.
        keys: Label -> class key (synonyms resolved).
        min_overlap, min_vertical: The fusion's overlap thresholds.
    """
    for j in sorted(taken):
        m = objects[j]
        if keys[m.label] == keys[o.label] and overlapping(o, m, min_overlap, min_vertical):
            return f"overlaps {m.id}, which another detection of this capture updated: not added"
    return None


def merge_overlapping(objects: list[SceneObject], touched: set[str], keys: dict[str, str], min_overlap: float,
                      min_vertical: float, refit: Callable[[SceneObject, SceneObject], SceneObject],
                      existing: set[str] | None = None) -> list[tuple[str, str]]:
    """Merge each touched object with any unpinned object of its class it overlaps (in place).

    Only objects in ``existing`` (the map before this capture; ``None``: all) are merged: a new object
    that overlaps one another detection of its capture updated is not added in the first place
    (:func:`taken_overlap`), and two new ones are two detections. Nor are two objects that one capture
    saw apart (:func:`seen_apart`).

    The object earlier in ``objects`` keeps its id and takes the later one's observations
    (``refit(kept, removed)`` returns the merged object); the later one is removed. Repeats until no touched pair overlaps.

    Returns:
        ``(kept id, removed id)`` per merge, in order.
    """
    out: list[tuple[str, str]] = []
    changed = True
    while changed:
        changed = False
        for a in range(len(objects)):
            for b in range(a + 1, len(objects)):
                oa, ob = objects[a], objects[b]
                if oa.id not in touched and ob.id not in touched:
                    continue
                if existing is not None and (oa.id not in existing or ob.id not in existing):
                    continue
                if oa.is_pinned or ob.is_pinned or keys.get(oa.label, oa.label) != keys.get(ob.label, ob.label):
                    continue
                if not overlapping(oa, ob, min_overlap, min_vertical) or seen_apart(oa, ob):
                    continue
                objects[a] = refit(oa, ob)
                touched.add(oa.id)
                touched.discard(ob.id)
                del objects[b]
                out.append((oa.id, ob.id))
                changed = True
                break
            if changed:
                break
    return out


def check_bounds(bounds: Any) -> tuple[tuple[float, ...], tuple[float, ...]]:
    """The workspace box ``(min, max)`` as two finite 3-vectors with ``min < max`` [m] (raises
    ``ValueError`` naming ``fuse.bounds`` otherwise)."""
    try:
        lo, hi = (tuple(float(v) for v in b) for b in bounds)
    except (TypeError, ValueError):
        raise ValueError(f"fuse.bounds: must be (min, max), two 3-vectors [m], got {bounds!r}") from None
    if len(lo) != 3 or len(hi) != 3 or not all(math.isfinite(v) for v in lo + hi) \
            or not all(a < b for a, b in zip(lo, hi)):
        raise ValueError(f"fuse.bounds: must be two finite 3-vectors with min < max [m], got {bounds!r}")
    return lo, hi


__all__ = ["check_bounds", "merge_overlapping", "overlapping", "taken_overlap"]
