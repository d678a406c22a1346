"""Which map object each observation of a capture is: candidate pairs, their costs, one global assignment.

Pure helpers of :func:`pipeline.mapping.map_fusion.fuse`. World frame (z up) [m]; covariances [m^2].
Candidates share the class (catalog synonyms resolved) and are either within the distance gate (squared
Mahalanobis distance under ``FusionConfig.gate`` with both estimates' covariances), or overlap in footprint
and height, or (a partial view, cut or hidden, that matched nothing else) see the one object of its class
its viewing ray meets (:func:`~pipeline.mapping.map_extent.along_ray_match`). A view that shows an object's
top and bottom is never paired with a floor-standing object on another level of a stack
(:func:`other_level`). One global assignment (``scipy.optimize.linear_sum_assignment`` on the Mahalanobis
costs): an observation updates at most one object, an object takes at most one observation per capture.
"""

from __future__ import annotations

import math
from typing import Any, Sequence

import numpy as np
from scipy.optimize import linear_sum_assignment

from pipeline.mapping.map_estimate import history_of, map_cov, sighting_cov
from pipeline.mapping.map_extent import RAY_SIGMAS, along_ray_match
from pipeline.mapping.map_report import FusionConfig
from pipeline.mapping.map_support import FLOOR_STANDING, footprint_overlap, vertical_overlap
from pipeline.mapping.observation_sigma import ObservationSigma
from pipeline.scene import Capture, SceneObject

LEVEL_GAP = 0.75
"""Two floor-standing objects whose bottoms differ by more than this fraction of the shorter one's height
stand on different levels (their heights overlap by under a quarter of it): a box and the box on top of it.
On the simulator tour's 11 runs the bottom of a box seen with its top and bottom lies within 0.21 m of the
true one (p95 0.08 m seen whole, 0.13 m cut on the left or right; the boxes are 0.4 m high, a row); the cut
views that joined a box of another row were 0.43-0.57 m off its bottom."""


def other_level(obs: SceneObject, obj: SceneObject) -> bool:
    """Whether ``obs`` and ``obj`` (floor-standing, world frame z up [m]) stand on different levels of a stack:
    their bottoms (centre z minus half the height ``size[1]``) differ by more than :data:`LEVEL_GAP` of the
    shorter one's height. Asked only of views that show the object's top and bottom
    (:attr:`~pipeline.mapping.observation_sigma.ObservationSigma.level_seen`): a cut by the left or right
    border widens a view's gate across the ray, vertically too (x3), enough to reach the box above or below,
    though the photo measured its height."""
    if obs.label not in FLOOR_STANDING:
        return False
    gap = abs((obs.position[2] - obs.size[1] / 2) - (obj.position[2] - obj.size[1] / 2))
    return gap > LEVEL_GAP * min(obs.size[1], obj.size[1])


def class_key(label: str, catalog: Any = None) -> str:
    """The catalog class a label names (synonyms resolved), else the label normalised."""
    from pipeline.catalog import normalize_label

    if catalog is not None:
        entry = catalog.lookup(label)
        if entry is not None:
            return str(entry.name)
    return normalize_label(label)


def pair_cost(obs: SceneObject, r_obs: np.ndarray, obj: SceneObject, p_obj: np.ndarray, cfg: FusionConfig,
              captures: dict[str, Capture]) -> float:
    """Squared Mahalanobis distance of a candidate pair, ``inf`` if not a candidate; a footprint overlap
    costs the gate. ``r_obs``, ``p_obj``: the observation's and the object's 3x3 covariances [m^2]."""
    points = [(np.asarray(obj.position), p_obj)]
    if obj.is_pinned:  # also where the operator's object was seen before it was pinned
        points += [(np.asarray(s.position), sighting_cov(s)) for s in history_of(obj, captures) if s.capture]
    best = math.inf
    for pos, cov in points:
        d = np.asarray(obs.position) - pos
        best = min(best, float(d @ np.linalg.solve(cov + r_obs, d)))
    if best <= cfg.gate:
        return best
    if vertical_overlap(obs, obj) >= cfg.min_vertical and footprint_overlap(obs, obj) >= cfg.min_overlap:
        return cfg.gate
    return math.inf


