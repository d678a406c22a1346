"""One map from many captures: association, uncertainty-weighted fusion, pinned objects, support.

Pure: ``fuse(map, observations) -> (map, report)``. Every position is a box centre in the world
frame (z up) [m], yaw about +z [rad], sizes ``(w, h, l)`` [m] (see :mod:`pipeline.scene`). This module
runs the steps; the association is :mod:`pipeline.mapping.map_association`, an object's estimate
:mod:`pipeline.mapping.map_estimate`, the thresholds and the report :mod:`pipeline.mapping.map_report`.

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
   observation updates at most one object, an object takes at most one observation per capture; when a
   view whose side a nearer object of its class hides (a line of boxes seen end-on) finds no object, the
   assignment is tried again with its gate as wide as its extent across the ray
   (:func:`~pipeline.mapping.map_association.assign_capture`).
   A view that shows an object's top and bottom never joins a floor-standing object on another level of a
   stack (:func:`~pipeline.mapping.map_association.other_level`).
   An unmatched observation becomes a new object with the next id of its class, above every number the
   class has had in the map's life (:func:`~pipeline.mapping.map_extent.next_id`, the map's ``last_ids``:
   an id freed by a merge or a removal is never given again; existing ids never change), unless it overlaps (in
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
   object the capture showed (in view, unhidden, in range) and did not detect gets a miss
   (:mod:`pipeline.mapping.map_misses`); one whose existence log-odds (its detections for it, its misses
   against it: :mod:`pipeline.mapping.map_existence`) falls below 0 is removed. An update that carried a centre out of the workspace keeps it at the edge.
6. **Support** (:mod:`pipeline.mapping.map_support`): a floor-standing class rests on the floor or on the
   object under it; a floating or buried estimate is corrected and flagged; the objects stacked on a touched
   one are settled with it.
7. **Consistency** (:mod:`pipeline.mapping.map_consistency`): a capture whose objects match nothing the map
   expects in view is held back (map unchanged) unless ``check_consistency=False``.
"""

from __future__ import annotations

import math
from dataclasses import replace
from typing import Any, Sequence

from pipeline.mapping import map_consistency
from pipeline.mapping.map_association import assign, assign_capture, candidates, class_key, pair_cost
from pipeline.mapping.map_estimate import history_of, map_cov, refit, sighting
from pipeline.mapping.map_extent import id_numbers, keep_inside, next_id, outside_workspace
from pipeline.mapping.map_merge import check_bounds, merge_overlapping, taken_overlap
from pipeline.mapping.map_misses import drop_unconfirmed, record_misses
from pipeline.mapping.map_report import EXTENT_NOTE, Action, FusionConfig, FusionReport, Outcome
from pipeline.mapping.map_support import settle
from pipeline.mapping.observation_sigma import MIN_RANGE, degenerate, distance_to_box, observation_sigma
from pipeline.scene import Capture, Scene, SceneError, SceneObject

_candidates, _cost, _map_cov = candidates, pair_cost, map_cov  # the names tests/planner/test_graph_index.py uses


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
    first = assign_capture([obs[i] for i in good], [sig[i] for i in good], objects, cfg, captures, keys, ray)
    match = {good[a]: j for a, j in first.items()}
    by_extent = {good[a] for a in ray}
    second = assign([obs[i] for i in bad], [covs[i] for i in bad], objects, cfg, captures, keys, set(match.values()),
                     [sig[i] for i in bad])
    match.update({bad[a]: j for a, j in second.items()})

    if check and objects:
        expected: set[str] = set()
        for c in observations.captures:
            expected |= {o.id for o in map_consistency.expected_in_view(objects, c)}
        agreeing = sum(1 for i in good if i in match)
        held = map_consistency.disagreement(len(good), len(expected), agreeing)
        if held is not None:
            outs = tuple(Outcome(o.id, o.label, "rejected", reason="capture held back", sigma=sig[i].along,
                                 detection=i + 1, score=o.score) for i, o in enumerate(obs))
            return scene, FusionReport(outs, (), held)

    last = id_numbers(scene.objects, scene.last_ids)  # numbers the map's life has given out
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
                outcomes.append(Outcome(o.id, o.label, "rejected", None, reason, sig[i].along, i + 1, o.score))
                continue
            new_id = next_id(o.id, o.label, index, last)
            objects.append(replace(o, id=new_id, history=(sighting(o, c, others=obs),), pinned=False, flags=()))
            index[new_id] = len(objects) - 1
            touched.add(new_id)
            outcomes.append(Outcome(o.id, o.label, "added", new_id, "", sig[i].along))
            continue
        m = objects[j]
        old = tuple(s for s in history_of(m, captures) if o.source.capture is None or s.capture != o.source.capture
                    or not s.used)
        if reason is None and i in by_extent and not m.is_pinned:
            note = EXTENT_NOTE
            objects[j] = replace(m, history=old + (sighting(o, c, used=False, note=note, others=obs),))
            outcomes.append(Outcome(o.id, o.label, "recorded", m.id, note, sig[i].along))
            continue
        if reason is not None or m.is_pinned:
            note = reason or "pinned: recorded, not moved"
            objects[j] = replace(m, history=old + (sighting(o, c, used=False, note=note, others=obs),))
            action: Action = "rejected" if reason is not None else "recorded"
            outcomes.append(Outcome(o.id, o.label, action, m.id, note, sig[i].along, i + 1, o.score))
            continue
        history = old + (sighting(o, c, others=obs),)
        objects[j] = refit(m, history, o)
        touched.add(m.id)
        outcomes.append(Outcome(o.id, o.label, "updated", m.id, "", sig[i].along))

    last_ids = id_numbers(objects, last)
    merged = merge_overlapping(objects, touched, keys, cfg.min_overlap, cfg.min_vertical,
                               lambda a, b: refit(a, history_of(a, captures) + history_of(b, captures), a),
                               {o.id for o in scene.objects})
    missed = record_misses(objects, observations.captures, touched | {o.object_id for o in outcomes if o.object_id})
    removed = drop_unconfirmed(objects, captures, set(missed))
    corrections = [] if bounds is None else keep_inside(objects, touched, bounds[0], bounds[1])
    corrections += settle(objects, touched)
    known = {c.id for c in scene.captures}
    new_caps = scene.captures + tuple(c for c in observations.captures if c.id not in known)
    return Scene(objects=tuple(objects), captures=new_caps, last_ids=last_ids), FusionReport(tuple(outcomes), tuple(corrections),
                                                                          merged=tuple(merged), removed=tuple(removed))


def pinned(obj: SceneObject, value: bool = True) -> SceneObject:
    """A copy confirmed (``value``) or released by the operator."""
    return replace(obj, pinned=value)


__all__ = ["EXTENT_NOTE", "Action", "FusionConfig", "FusionReport", "Outcome", "class_key", "fuse", "pinned"]
