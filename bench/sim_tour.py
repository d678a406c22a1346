"""Map fusion over a tour of captures, against the hidden room (issue 12's benchmark).

Run from the repository root::

    python bench/sim_mapping.py --tour [--noise] [--seed N] [--extended]
    python bench/sim_mapping.py --tour --table 0-9    # the docs' table: ground truth and noise seeds 0-9

The simulated robot captures the paper's room from :data:`TOUR` (world frame, z up [m]): good views
and :data:`BAD` ones (a camera 0.07 m from a desk, views with objects cut by the image border);
``--extended`` goes on from :data:`SIDE_AND_FAR` (the sides and the far end of the room, among them a
desk partly hidden at the edge of the view and a close-up cut on three sides) and prints the tour's
figures and then the extended tour's. Perception is the renderer's ground truth through the real
:class:`~pipeline.mapper.Mapper`; ``--noise`` adds perception noise
(:class:`console.link.sim_perception_noise.PerceptionNoise`, as ``morphonavi console --perception
noisy``): box jitter (``N(0, 2 px)`` per side), missed detections (10 %) and a false detection in 40 %
of the captures. The captures are folded into one map by :func:`pipeline.mapping.map_fusion.fuse`
(with the workspace's bounds) and, in the same run, by the console's former merge
(``legacy_merge.py``). Printed per merge: mapped objects; true objects in view at least once that
are mapped (exactly once / twice or more / not at all); false objects; mapped objects whose centre is
outside the workspace; the 3D centre error median and 95th percentile [m] (each mapped object against
its assigned true object); floor-standing objects floating or buried by more than 0.05 m; and the
median with the bad captures left out. With ``--extended`` also the errors on the true objects both tours
map. Mapped and true objects are matched one to one per label (:func:`match`).
"""

from __future__ import annotations

import argparse
import math
import os
import sys
from typing import Callable, Sequence

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

import numpy as np  # noqa: E402
from scipy.optimize import linear_sum_assignment  # noqa: E402

from console.link.sim import SimRobot  # noqa: E402
from console.link.sim_perception_noise import PerceptionNoise  # noqa: E402
from console.link.world import paper_room  # noqa: E402
from legacy_merge import merge_observations  # noqa: E402
from pipeline.catalog import default_catalog  # noqa: E402
from pipeline.camera.geometry import Pose  # noqa: E402
from pipeline.models.ground_truth import ground_truth_bundle  # noqa: E402
from pipeline.mapping.map_fusion import fuse  # noqa: E402
from pipeline.mapping.map_support import FLOOR_ONLY  # noqa: E402
from pipeline.mapper import Mapper  # noqa: E402
from pipeline.scene import Scene  # noqa: E402
from planner.grid import Workspace  # noqa: E402

GOOD: list[tuple[float, float, float]] = [
    (2.5, 0.7, math.pi / 2), (1.0, 1.0, math.pi / 2 - 0.4), (4.2, 0.9, math.pi / 2 + 0.5),
    (2.5, 1.2, math.pi / 2), (2.5, 5.0, math.pi / 2), (0.8, 5.2, 0.3), (4.0, 5.2, math.pi / 2 + 0.9),
]
"""Robot poses ``(x [m], y [m], yaw [rad])`` of ordinary captures."""

BAD: list[tuple[float, float, float]] = [
    (0.8, 2.38, math.pi / 2),  # the camera 0.07 m in front of desk-1
    (2.5, 0.7, math.pi / 2 + 0.55), (2.5, 0.7, math.pi / 2 - 0.5),  # desks, chairs, boxes cut by the border
]
"""Robot poses of the captures that used to make the map worse."""

TOUR = GOOD[:2] + BAD[:1] + GOOD[2:4] + BAD[1:] + GOOD[4:]
"""The tour, in capture order (10 poses)."""