def candidates(obs: Sequence[SceneObject], covs: Sequence[np.ndarray], objects: Sequence[SceneObject],
               p_objs: Sequence[np.ndarray], cfg: FusionConfig, captures: dict[str, Capture],
               sigs: Sequence[ObservationSigma] = ()) -> np.ndarray:
    """``[len(obs), len(objects)]`` mask of the pairs :func:`pair_cost` may find finite, from bounds alone
    (numpy over all pairs, so the exact cost runs on a few instead of every pair: a second drop of a
    1900-object file took 184 s): the squared Mahalanobis distance is at least ``|d|^2 / (lmax(P) +
    lmax(R))``, footprints overlap only when their centres lie within both half-diagonals, and a partial
    view's ray meets a box only within both 3D half-diagonals and its sigmas' reach. A pinned
    object is also tried where it was seen before, as :func:`pair_cost` does."""
    pts, lams, owner = [], [], []
    for j, (m, p) in enumerate(zip(objects, p_objs)):
        points = [(m.position, p)]
        if m.is_pinned:
            points += [(s.position, sighting_cov(s)) for s in history_of(m, captures) if s.capture]
        for pos, cov in points:
            pts.append(pos)
            lams.append(float(np.linalg.eigvalsh(cov).max()))
            owner.append(j)
    po = np.array([o.position for o in obs], dtype=np.float64)
    pm = np.array(pts, dtype=np.float64)
    lam_o = np.array([float(np.linalg.eigvalsh(r).max()) for r in covs])
    lam_m = np.array(lams)
    near = np.zeros((len(obs), len(pts)), dtype=bool)
    for i0 in range(0, len(obs), 256):  # in blocks: [256, n_points, 3] at most
        d = pm[None, :, :] - po[i0:i0 + 256, None, :]
        near[i0:i0 + 256] = (d * d).sum(axis=2) <= cfg.gate * (lam_o[i0:i0 + 256, None] + lam_m[None, :]) \
            * (1 + 1e-9) + 1e-12
    gate = np.zeros((len(obs), len(objects)), dtype=bool)
    np.logical_or.at(gate.T, np.array(owner), near.T)
    if cfg.min_overlap <= 0:
        return np.ones_like(gate)
    rad_o = np.array([math.hypot(o.size[0], o.size[2]) / 2 for o in obs])
    rad_m = np.array([math.hypot(m.size[0], m.size[2]) / 2 for m in objects])
    pc = np.array([m.position for m in objects], dtype=np.float64)
    dh = np.hypot(pc[None, :, 0] - po[:, None, 0], pc[None, :, 1] - po[:, None, 1])
    gate |= dh <= rad_o[:, None] + rad_m[None, :] + 1e-9
    if sigs:
        reach = np.array([np.linalg.norm(o.size) / 2 + RAY_SIGMAS * (g.along + g.across) if g.partial else -np.inf
                          for o, g in zip(obs, sigs)])
        d3 = np.linalg.norm(pc[None, :, :] - po[:, None, :], axis=2)
        gate |= d3 <= reach[:, None] + np.array([np.linalg.norm(m.size) / 2 for m in objects])[None, :]
    return gate


def assign(obs: Sequence[SceneObject], covs: Sequence[np.ndarray], objects: Sequence[SceneObject],
           cfg: FusionConfig, captures: dict[str, Capture], keys: dict[str, str],
           taken: set[int], sigs: Sequence[ObservationSigma], by_extent: set[int] | None = None) -> dict[int, int]:
    """Observation index -> object index, one global assignment over the candidate pairs; the
    observations matched only by their extent along the viewing ray are added to ``by_extent``.
    ``taken``: object indices not to assign; ``keys``: label -> class key."""
    if not obs or not objects:
        return {}
    ray_pairs: set[tuple[int, int]] = set()
    big = 1e9
    cost = np.full((len(obs), len(objects)), big)
    p_objs = [map_cov(o, captures) for o in objects]
    cand = candidates(obs, covs, objects, p_objs, cfg, captures, sigs)
    level = [bool(sigs) and sigs[i].level_seen for i in range(len(obs))]
    for i, (o, r) in enumerate(zip(obs, covs)):
        for j in np.flatnonzero(cand[i]).tolist():
            m = objects[j]
            if j in taken or keys[o.label] != keys[m.label] or (level[i] and other_level(o, m)):
                continue
            c = pair_cost(o, r, m, p_objs[j], cfg, captures)
            if math.isfinite(c):
                cost[i, j] = c
        g = sigs[i] if sigs else None
        if g is not None and g.partial and not (cost[i] < big).any():  # a partial view that matched nothing:
            ext = [j for j in np.flatnonzero(cand[i]).tolist() if j not in taken and keys[o.label] == keys[objects[j].label]
                   and not (level[i] and other_level(o, objects[j])) and along_ray_match(o, g.camera, g.across, objects[j])]
            if len(ext) == 1:  # its ray meets one object of its class (two, e.g. a line of boxes: ambiguous)
                cost[i, ext[0]] = cfg.gate
                ray_pairs.add((i, ext[0]))
    rows, cols = linear_sum_assignment(cost)
    out = {int(i): int(j) for i, j in zip(rows, cols) if cost[i, j] < big}
    if by_extent is not None:
        by_extent |= {i for i, j in out.items() if (i, j) in ray_pairs}
    return out


def assign_capture(obs: Sequence[SceneObject], sigs: Sequence[ObservationSigma], objects: Sequence[SceneObject],
                   cfg: FusionConfig, captures: dict[str, Capture], keys: dict[str, str],
                   by_extent: set[int]) -> dict[int, int]:
    """:func:`assign` for the usable observations of a capture (``sigs``: their sigmas), tried a second
    time with the wide gate when an observation whose side a nearer object of its class hides found no
    object (:attr:`~pipeline.mapping.observation_sigma.ObservationSigma.side_extent`): seen along a line of
    boxes, a view's box ends where its nearer neighbour begins, its centre is off across the ray by up
    to its extent, and the narrow gate gives its object to the neighbour's view. The second try is kept
    when it matches more observations (one box fewer mapped twice)."""
    covs = [g.gate_covariance(o.position) for o, g in zip(obs, sigs)]
    ray: set[int] = set()
    out = assign(obs, covs, objects, cfg, captures, keys, set(), sigs, ray)
    if any(i not in out and g.side_extent > 0 for i, g in enumerate(sigs)):
        wide = [g.gate_covariance(o.position, wide=True) for o, g in zip(obs, sigs)]
        ray2: set[int] = set()
        again = assign(obs, wide, objects, cfg, captures, keys, set(), sigs, ray2)
        gained = set(again) - set(out)
        if set(out) <= set(again) and gained and all(sigs[i].side_extent > 0 for i in gained):
            out, ray = again, ray2
    by_extent |= ray
    return out


__all__ = ["LEVEL_GAP", "assign", "assign_capture", "candidates", "class_key", "other_level", "pair_cost"]
