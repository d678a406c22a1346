"""Fit the observation-sigma factors of :mod:`pipeline.mapping.observation_sigma` on the simulator tour.

Run from the repository root::

    python bench/sim_sigma_fit.py [--seed N]

Every observation of the extended tour (:data:`bench.sim_tour.EXTENDED`, 20 captures of the paper's room),
mapped with ground-truth perception and again with ``--noise`` perception (seed ``N``), is matched to
its true object (one-to-one per class, within 2 m) and its along-ray error ``e`` [m] (along the camera
ray through the mapped centre) is compared with the method's sigma ``s`` (``a + b * distance``, cut
views x3: the model before the factors). A median regression (least absolute deviations, HiGHS) of
``log((e + 0.01) / s)`` on the conditions (near, edge of the view, mostly hidden behind nearer
objects, beyond the depth model's range) gives each condition's factor as ``exp(beta)``: how much
larger the median error is when it holds, the others equal. Printed beside the constants in use, and
the baseline: the share of observations within 1 / 2 sigma with and without the factors.
"""

from __future__ import annotations

import argparse
import math
import os
import sys
from typing import Sequence

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

import numpy as np  # noqa: E402
from scipy.optimize import linear_sum_assignment, linprog  # noqa: E402

from console.link.world import paper_room  # noqa: E402
from pipeline.mapping import observation_sigma as osig  # noqa: E402
from pipeline.scene import Capture, SceneObject  # noqa: E402

CONDITIONS = ("near", "edge of the view", "hidden", "beyond depth range")
"""The regression's conditions, in the order of :func:`conditions`."""


def conditions(obj: SceneObject, capture: Capture, others: Sequence[SceneObject]) -> list[bool]:
    """Which conditions hold for one observation (the definitions of :mod:`pipeline.mapping.observation_sigma`)."""
    near = osig.surface_distance(obj, capture)
    d = osig.camera_distance(obj, capture) or 0.0
    return [near is not None and near < osig.NEAR_RANGE, osig.edge_offset(obj, capture) > osig.EDGE,
            osig.hidden_share(obj, capture, others) > osig.HIDDEN, d > osig.DEPTH_RANGE]


def observations(seed: int) -> list[tuple[list[bool], float, float, float]]:
    """``(conditions, along-ray error [m], method sigma [m], sigma with the factors [m])`` per matched observation."""
    from sim_tour import EXTENDED, shoot  # noqa: E402  (bench/ is on sys.path when run as a script)

    truth = paper_room().objects
    rows = []
    for noisy in (False, True):
        rng = np.random.default_rng(seed) if noisy else None
        for k, pose in enumerate(EXTENDED):
            scene, _ = shoot(pose, f"fit-{k}", rng)
            cap = scene.captures[0]
            cam = np.asarray(cap.camera_position, dtype=np.float64)
            for label in sorted({o.label for o in scene.objects}):
                mapped = [o for o in scene.objects if o.label == label]
                true = [t for t in truth if t.label == label]
                if not true:
                    continue
                cost = np.array([[math.dist(m.position, t.position) for t in true] for m in mapped])
                for i, j in zip(*linear_sum_assignment(cost)):
                    if cost[i, j] > 2.0:
                        continue
                    o = mapped[i]
                    p = np.asarray(o.position, dtype=np.float64)
                    u = (p - cam) / np.linalg.norm(p - cam)
                    err = abs(float((p - np.asarray(true[j].position)) @ u))
                    full = osig.observation_sigma(o, cap, scene.objects)
                    a, b = osig.METHOD_SIGMA.get(o.source.method, osig.DEFAULT_METHOD_SIGMA)
                    base = (a + b * full.distance) * (osig.CUT_FACTOR if full.cut else 1.0)
                    rows.append((conditions(o, cap, scene.objects), err, base, full.along))
    return rows


def median_regression(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Coefficients minimising ``sum |y - x @ beta|`` (a linear program)."""
    n, p = x.shape
    c = np.r_[np.zeros(p), np.ones(2 * n)]
    res = linprog(c, A_eq=np.c_[x, np.eye(n), -np.eye(n)], b_eq=y,
                  bounds=[(None, None)] * p + [(0, None)] * (2 * n), method="highs")
    return np.asarray(res.x[:p])


def main(argv: Sequence[str]) -> None:
    parser = argparse.ArgumentParser(prog="sim_sigma_fit.py", description="Fit the observation-sigma factors on "
                                     "the simulator tour (ground-truth and noisy perception).")
    parser.add_argument("--seed", type=int, default=1, help="random seed of the noisy run (default 1)")
    args = parser.parse_args(list(argv))
    rows = observations(args.seed)
    x = np.array([[1.0, *map(float, c)] for c, _, _, _ in rows])
    y = np.log(np.array([(e + 0.01) / s for _, e, s, _ in rows]))
    beta = median_regression(x, y)
    used = {"near": f"{osig.NEAR_FACTOR:.2f}", "edge of the view": "none", "hidden": f"{osig.HIDDEN_FACTOR:.2f}",
            "beyond depth range": f"distance / {osig.DEPTH_RANGE:g} m"}
    print(f"{len(rows)} observations of 40 captures (20 poses, ground truth and noise seed {args.seed})")
    for name, b, col in zip(CONDITIONS, beta[1:], x[:, 1:].T):
        print(f"  {name:20s} {int(col.sum()):4d} observations: fitted factor {math.exp(b):.2f} "
              f"(in use: {used[name]})" + ("; the rendered depth has no range limit: the factor applies to a "
                                               "depth model's readings only" if name == "beyond depth range" else ""))
    err = np.array([e for _, e, _, _ in rows])
    for name, sig in (("method sigma", np.array([s for _, _, s, _ in rows])),
                      ("with the factors", np.array([f for _, _, _, f in rows]))):
        print(f"  {name:17s}: within 1 sigma {100 * np.mean(err <= sig):.0f} %, within 2 sigma "
              f"{100 * np.mean(err <= 2 * sig):.0f} %")


if __name__ == "__main__":
    main(sys.argv[1:])