SIDE_AND_FAR: list[tuple[float, float, float]] = [
    (4.12, 1.12, math.pi),  # from the right wall facing -x: desk-1 partly hidden by its chair, at the image edge
    (4.2, 2.0, math.pi / 2),  # a close-up of desk-2: its box cut on three sides, 0.85 m away
    (0.4, 2.0, 0.0), (4.7, 1.6, math.pi - 0.3), (0.3, 0.3, math.pi / 4),  # the sides and a corner, in front of the line
    (2.5, 7.6, -math.pi / 2), (1.4, 7.6, -math.pi / 2 + 0.4), (4.0, 7.5, -math.pi / 2 - 0.4),  # the far end
    (0.4, 5.5, 0.0), (4.5, 5.0, math.pi),  # the sides behind the line
]
"""Robot poses from the sides and the far end of the room, captured after :data:`TOUR`."""

EXTENDED = TOUR + SIDE_AND_FAR
"""The extended tour (20 poses): :data:`TOUR`, then :data:`SIDE_AND_FAR`."""

WORKSPACE = Workspace()
"""The planning workspace of the paper's room (5 x 8 x 3 m from the origin, world frame)."""

MATCH_RADIUS = 1.0
"""A mapped object farther than this from every true object of its label is a false object [m]."""


def shoot(pose: Sequence[float], cid: str, rng: np.random.Generator | None) -> tuple[Scene, set[str]]:
    """One capture mapped with (noisy) ground-truth perception; ``(objects, ids of true objects in view)``."""
    robot = SimRobot(start=Pose.from_xyz_yaw(pose[0], pose[1], 0.0, pose[2]), manual_clock=True)
    robot.connect()
    try:
        shot = robot.capture()
    finally:
        robot.close()
    gt = shot.ground_truth
    h, w = shot.image.shape[:2]
    boxes = [v.bbox for v in gt.visible]
    labels = [v.label for v in gt.visible]
    masks = [gt.instances == v.index for v in gt.visible]
    if rng is not None:
        boxes, labels, masks = PerceptionNoise().apply(boxes, labels, masks, (w, h), rng)  # type: ignore[assignment]
    with Mapper(ground_truth_bundle(boxes, labels, masks, gt.depth), default_catalog()) as mapper:
        res = mapper.run(shot.image, shot.intrinsics, shot.mount, shot.robot_pose, capture_id=cid)
    return res.scene, {v.id for v in gt.visible}


