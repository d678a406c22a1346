"""Neighbour search for the scene graph: which pairs of objects can relate at all, found without
looking at every pair (near-linear in the number of objects).

World frame, z up [m]. An object's footprint lies within its *reach radius* ``hypot(w, l) / 2`` of its
centre, so two footprints can be ``gap`` apart or closer only when their centres are at most
``ra + rb + gap`` apart: :func:`near_pairs` finds those pairs with a KD-tree (``scipy.spatial.cKDTree``)
over the centres. Objects much larger than the rest (a wall, a long table) are searched on their own
so they do not widen every other object's search.

:func:`overlapping_bearings` finds the pairs whose bearing intervals, as seen from the robot, overlap
(:class:`planner.view_geometry.RobotView`): a sweep over the intervals sorted by their start, with
intervals crossing +-pi taken once more a turn away.
"""

from __future__ import annotations

import math
from typing import Any, Sequence

import numpy as np
from scipy.spatial import cKDTree

from pipeline.scene import SceneObject

BIG_FACTOR = 4.0
"""Objects whose reach radius exceeds this many times the median are searched one by one."""


def reach_radii(objs: Sequence[SceneObject]) -> np.ndarray:
    """Each object's footprint radius ``hypot(w, l) / 2`` [m]."""
    return np.array([math.hypot(o.size[0], o.size[2]) / 2 for o in objs], dtype=np.float64)


def near_pairs(objs: Sequence[SceneObject], gap: float) -> list[tuple[int, int]]:
    """Index pairs ``(a, b)``, ``a < b``, sorted, whose footprints may lie ``gap`` [m] apart or closer
    (centres at most ``ra + rb + gap`` apart horizontally); a superset of the pairs within ``gap``."""
    n = len(objs)
    if n < 2:
        return []
    xy = np.array([o.position[:2] for o in objs], dtype=np.float64)
    r = reach_radii(objs)
    big = r > max(BIG_FACTOR * float(np.median(r)), 0.5)
    small_idx = np.flatnonzero(~big)
    pairs: set[tuple[int, int]] = set()
    if len(small_idx) >= 2:
        rmax = float(r[small_idx].max())
        tree = cKDTree(xy[small_idx])
        found = tree.query_pairs(2 * rmax + gap, output_type="ndarray")
        if len(found):
            a, b = small_idx[found[:, 0]], small_idx[found[:, 1]]
            keep = np.hypot(*(xy[a] - xy[b]).T) <= r[a] + r[b] + gap
            pairs.update(zip(np.minimum(a, b)[keep].tolist(), np.maximum(a, b)[keep].tolist()))
    if big.any():
        full = cKDTree(xy)
        rall = float(r.max())
        for a in np.flatnonzero(big):
            for b in full.query_ball_point(xy[a], float(r[a]) + rall + gap):
                if b != a and math.dist(xy[a], xy[b]) <= r[a] + r[b] + gap:
                    pairs.add((min(int(a), b), max(int(a), b)))
    return sorted(pairs)


def neighbours(n: int, pairs: Sequence[tuple[int, int]]) -> list[list[int]]:
    """For each index, its partners in ``pairs``, ascending."""
    out: list[list[int]] = [[] for _ in range(n)]
    for a, b in pairs:
        out[a].append(b)
        out[b].append(a)
    for lst in out:
        lst.sort()
    return out


def overlapping_bearings(lo: np.ndarray, hi: np.ndarray, skip: np.ndarray) -> list[list[int]]:
    """For each object, the others whose bearing intervals ``[lo, hi]`` [rad] overlap its own, ascending.

    Intervals are unwrapped around their centre bearing (``lo`` may be below -pi, ``hi`` above pi);
    each is also tried a whole turn to either side. ``skip`` marks objects left out (no direction
    relations: the robot stands inside them or they span half the view).
    """
    n = len(lo)
    keep = np.flatnonzero(~skip)
    if len(keep) < 2:
        return [[] for _ in range(n)]
    starts = np.concatenate([lo[keep] + s for s in (-2 * math.pi, 0.0, 2 * math.pi)])
    ends = np.concatenate([hi[keep] + s for s in (-2 * math.pi, 0.0, 2 * math.pi)])
    ids = np.concatenate([keep, keep, keep])
    order = np.argsort(starts, kind="stable")
    starts, ends, ids = starts[order], ends[order], ids[order]
    out: list[set[int]] = [set() for _ in range(n)]
    widest = float(np.max(hi[keep] - lo[keep]))
    for a in keep:
        # candidates start before a's end and after a's start less the widest interval; of those,
        # keep the ones ending after a's start
        last = int(np.searchsorted(starts, hi[a], side="left"))
        first = int(np.searchsorted(starts, lo[a] - widest, side="left"))
        seg = slice(first, last)
        hit = ids[seg][ends[seg] > lo[a]]
        out[a].update(int(b) for b in hit if b != a)
    return [sorted(s) for s in out]


