"""One map from many captures: association, uncertainty-weighted fusion, pinned objects, support.

Pure: ``fuse(map, observations) -> (map, report)``. Every position is a box centre in the world
frame (z up) [m], yaw about +z [rad], sizes ``(w, h, l)`` [m] (see :mod:`pipeline.scene`).

1. **Rejection.** A view that carries no position (:func:`~pipeline.mapping.observation_sigma.degenerate`:
   camera too close, the box covering the whole image, a sliver at the border) is rejected with its
   reason; so is one whose camera stood within :data:`~pipeline.mapping.observation_sigma.MIN_RANGE` of the
   map object it matches. A rejected view is still recorded in that object's history.
2. **Association.** Candidates share the class (catalog synonyms resolved) and are either within
   the distance gate (squared Mahalanobis distance under ``FusionConfig.gate`` with both estimates'
   covariances: see :mod:`pipeline.mapping.observation_sigma`), or overlap in footprint and height, or
   (a partial view, cut or hidden, that matched nothing else) see the one object of its class its
   viewing ray meets (:func:`~pipeline.mapping.map_extent.along_ray_match`): such a view is recorded in
   the object's history, its centre (a guess from the class size) not used. One
   global assignment (``scipy.optimize.linear_sum_assignment`` on the Mahalanobis costs): an
   observation updates at most one object, an object takes at most one observation per capture.
   An unmatched observation becomes a new object with the next free id of its class
   (:func:`~pipeline.mapping.map_extent.next_id`; existing ids never change), unless it overlaps (in
   footprint and height, as above) an object of its class another observation of the capture updated
   (one object seen as two detections) or its centre is outside the workspace ``bounds``: then it is
   rejected with the reason.
3. **Fusion.** An object keeps its observations (``SceneObject.history``); its position is their
   mean weighted by ``1 / sigma^2`` (the larger of each view's along- and across-ray sigmas), its yaw their weighted
   mean modulo pi (a box is symmetric under a half turn), its size their weighted mean. A far, cut
   or occluded view weighs little; a capture seen again replaces its own earlier observation.
4. **Pinned objects** (:attr:`~pipeline.scene.SceneObject.is_pinned`: the operator moved, typed or
   confirmed them) never move: a matching observation (near the pinned place, or near any of its
   earlier observations) is recorded in its history and creates no duplicate.
5. **Duplicates** (:mod:`pipeline.mapping.map_merge`): two objects of the map before this capture, of one
   class, that now overlap in footprint and height are one object mapped twice (a false or partial
   box beside a real one started the second): the older keeps its id and takes the other's
   observations, unless one capture detected both whole, apart; pinned objects are left alone. An
   object the capture should have seen (in view, nothing mapped in front) and did not gets a miss
   (:mod:`pipeline.mapping.map_misses`): one seen by a single capture is removed after two (one if seen
   only in part). An update that carried a centre out of the workspace keeps it at the edge.
6. **Support** (:mod:`pipeline.mapping.map_support`): a floor-standing class rests on the floor or on the
   object under it; a floating or buried estimate is corrected and flagged.
7. **Consistency** (:mod:`pipeline.mapping.map_consistency`): a capture whose objects match nothing the map
   expects in view is held back (map unchanged) unless ``check_consistency=False``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Any, Literal, Sequence

import numpy as np
from scipy.optimize import linear_sum_assignment

from pipeline.mapping import map_consistency
from pipeline.mapping.map_extent import RAY_SIGMAS, along_ray_match, keep_inside, next_id, outside_workspace
from pipeline.mapping.map_merge import check_bounds, merge_overlapping, taken_overlap
from pipeline.mapping.map_misses import drop_unconfirmed, record_misses
from pipeline.mapping.map_support import footprint_overlap, supported_z, vertical_overlap
from pipeline.mapping.observation_sigma import (MIN_RANGE, ObservationSigma, degenerate, distance_to_box,
                                                observation_sigma, ray_covariance)
from pipeline.scene import Capture, Scene, SceneError, SceneObject, Sighting, Vec3

Action = Literal["added", "updated", "recorded", "rejected"]

EXTENT_NOTE = "seen in part along the viewing ray: its centre, a guess from the class size, not used"
"""Why a partial view joined by its extent does not move the object (history note, capture notice)."""


@dataclass(frozen=True)
class FusionConfig:
    """Thresholds of :func:`fuse`.

    Attributes:
        gate: Largest squared Mahalanobis distance of an association (11.34: chi-square, 3 degrees
            of freedom, 99 %).
        min_overlap: Footprint overlap (over the smaller footprint) that associates whatever the gate
            says, when the heights overlap by at least ``min_vertical``.
        min_vertical: Height-range overlap (over the shorter object) for the footprint rule.
        check_consistency: Hold back a capture that disagrees with the map everywhere.
    """

    gate: float = 11.34
    min_overlap: float = 0.3
    min_vertical: float = 0.5
    check_consistency: bool = True

    def __post_init__(self) -> None:
        for name in ("gate", "min_overlap", "min_vertical"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) or v <= 0:
                raise ValueError(f"FusionConfig.{name}: must be a finite number > 0, got {v!r}")


@dataclass(frozen=True)
class Outcome:
    """What happened to one observation.

    Attributes:
        observation: Its id in the new capture.
        label: Its class.
        action: ``added`` (a new object), ``updated`` (fused into ``object_id``), ``recorded`` (matched
            the pinned ``object_id``, or joined it by extent only: kept in its history, ``reason``
            says why) or ``rejected`` (``reason`` says why).
        object_id: The map object it became or matched, if any.
        reason: Why rejected (or recorded only).
        sigma: Its along-ray 1-sigma [m].
    """

    observation: str
    label: str
    action: Action
    object_id: str | None = None
    reason: str = ""
    sigma: float = math.nan


@dataclass(frozen=True)
class FusionReport:
    """What :func:`fuse` did: one :class:`Outcome` per observation, corrections, hold-back."""

    outcomes: tuple[Outcome, ...] = ()
    corrections: tuple[tuple[str, str], ...] = ()
    """``(object id, what was corrected)`` for objects moved onto their support."""
    held_back: str | None = None
    """Why the capture was not merged (the map is unchanged), ``None`` if it was."""
    merged: tuple[tuple[str, str], ...] = ()
    """``(kept id, removed id)``: two objects of one class that overlapped, merged (one object mapped twice)."""
    removed: tuple[tuple[str, str], ...] = ()
    """``(id, why)``: objects seen by one capture only that later captures did not see where they should have."""

    def ids(self, action: Action) -> list[str]:
        """Map object ids (``observation`` ids for ``rejected``) with this outcome."""
        return [o.object_id or o.observation for o in self.outcomes if o.action == action]

    @property
    def added(self) -> list[str]:
        return self.ids("added")

    @property
    def updated(self) -> list[str]:
        return self.ids("updated")

    @property
    def rejected(self) -> list[Outcome]:
        return [o for o in self.outcomes if o.action == "rejected"]

    @property
    def not_added(self) -> set[str]:
        """Observation ids rejected without a map object (outside the workspace, a sliver...): a caller
        that merges the capture again (the console's spawn) leaves them out."""
        return {o.observation for o in self.outcomes if o.action == "rejected" and o.object_id is None}

    def notes(self) -> list[str]:
        """Operator-facing lines: rejections, pinned objects seen again, corrections, hold-back."""
        out = [f"{o.observation} ({o.label}) not used: {o.reason}" for o in self.rejected]
        out += [f"{o.object_id} is pinned: seen again at the capture, not moved" if o.reason != EXTENT_NOTE
                else f"{o.object_id}: {o.reason}" for o in self.outcomes if o.action == "recorded"]
        out += [f"{oid}: {what}" for oid, what in self.corrections]
        out += [f"{gone} merged into {kept}: they overlapped (one object mapped twice)" for kept, gone in self.merged]
        out += [f"{oid}: {why}" for oid, why in self.removed]
        if self.held_back:
            out.insert(0, f"capture held back: {self.held_back}")
        return out


def class_key(label: str, catalog: Any = None) -> str:
    """The catalog class a label names (synonyms resolved), else the label normalised."""
    from pipeline.catalog import normalize_label

    if catalog is not None:
        entry = catalog.lookup(label)
        if entry is not None:
            return str(entry.name)
    return normalize_label(label)


# --- per-object estimates -----------------------------------------------------------------------------


def _sighting(obj: SceneObject, capture: Capture | None, used: bool = True, note: str = "",
              others: Sequence[SceneObject] = ()) -> Sighting:
    sig = observation_sigma(obj, capture, others)
    if sig.factors and not note:
        note = "sigma grown: " + ", ".join(sig.factors)
    return Sighting(capture=obj.source.capture, position=obj.position, yaw=obj.yaw, size=obj.size,
                    sigma=(sig.along, sig.across, sig.yaw), camera=sig.camera, distance=sig.distance,
                    used=used, note=note)


def _cov(s: Sighting) -> np.ndarray:
    if s.camera is None:
        return np.eye(3) * s.sigma[0] ** 2
    return ray_covariance(s.position, s.camera, s.sigma[0], s.sigma[1])


def _estimate(sightings: Sequence[Sighting]) -> tuple[np.ndarray, np.ndarray, float, Vec3]:
    """``(position, covariance, yaw, size)`` fused from the used sightings.

    The position is the mean weighted by ``1 / max(along, across)^2`` (a view is weighed by its weaker
    direction: an object cut on both sides is placed across the ray no better than its extent; a convex combination: it stays among the
    views even when their across-ray errors disagree, which the information-weighted mean of narrow
    ray covariances would not); its covariance (for the association gate) ``(sum R_k^-1)^-1``, the
    views' ray covariances combined: narrow across the rays it was seen along.
    """
    w = np.array([1.0 / max(s.sigma[0], s.sigma[1]) ** 2 for s in sightings])
    pos = (w[:, None] * np.array([s.position for s in sightings], dtype=np.float64)).sum(0) / w.sum()
    cov = np.linalg.inv(sum(np.linalg.inv(_cov(s)) for s in sightings))
    wy = np.array([1.0 / s.sigma[2] ** 2 for s in sightings])
    c2 = float(np.sum(wy * np.cos([2 * s.yaw for s in sightings])))
    s2 = float(np.sum(wy * np.sin([2 * s.yaw for s in sightings])))
    yaw = 0.5 * math.atan2(s2, c2)
    ref = sightings[int(np.argmax(wy))].yaw  # keep the heading of the best view (not its half-turn twin)
    if math.cos(yaw - ref) < 0:
        yaw += math.pi
    yaw = math.atan2(math.sin(yaw), math.cos(yaw))
    size = tuple(float(v) for v in (w[:, None] * np.array([s.size for s in sightings])).sum(0) / w.sum())
    return pos, cov, yaw, size  # type: ignore[return-value]


def _history(obj: SceneObject, captures: dict[str, Capture]) -> tuple[Sighting, ...]:
    """The object's history, or one sighting of the object as it stands when it has none."""
    if obj.history:
        return obj.history
    return (_sighting(obj, captures.get(obj.source.capture or "")),)


def _map_cov(obj: SceneObject, captures: dict[str, Capture]) -> np.ndarray:
    used = [s for s in _history(obj, captures) if s.used]
    if obj.is_pinned or not used:
        return np.eye(3) * 0.03**2
    return _estimate(used)[1]


# --- association ----------------------------------------------------------------------------------------


def _cost(obs: SceneObject, r_obs: np.ndarray, obj: SceneObject, p_obj: np.ndarray, cfg: FusionConfig,
          captures: dict[str, Capture]) -> float:
    """Squared Mahalanobis distance of a candidate pair, ``inf`` if not a candidate; a footprint overlap
    costs the gate."""
    points = [(np.asarray(obj.position), p_obj)]
    if obj.is_pinned:  # also where the operator's object was seen before it was pinned
        points += [(np.asarray(s.position), _cov(s)) for s in _history(obj, captures) if s.capture]
    best = math.inf
    for pos, cov in points:
        d = np.asarray(obs.position) - pos
        best = min(best, float(d @ np.linalg.solve(cov + r_obs, d)))
    if best <= cfg.gate:
        return best
    if vertical_overlap(obs, obj) >= cfg.min_vertical and footprint_overlap(obs, obj) >= cfg.min_overlap:
        return cfg.gate
    return math.inf


def _candidates(obs: Sequence[SceneObject], covs: Sequence[np.ndarray], objects: Sequence[SceneObject],
                p_objs: Sequence[np.ndarray], cfg: FusionConfig, captures: dict[str, Capture],
                sigs: Sequence[ObservationSigma] = ()) -> np.ndarray:
    """``[len(obs), len(objects)]`` mask of the pairs :func:`_cost` may find finite, from bounds alone
    (numpy over all pairs, so the exact cost runs on a few instead of every pair: a second drop of a
    1900-object file took 184 s): the squared Mahalanobis distance is at least ``|d|^2 / (lmax(P) +
    lmax(R))``, footprints overlap only when their centres lie within both half-diagonals, and a partial
    view's ray meets a box only within both 3D half-diagonals and its sigmas' reach. A pinned
    object is also tried where it was seen before, as :func:`_cost` does."""
    pts, lams, owner = [], [], []
    for j, (m, p) in enumerate(zip(objects, p_objs)):
        points = [(m.position, p)]
        if m.is_pinned:
            points += [(s.position, _cov(s)) for s in _history(m, captures) if s.capture]
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


def _assign(obs: Sequence[SceneObject], covs: Sequence[np.ndarray], objects: Sequence[SceneObject],
            cfg: FusionConfig, captures: dict[str, Capture], keys: dict[str, str],
            taken: set[int], sigs: Sequence[ObservationSigma], by_extent: set[int] | None = None) -> dict[int, int]:
    """Observation index -> object index, one global assignment over the candidate pairs; the
    observations matched only by their extent along the viewing ray are added to ``by_extent``."""
    if not obs or not objects:
        return {}
    ray_pairs: set[tuple[int, int]] = set()
    big = 1e9
    cost = np.full((len(obs), len(objects)), big)
    p_objs = [_map_cov(o, captures) for o in objects]
    cand = _candidates(obs, covs, objects, p_objs, cfg, captures, sigs)
    for i, (o, r) in enumerate(zip(obs, covs)):
        for j in np.flatnonzero(cand[i]).tolist():
            m = objects[j]
            if j in taken or keys[o.label] != keys[m.label]:
                continue
            c = _cost(o, r, m, p_objs[j], cfg, captures)
            if math.isfinite(c):
                cost[i, j] = c
        g = sigs[i] if sigs else None
        if g is not None and g.partial and not (cost[i] < big).any():  # a partial view that matched nothing:
            ext = [j for j in np.flatnonzero(cand[i]).tolist() if j not in taken and keys[o.label] == keys[objects[j].label]
                   and along_ray_match(o, g.camera, g.across, objects[j])]
            if len(ext) == 1:  # its ray meets one object of its class (two, e.g. a line of boxes: ambiguous)
                cost[i, ext[0]] = cfg.gate
                ray_pairs.add((i, ext[0]))
    rows, cols = linear_sum_assignment(cost)
    out = {int(i): int(j) for i, j in zip(rows, cols) if cost[i, j] < big}
    if by_extent is not None:
        by_extent |= {i for i, j in out.items() if (i, j) in ray_pairs}
    return out


# --- the fusion -------------------------------------------------------------------------------------------


def _refit(obj: SceneObject, history: tuple[Sighting, ...], newest: SceneObject) -> SceneObject:
    used = [s for s in history if s.used]
    if not used:
        return replace(obj, history=history)
    pos, _, yaw, size = _estimate(used)
    return replace(obj, position=tuple(float(v) for v in pos), yaw=yaw,  # type: ignore[arg-type]
                   size=size if not obj.size_known else obj.size, history=history,
                   score=max(obj.score, newest.score), source=newest.source, flags=())


def fuse(scene: Scene, observations: Scene, *, catalog: Any = None, config: FusionConfig | None = None,
         check_consistency: bool | None = None,
         bounds: tuple[Sequence[float], Sequence[float]] | None = None) -> tuple[Scene, FusionReport]:
    """Fold the world-frame objects of ``observations`` (one capture, usually) into ``scene``.

    Args:
        scene: The map (world frame).
        observations: Newly mapped objects and their capture(s).
        catalog: Resolves label synonyms (default: the packaged catalog).
        config: Thresholds.
        check_consistency: Override ``config.check_consistency`` (``False``: the operator accepted).
        bounds: The workspace box ``(min, max)`` (world frame [m]); an observation that would become a
            new object with its centre outside it is rejected ("... m outside the workspace: not
            added"). ``None``: not checked.

    Returns:
        ``(map, report)``; when ``report.held_back`` the map is ``scene`` unchanged.

    Raises:
        SceneError: An observation not in the world frame or with a non-finite value (names it).
        ValueError: ``bounds`` not two finite 3-vectors with ``min < max`` (names it).
    """
    cfg = config or FusionConfig()
    if bounds is not None:
        bounds = check_bounds(bounds)
    check = cfg.check_consistency if check_consistency is None else check_consistency
    if catalog is None:
        from pipeline.catalog import default_catalog

        catalog = default_catalog()
    for k, o in enumerate(observations.objects):
        if o.frame != "world":
            raise SceneError(f"objects[{k}].frame", f"must be world to fuse into the map, got {o.frame}")
        if not all(math.isfinite(v) for v in (*o.position, *o.size, o.yaw)):
            raise SceneError(f"objects[{k}]", f"{o.id}: position, size and yaw must be finite")
    captures = {c.id: c for c in scene.captures + observations.captures}
    keys = {o.label: class_key(o.label, catalog) for o in scene.objects + observations.objects}
    objects = list(scene.objects)

    def cap(o: SceneObject) -> Capture | None:
        return captures.get(o.source.capture or "")

    why = {i: degenerate(o, cap(o)) for i, o in enumerate(observations.objects)}
    good = [i for i, w in why.items() if w is None]
    bad = [i for i, w in why.items() if w is not None]
    obs = observations.objects
    sig = {i: observation_sigma(o, cap(o), obs) for i, o in enumerate(obs)}
    covs = {i: sig[i].gate_covariance(o.position) for i, o in enumerate(obs)}
    ray: set[int] = set()
    first = _assign([obs[i] for i in good], [covs[i] for i in good], objects, cfg, captures, keys, set(),
                    [sig[i] for i in good], ray)
    match = {good[a]: j for a, j in first.items()}
    by_extent = {good[a] for a in ray}
    second = _assign([obs[i] for i in bad], [covs[i] for i in bad], objects, cfg, captures, keys, set(match.values()),
                     [sig[i] for i in bad])
    match.update({bad[a]: j for a, j in second.items()})

    if check and objects:
        expected: set[str] = set()
        for c in observations.captures:
            expected |= {o.id for o in map_consistency.expected_in_view(objects, c)}
        agreeing = sum(1 for i in good if i in match)
        held = map_consistency.disagreement(len(good), len(expected), agreeing)
        if held is not None:
            outs = tuple(Outcome(o.id, o.label, "rejected", reason="capture held back", sigma=sig[i].along)
                         for i, o in enumerate(obs))
            return scene, FusionReport(outs, (), held)

    outcomes: list[Outcome] = []
    touched: set[str] = set()
    index = {o.id: n for n, o in enumerate(objects)}
    for i, o in enumerate(obs):
        c = cap(o)
        j = match.get(i)
        reason = why[i]
        if j is not None and reason is None and c is not None and c.camera_position is not None:
            m = objects[j]
            near = distance_to_box(c.camera_position, m.position, m.size, m.yaw)
            if near < MIN_RANGE:
                reason = f"camera too close: {near:.2f} m from {m.id} (under {MIN_RANGE:g} m)"
        if j is None:
            taken = set(match.values())
            reason = reason or taken_overlap(o, objects, taken, keys, cfg.min_overlap, cfg.min_vertical)
            if reason is None and bounds is not None:
                out, reach = outside_workspace(o, bounds[0], bounds[1])
                if out:
                    reason = f"{reach:.1f} m outside the workspace: not added"
            if reason is not None:
                outcomes.append(Outcome(o.id, o.label, "rejected", None, reason, sig[i].along))
                continue
            new_id = next_id(o.id, o.label, index)
            objects.append(replace(o, id=new_id, history=(_sighting(o, c, others=obs),), pinned=False, flags=()))
            index[new_id] = len(objects) - 1
            touched.add(new_id)
            outcomes.append(Outcome(o.id, o.label, "added", new_id, "", sig[i].along))
            continue
        m = objects[j]
        old = tuple(s for s in _history(m, captures) if o.source.capture is None or s.capture != o.source.capture
                    or not s.used)
        if reason is None and i in by_extent and not m.is_pinned:
            note = EXTENT_NOTE
            objects[j] = replace(m, history=old + (_sighting(o, c, used=False, note=note, others=obs),))
            outcomes.append(Outcome(o.id, o.label, "recorded", m.id, note, sig[i].along))
            continue
        if reason is not None or m.is_pinned:
            note = reason or "pinned: recorded, not moved"
            objects[j] = replace(m, history=old + (_sighting(o, c, used=False, note=note, others=obs),))
            action: Action = "rejected" if reason is not None else "recorded"
            outcomes.append(Outcome(o.id, o.label, action, m.id, note, sig[i].along))
            continue
        history = old + (_sighting(o, c, others=obs),)
        objects[j] = _refit(m, history, o)
        touched.add(m.id)
        outcomes.append(Outcome(o.id, o.label, "updated", m.id, "", sig[i].along))

    merged = merge_overlapping(objects, touched, keys, cfg.min_overlap, cfg.min_vertical,
                               lambda a, b: _refit(a, _history(a, captures) + _history(b, captures), a),
                               {o.id for o in scene.objects})
    record_misses(objects, observations.captures, touched | {o.object_id for o in outcomes if o.object_id})
    removed = drop_unconfirmed(objects)
    corrections = [] if bounds is None else keep_inside(objects, touched, bounds[0], bounds[1])
    corrections += _support(objects, touched)
    known = {c.id for c in scene.captures}
    new_caps = scene.captures + tuple(c for c in observations.captures if c.id not in known)
    return Scene(objects=tuple(objects), captures=new_caps), FusionReport(tuple(outcomes), tuple(corrections),
                                                                          merged=tuple(merged), removed=tuple(removed))


def _support(objects: list[SceneObject], touched: set[str]) -> list[tuple[str, str]]:
    """Put the touched floor-standing objects on their support (lowest first); flag each correction."""
    out: list[tuple[str, str]] = []
    order = sorted((n for n, o in enumerate(objects) if o.id in touched and not o.is_pinned),
                   key=lambda n: objects[n].position[2] - objects[n].size[1] / 2)
    for n in order:
        o = objects[n]
        fix = supported_z(o, objects)
        if fix is None:
            continue
        z, what = fix
        objects[n] = replace(o, position=(o.position[0], o.position[1], z), flags=o.flags + (what,))
        out.append((o.id, what))
    return out


def pinned(obj: SceneObject, value: bool = True) -> SceneObject:
    """A copy confirmed (``value``) or released by the operator."""
    return replace(obj, pinned=value)