def match(cost: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """One-to-one pairs ``(rows, cols)`` of a ``[mapped, true]`` distance matrix [m] minimising the summed
    distance, where leaving a mapped or a true object unmatched costs half :data:`MATCH_RADIUS` each (so a
    pair is made within it): a map that lacks one box of a line is not matched as a chain of boxes each
    shifted by one place to its neighbour's true box (which read a missing box as 0.4-0.9 m errors)."""
    n, k = cost.shape
    big, half = 1e6, MATCH_RADIUS / 2
    full = np.full((n + k, k + n), big)
    full[:n, :k] = np.where(cost <= MATCH_RADIUS, cost, big)
    full[np.arange(n), k + np.arange(n)] = half
    full[n + np.arange(k), np.arange(k)] = half
    full[n:, k:] = 0.0
    rows, cols = linear_sum_assignment(full)
    keep = (rows < n) & (cols < k)
    return rows[keep], cols[keep]


def evaluate(scene: Scene, in_view: set[str]) -> dict[str, float]:
    """The map against the hidden room: one-to-one assignment per label (centre distance, within
    :data:`MATCH_RADIUS`, see :func:`match`); unassigned mapped objects near a true one are duplicates,
    others false."""
    truth = paper_room().objects
    errors: list[float] = []
    by_id: dict[str, float] = {}
    dup = false = 0
    matched: set[str] = set()
    for label in sorted({o.label for o in scene.objects}):
        mapped = [o for o in scene.objects if o.label == label]
        true = [t for t in truth if t.label == label]
        if not true:
            false += len(mapped)
            continue
        cost = np.array([[math.dist(m.position, t.position) for t in true] for m in mapped])
        rows, cols = match(cost)
        used = set()
        for r, c in zip(rows, cols):
            if cost[r, c] <= MATCH_RADIUS:
                errors.append(float(cost[r, c]))
                by_id[true[c].id] = float(cost[r, c])
                matched.add(true[c].id)
                used.add(r)
        for r in range(len(mapped)):
            if r not in used:
                dup += cost[r].min() <= MATCH_RADIUS
                false += cost[r].min() > MATCH_RADIUS
    off_floor = sum(1 for o in scene.objects if o.label in FLOOR_ONLY and abs(o.position[2] - o.size[1] / 2) > 0.05)
    outside = sum(1 for o in scene.objects if not WORKSPACE.contains(o.position))
    e = np.array(errors)
    return {"mapped": len(scene.objects), "outside": outside, "in_view": len(in_view), "once": len(in_view & matched),
            "missing": len(in_view - matched), "missing_ids": sorted(in_view - matched), "duplicates": dup, "false": false,
            "median": float(np.median(e)), "p95": float(np.percentile(e, 95)), "off_floor": off_floor,
            "errors": by_id}


Merge = Callable[[Scene, Scene], "tuple[Scene, bool]"]
"""``merge(map, observations) -> (map, held back)``."""


def _fused(scene: Scene, obs: Scene) -> tuple[Scene, bool]:
    merged, report = fuse(scene, obs, bounds=(WORKSPACE.min, WORKSPACE.max))
    return merged, report.held_back is not None


def _legacy(scene: Scene, obs: Scene) -> tuple[Scene, bool]:
    return merge_observations(scene, obs)[0], False


def run(shots: Sequence[tuple[tuple[float, float, float], Scene, set[str]]], merge: Merge) -> dict[str, float]:
    scene: Scene = Scene()
    seen: set[str] = set()
    held = 0
    for _, obs, ids in shots:
        scene, was_held = merge(scene, obs)
        held += was_held
        seen |= ids
    return {**evaluate(scene, seen), "held": held}


def _seed(text: str) -> int:
    if not text.isdigit():
        raise argparse.ArgumentTypeError(f"must be a non-negative integer, got {text!r}")
    return int(text)


def _seeds(text: str) -> list[int]:
    lo, dash, hi = text.partition("-")
    try:
        seeds = list(range(int(lo), int(hi) + 1)) if dash else [int(v) for v in text.split(",")]
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be N-M or N,M,... (non-negative integers), got {text!r}") from None
    if not seeds or min(seeds) < 0:
        raise argparse.ArgumentTypeError(f"must name at least one non-negative seed, got {text!r}")
    return seeds


def table(seeds: Sequence[int]) -> None:
    """One Markdown row per tour and perception (ground truth, then noise with each seed): the map fusion's
    duplicates, objects outside the workspace, median and p95 centre error [m]; for the extended tour also
    on the true objects the tour maps too (the tour's in brackets); and the former merge of the same
    captures as the baseline (its median and the fusion's over it)."""
    print("| tour | perception | duplicates | outside | median | p95 | on the objects both tours map: median / p95 "
          "(tour's) | former merge: duplicates / outside / median (fusion / former) |")
    print("|---|---|---|---|---|---|---|---|")
    for seed in [None, *seeds]:
        rng = None if seed is None else np.random.default_rng(seed)
        shots = [(pose, *shoot(pose, f"tour-{k}", rng)) for k, pose in enumerate(EXTENDED)]
        what = "ground truth" if seed is None else f"noise, seed {seed}"
        fused = {}
        for tour, part in (("tour", shots[:len(TOUR)]), ("extended", shots)):
            r, old = run(part, _fused), run(part, _legacy)
            fused[tour] = r
            both = ""
            if tour == "extended":
                keys = sorted(set(fused["tour"]["errors"]) & set(r["errors"]))
                a = np.array([fused["tour"]["errors"][k] for k in keys])
                b = np.array([r["errors"][k] for k in keys])
                both = (f"{np.median(b):.3f} / {np.percentile(b, 95):.3f} ({np.median(a):.3f} / "
                        f"{np.percentile(a, 95):.3f}), {len(keys)} objects")
            print(f"| {tour} | {what} | {r['duplicates']} | {r['outside']} | {r['median']:.3f} | {r['p95']:.3f} | {both} | "
                  f"{old['duplicates']} / {old['outside']} / {old['median']:.3f} (x{r['median'] / old['median']:.2f}) |",
                  flush=True)


def add_tour_options(parser: argparse.ArgumentParser) -> None:
    """``--noise`` and ``--seed N`` (shared with ``bench/sim_mapping.py --tour``)."""
    parser.add_argument("--noise", action="store_true",
                        help="add perception noise: box jitter N(0, 2 px) per side, 10 %% missed detections, "
                             "a false detection in 40 %% of the captures")
    parser.add_argument("--seed", type=_seed, default=1, help="random seed of the noise (default 1)")
    parser.add_argument("--extended", action="store_true",
                        help="also capture from the sides and the far end of the room (10 more poses) and print "
                             "the extended tour's figures after the tour's")
    parser.add_argument("--table", type=_seeds, default=None, metavar="SEEDS",
                        help="print one Markdown table instead: the tour and the extended tour with ground-truth "
                             "perception and with noise for each seed of SEEDS (e.g. 0-9 or 1,2,3)")


def main(argv: Sequence[str]) -> None:
    parser = argparse.ArgumentParser(
        prog="sim_tour.py", description="Map fusion over a tour of simulator captures against the hidden room, "
                                        "beside the former merge in the same run (ground-truth perception).")
    add_tour_options(parser)
    args = parser.parse_args(list(argv))
    if args.table is not None:
        table(args.table)
        return
    noise, seed = args.noise, args.seed
    rng = np.random.default_rng(seed) if noise else None
    poses = EXTENDED if args.extended else TOUR
    shots = [(pose, *shoot(pose, f"tour-{k}", rng)) for k, pose in enumerate(poses)]
    first = evaluate(_fused(Scene(), shots[0][1])[0], shots[0][2])
    print(f"tour of {len(TOUR)} captures ({len(BAD)} bad)" + (f", extended by {len(SIDE_AND_FAR)} from the sides and "
          "the far end" if args.extended else "") + ", perception: ground truth"
          + (f" + noise (seed {seed})" if noise else "") + f"; one capture alone: median {first['median']:.3f} m")
    tours = [("tour", shots[:len(TOUR)])] + ([("extended", shots)] if args.extended else [])
    fused: dict[str, dict] = {}
    for tour, part in tours:
        good = [s for s in part if s[0] not in BAD]
        for name, merge in (("former merge", _legacy), ("map fusion  ", _fused)):
            r, g = run(part, merge), run(good, merge)
            if merge is _fused:
                fused[tour] = r
            print(f"{tour:8s} {name}: {r['mapped']} mapped; of {r['in_view']} true objects in view {r['once']} mapped "
                  f"({r['missing']} not: {', '.join(r['missing_ids'])}), {r['duplicates']} duplicates, {r['false']} false, "
                  f"{r['outside']} outside the workspace; centre error median {r['median']:.3f} m, p95 {r['p95']:.3f} m; "
                  f"{r['held']} captures held back; {r['off_floor']} floor objects off the floor > 0.05 m; "
                  f"without the bad captures median {g['median']:.3f} m (bad ones add {r['median'] - g['median']:+.3f} m)")
    if args.extended:
        print(common_line(fused["tour"]["errors"], fused["extended"]["errors"]))


def common_line(tour: dict[str, float], extended: dict[str, float]) -> str:
    """The map fusion's errors [m] on the true objects both tours map, and on those only the extended maps."""
    both = sorted(set(tour) & set(extended))
    only = sorted(set(extended) - set(tour))
    a, b = np.array([tour[k] for k in both]), np.array([extended[k] for k in both])
    c = np.array([extended[k] for k in only]) if only else np.array([math.nan])
    return (f"map fusion on the {len(both)} true objects both tours map: tour median {np.median(a):.3f} m, p95 "
            f"{np.percentile(a, 95):.3f} m; extended median {np.median(b):.3f} m, p95 {np.percentile(b, 95):.3f} m; "
            f"the {len(only)} only the extended tour maps: median {np.median(c):.3f} m")

if __name__ == "__main__":
    main(sys.argv[1:])
