"""The scene graph's neighbour search finds every pair the all-pairs rules would (random scenes, brute force
as the reference), and the map fusion's candidate bound keeps every pair its exact cost admits."""

from __future__ import annotations

import math
import random

import numpy as np

from pipeline.scene import SceneObject, Source
from planner.graph_index import behind_mask, footprint_gaps, near_pairs, overlapping_bearings
from planner.object_goal import footprint
from planner.view_geometry import RobotView, polygon_gap


def _objects(n: int, side: float, seed: int, big: int = 0) -> list[SceneObject]:
    rng = random.Random(seed)
    out = []
    for i in range(n):
        w, l = rng.uniform(0.2, 1.5), rng.uniform(0.2, 1.5)
        if i < big:
            w, l = 0.3, rng.uniform(6.0, 12.0)  # walls
        out.append(SceneObject(f"o-{i}", "box", (rng.uniform(0, side), rng.uniform(0, side), 0.4), (w, 0.8, l),
                               yaw=rng.uniform(-math.pi, math.pi), source=Source(method="ground_truth")))
    return out


def test_near_pairs_hold_every_pair_within_the_gap() -> None:
    for seed, big in ((0, 0), (1, 3)):
        objs = _objects(70, 10.0, seed, big)
        feet = [footprint(o) for o in objs]
        found = set(near_pairs(objs, 1.0))
        for a in range(len(objs)):
            for b in range(a + 1, len(objs)):
                if polygon_gap(feet[a], feet[b]) <= 1.0:
                    assert (a, b) in found, (seed, a, b)


def test_batched_footprint_gaps_equal_polygon_gap() -> None:
    objs = _objects(50, 6.0, 3, 4)
    feet = [footprint(o) for o in objs]
    pairs = [(a, b) for a in range(len(objs)) for b in range(a + 1, len(objs))]
    got = footprint_gaps(np.array([feet[a] for a, _ in pairs]), np.array([feet[b] for _, b in pairs]))
    want = np.array([polygon_gap(feet[a], feet[b]) for a, b in pairs])
    assert np.allclose(got, want, atol=1e-9)
    assert (want == 0).any() and (want > 0).any()


def test_behind_candidates_and_mask_equal_the_all_pairs_rule() -> None:
    objs = _objects(120, 12.0, 4, 2)
    for robot in ((0.1, 0.1, 0.0, 0.7), (6.0, 6.0, 0.0, -2.0), (13.0, 1.0, 0.0, 3.1)):
        view = RobotView(objs, robot, 0.3, 0.25)
        over = overlapping_bearings(view.lo, view.hi, view.contains)
        for a in range(len(objs)):
            want = [b for b in range(len(objs)) if b != a and view.behind(a, b)]
            got = [over[a][k] for k in np.flatnonzero(behind_mask(view, a, over[a]))]
            assert got == want, (robot, a)


def test_fusion_candidates_cover_every_finite_cost() -> None:
    from pipeline.mapping.map_fusion import FusionConfig, _candidates, _cost, _map_cov
    from pipeline.mapping.observation_sigma import observation_sigma

    rng = random.Random(5)
    objs = _objects(60, 8.0, 6)
    objs = [o if i % 3 else SceneObject(o.id, o.label, o.position, o.size, o.yaw) for i, o in enumerate(objs)]  # pinned
    obs = [SceneObject(f"n-{i}", "box", (o.position[0] + rng.uniform(-0.5, 0.5), o.position[1], 0.4), o.size,
                       source=Source(method="fused")) for i, o in enumerate(objs[:40])]
    covs = [observation_sigma(o, None).covariance(o.position) for o in obs]
    p = [_map_cov(o, {}) for o in objs]
    cfg = FusionConfig()
    mask = _candidates(obs, covs, objs, p, cfg, {})
    finite = np.array([[math.isfinite(_cost(o, r, m, pm, cfg, {})) for m, pm in zip(objs, p)]
                       for o, r in zip(obs, covs)])
    assert finite.any() and not (finite & ~mask).any()
    assert mask.sum() < mask.size / 2  # and it leaves most pairs out