def _point_segment(p: np.ndarray, s0: np.ndarray, s1: np.ndarray) -> np.ndarray:
    """Distances ``[P]`` from points ``p [P, 2]`` to segments ``s0-s1 [P, 2]``."""
    d = s1 - s0
    t = np.clip(np.einsum("pk,pk->p", p - s0, d) / np.maximum(np.einsum("pk,pk->p", d, d), 1e-18), 0.0, 1.0)
    return np.linalg.norm(p - s0 - t[:, None] * d, axis=1)


def footprint_gaps(feet_a: np.ndarray, feet_b: np.ndarray) -> np.ndarray:
    """Distances [m] between convex quadrilaterals ``feet_a[P, 4, 2]`` and ``feet_b[P, 4, 2]`` pairwise,
    0 where they overlap or touch (separating-axis test), as :func:`planner.view_geometry.polygon_gap`
    gives for each pair, in one batch."""
    P = len(feet_a)
    if P == 0:
        return np.zeros(0)
    separated = np.zeros(P, dtype=bool)
    for poly in (feet_a, feet_b):
        edges = np.roll(poly, -1, axis=1) - poly  # [P, 4, 2]
        normals = np.stack([-edges[:, :, 1], edges[:, :, 0]], axis=-1)  # [P, 4, 2]
        pa = np.einsum("pek,pvk->pev", normals, feet_a)  # [P, 4 axes, 4 vertices]
        pb = np.einsum("pek,pvk->pev", normals, feet_b)
        scale = 1e-12 * np.maximum(np.linalg.norm(normals, axis=-1), 1e-12)  # [P, 4]
        sep = (pa.max(axis=2) < pb.min(axis=2) - scale) | (pb.max(axis=2) < pa.min(axis=2) - scale)
        separated |= sep.any(axis=1)
    out = np.zeros(P)
    idx = np.flatnonzero(separated)
    if len(idx):
        A, B = feet_a[idx], feet_b[idx]
        best = np.full(len(idx), np.inf)
        for i in range(4):
            for j in range(4):
                best = np.minimum(best, _point_segment(A[:, i], B[:, j], B[:, (j + 1) % 4]))
                best = np.minimum(best, _point_segment(B[:, i], A[:, j], A[:, (j + 1) % 4]))
        out[idx] = best
    return out


def behind_mask(view: Any, a: int, bs: Sequence[int]) -> np.ndarray:
    """``view.behind(a, b)`` for every ``b`` in ``bs`` at once (:class:`planner.view_geometry.RobotView`)."""
    b = np.asarray(bs, dtype=np.int64)
    if len(b) == 0 or view.contains[a]:
        return np.zeros(len(b), dtype=bool)
    shift = 2 * np.pi * np.round((view.bearing[b] - view.bearing[a]) / (2 * np.pi))
    blo, bhi = view.lo[b] - shift, view.hi[b] - shift
    lo, hi = np.maximum(view.lo[a], blo), np.minimum(view.hi[a], bhi)
    narrow = np.maximum(np.minimum(view.hi[a] - view.lo[a], bhi - blo), 1e-9)
    overlap = np.maximum(0.0, hi - lo) / narrow
    return (~view.contains[b] & (view.centre[a] - view.centre[b] >= view.behind_depth)
            & (view.near[a] > view.near[b]) & (overlap >= view.behind_overlap))


__all__ = ["behind_mask", "footprint_gaps", "near_pairs", "neighbours", "overlapping_bearings", "reach_radii"]
