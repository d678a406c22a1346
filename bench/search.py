"""Search benchmark: the product's search against three baselines on seeded random rooms and the paper's room.

Rooms (``bench/search_rooms.py``): the paper's room and ``--rooms`` random ones, 5-12 m a side,
a line of boxes across (wall to wall, with gaps wider or narrower than the robot, an open end, or
two lines), catalog furniture, a robot dog hidden behind the line (in half of them also behind
furniture); some reachable only by flying, a few where it cannot be found (sealed in boxes up to
the ceiling, or absent). Each room is searched by every strategy (``bench/search_strategies.py``:
``search`` the product's viewpoint choice, ``frontier`` nearest frontier on the floor only,
``random`` random viewpoints, ``manual`` the paper's capture / farthest seen-free point / capture)
in the same loop (``bench/search_sim.py``: the console's search loop on a fast simulated robot),
twice: ground-truth perception with noise (``noise``) and again with 10 % missed detections
(``miss10``), with a budget of ``--budget`` captures.

Per strategy and run: ``success`` over the rooms where the target can be reached (the search ends
with the robot on the floor within 1 m of the target's footprint); ``SPL`` (success weighted by
path length: shortest / max(taken, shortest), the shortest being the planner's path on the true
room from the start to such a spot) in metres and in planner cost; captures, the robot's time
and the computer's time per search; the next-viewpoint choice's time; ``collisions`` (the
simulator's body touching a true object on a route: must be 0); and the not-found ends: correct
(the target could not be reached) and incorrect (it could: a miss). Ratios are against ``frontier``
in the same run. The product's next-viewpoint time on the paper's room is also measured in the
console's own session (``--repeat``), against the nearest-frontier spot.

    .venv/bin/python bench/search.py                  # 50 rooms + the paper's, both runs, 2 processes
    .venv/bin/python bench/search.py --rooms 5 --jobs 1
"""

from __future__ import annotations

import argparse
import json
import logging
import math
import multiprocessing
import os
import statistics
import sys
import tempfile
import time
from pathlib import Path

_HERE = os.path.dirname(os.path.abspath(__file__))
# bench/planner.py would shadow the planner package: keep this folder off sys.path
sys.path[:] = [p for p in sys.path if os.path.abspath(p or os.getcwd()) != _HERE]
sys.path.insert(0, os.path.dirname(_HERE))

RUNS = {"noise": 0.0, "miss10": 0.1}
"""Perception runs: name -> chance of missing an object in view per capture."""


def run_room(task: tuple) -> list[dict]:
    """Every strategy and run in one room (a worker's job): one record per search."""
    import numpy as np

    from bench.search_rooms import paper_search_room, random_search_room, truth
    from bench.search_sim import SimSearch
    from bench.search_strategies import STRATEGIES
    from console.link.render import SceneRenderer
    from pipeline.scene import Scene

    seed, n, runs, strategies, budget, scale, noise_seed = task
    room = paper_search_room() if n < 0 else random_search_room(seed, n)
    tr = truth(room)
    renderer = SceneRenderer(Scene(objects=room.objects), room.shell)
    out = []
    for r, run in enumerate(runs):
        for s, name in enumerate(strategies):
            rng = np.random.default_rng([seed, n + 1, r, s] + ([noise_seed] if noise_seed else []))
            sim = SimSearch(room, renderer, STRATEGIES[name], rng, RUNS[run], budget, scale, looked=name == "search")
            o = sim.run()
            out.append({"room": room.name, "kind": room.kind, "run": run, "strategy": name, "findable": tr.findable,
                        "walk": tr.walk, "shortest_m": tr.shortest_m, "shortest_cost": tr.shortest_cost,
                        "found": o.found, "success": o.success, "reason": o.reason, "distance": o.distance,
                        "final": [round(float(v), 3) for v in o.final], "path_m": float(o.path_m),
                        "path_cost": float(o.path_cost), "captures": o.captures, "robot_s": float(o.robot_s),
                        "wall_s": o.wall_s, "choose_s": [float(v) for v in o.choose_s], "collisions": o.collisions,
                        "refused": o.moves_refused, "contacts": o.contacts, "steps": sim.steps,
                        "target_views": o.target_views})
    return out


def _spl(r: dict, key: str, short: str) -> float:
    if not r["success"]:
        return 0.0
    return r[short] / max(r[key], r[short])


def aggregate(records: list[dict], runs: list[str], strategies: list[str]) -> list[dict]:
    """One row per (run, strategy): the benchmark's figures."""
    rows = []
    for run in runs:
        for name in strategies:
            rs = [r for r in records if r["run"] == run and r["strategy"] == name]
            fin = [r for r in rs if r["findable"]]
            unf = [r for r in rs if not r["findable"]]
            choose = [v for r in rs for v in r["choose_s"]]
            paper = [v for r in rs if r["room"] == "paper" for v in r["choose_s"]]
            rows.append({
                "run": run, "strategy": name, "rooms": len(rs), "findable": len(fin),
                "success": sum(r["success"] for r in fin) / len(fin) if fin else math.nan,
                "spl_m": statistics.fmean(_spl(r, "path_m", "shortest_m") for r in fin) if fin else math.nan,
                "spl_cost": statistics.fmean(_spl(r, "path_cost", "shortest_cost") for r in fin) if fin else math.nan,
                "captures": statistics.fmean(r["captures"] for r in rs), "robot_s": statistics.fmean(r["robot_s"] for r in rs),
                "wall_s": statistics.fmean(r["wall_s"] for r in rs),
                "choose_ms": 1000 * statistics.median(choose) if choose else math.nan,
                "choose_max_ms": 1000 * max(choose) if choose else math.nan,
                "paper_choose_ms": 1000 * statistics.median(paper) if paper else math.nan,
                "collisions": sum(r["collisions"] for r in rs),
                "notfound_correct": sum(not r["found"] for r in unf),
                "found_wrong": sum(r["found"] for r in unf),
                "notfound_incorrect": sum(not r["success"] for r in fin),
                "walk_success": _share([r for r in fin if r["walk"]]),
                "fly_success": _share([r for r in fin if not r["walk"]]),
            })
    return rows


def _share(rs: list[dict]) -> float:
    return sum(r["success"] for r in rs) / len(rs) if rs else math.nan


def print_table(rows: list[dict], base: str) -> None:
    head = (f"{'run':7} {'strategy':8} {'success':>8} {'walk':>5} {'fly':>5} {'SPL m':>6} {'SPL cost':>8} {'captures':>8} "
            f"{'robot s':>7} {'cpu s':>6} {'choose ms':>9} {'coll':>4} {'nf ok':>5} {'nf miss':>7}")
    print(head)
    print("-" * len(head))
    for r in rows:
        print(f"{r['run']:7} {r['strategy']:8} {100 * r['success']:7.1f}% {100 * r['walk_success']:4.0f}% "
              f"{100 * r['fly_success']:4.0f}% {r['spl_m']:6.3f} {r['spl_cost']:8.3f} {r['captures']:8.1f} "
              f"{r['robot_s']:7.0f} {r['wall_s']:6.1f} {r['choose_ms']:9.0f} {r['collisions']:4d} "
              f"{r['notfound_correct']:2d}/{r['rooms'] - r['findable']:<2d} {r['notfound_incorrect']:4d}/{r['findable']:<2d}")
    print()
    for run in dict.fromkeys(r["run"] for r in rows):
        b = next((r for r in rows if r["run"] == run and r["strategy"] == base), None)
        if b is None:
            continue
        for r in rows:
            if r["run"] != run or r["strategy"] == base:
                continue
            ratio = [(k, r[k] / b[k] if b[k] else math.inf) for k in ("success", "spl_m", "spl_cost")]
            print(f"{run:7} {r['strategy']:8} / {base}: " + ", ".join(f"{k} {v:.2f}x" for k, v in ratio))


def choice_time(repeat: int) -> tuple[float, float, str]:
    """The product's next-viewpoint choice in the console's own session on the paper's room (after one
    capture from the start, the simulator's ground truth) against the nearest-frontier spot:
    ``(median s, baseline median s, the choice)``."""
    import numpy as np

    from console.cli.search_cmd import HeadlessRig
    from console.link.world_file import paper_world
    from planner.route import Route
    from planner.search_viewpoints import score_viewpoints
    from planner.viewpoint import frontier_spot

    logging.getLogger("console").setLevel(logging.ERROR)  # the session's notices are not the benchmark's output
    rig = HeadlessRig(paper_world(), Path(tempfile.mkdtemp(prefix="bench-search-")) / "s")
    try:
        if not rig.mapping.run():
            raise RuntimeError(f"the first capture failed: {rig.session.job}")
        s = rig.session
        grid = s.grid
        start = (2.5, 0.7, 0.0)
        cell = grid.workspace.cell_of(start)
        state = s.known_space.state()
        ours, base = [], []
        vp = []
        for _ in range(repeat):
            t0 = time.perf_counter()
            cost = Route(grid, start, s.weights).cost_array
            vp = score_viewpoints(state, grid, cost, cell, 0.4, limit=1)
            ours.append(time.perf_counter() - t0)
            t0 = time.perf_counter()
            passable = np.isfinite(Route(grid, start, s.weights).cost_array)
            frontier_spot(grid, passable, cell, (2.5, 6.3, 0.2))
            base.append(time.perf_counter() - t0)
        return statistics.median(ours), statistics.median(base), vp[0].why if vp else "none"
    finally:
        rig.close()


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0], formatter_class=argparse.RawDescriptionHelpFormatter,
                                 epilog="Ratios are against the nearest-frontier baseline in the same run.")
    ap.add_argument("--rooms", type=int, default=50, help="random rooms besides the paper's (default 50)")
    ap.add_argument("--seed", type=int, default=19, help="random seed (default 19)")
    ap.add_argument("--noise-seed", type=int, default=0,
                    help="another draw of the perception noise and misses on the same rooms (default 0)")
    ap.add_argument("--budget", type=int, default=12, help="capture budget per search (default 12)")
    ap.add_argument("--jobs", type=int, default=2, help="worker processes (default 2)")
    ap.add_argument("--image-scale", type=float, default=0.5,
                    help="rendered image size against the simulated 640 x 480 camera, same field of view (default "
                         "0.5: 320 x 240; objects must cover the same share of the image)")
    ap.add_argument("--runs", default="noise,miss10", help="perception runs, comma-separated (default noise,miss10)")
    ap.add_argument("--strategies", default="search,frontier,random,manual",
                    help="strategies, comma-separated (default search,frontier,random,manual)")
    ap.add_argument("--no-paper", action="store_true", help="leave the paper's room out")
    ap.add_argument("--repeat", type=int, default=10,
                    help="timed next-viewpoint choices in the console's session on the paper's room (0: skip)")
    ap.add_argument("--json", default=None, metavar="FILE", help="write the rows and every search's record here")
    args = ap.parse_args(argv)
    from bench.search_strategies import BASELINE, STRATEGIES

    runs = [r.strip() for r in args.runs.split(",") if r.strip()]
    strategies = [s.strip() for s in args.strategies.split(",") if s.strip()]
    if args.rooms < 0:
        ap.error("--rooms must be >= 0")
    if args.noise_seed < 0:
        ap.error("--noise-seed must be >= 0")
    if not 1 <= args.budget <= 200:
        ap.error("--budget must be within 1..200")
    if args.jobs < 1:
        ap.error("--jobs must be >= 1")
    if not (math.isfinite(args.image_scale) and 0.1 <= args.image_scale <= 1.0):
        ap.error("--image-scale must be within 0.1..1")
    if args.repeat < 0:
        ap.error("--repeat must be >= 0")
    for r in runs:
        if r not in RUNS:
            ap.error(f"--runs: unknown run {r!r} (one of {', '.join(RUNS)})")
    for s in strategies:
        if s not in STRATEGIES:
            ap.error(f"--strategies: unknown strategy {s!r} (one of {', '.join(STRATEGIES)})")
    if not runs or not strategies:
        ap.error("--runs and --strategies need at least one name")
    rooms = ([] if args.no_paper else [-1]) + list(range(args.rooms))
    if not rooms:
        ap.error("no rooms: give --rooms or leave out --no-paper")
    tasks = [(args.seed, n, runs, strategies, args.budget, args.image_scale, args.noise_seed) for n in rooms]
    t0 = time.perf_counter()
    records: list[dict] = []
    def done(part: list[dict]) -> None:
        records.extend(part)
        print(f"{part[0]['room']} searched ({len(records) // len(part)} of {len(tasks)} rooms, "
              f"{time.perf_counter() - t0:.0f} s)", file=sys.stderr, flush=True)

    if args.jobs == 1:
        for t in tasks:
            done(run_room(t))
    else:
        with multiprocessing.get_context("fork").Pool(args.jobs) as pool:
            for part in pool.imap_unordered(run_room, tasks):
                done(part)
    total = time.perf_counter() - t0
    print(f"{len(rooms)} rooms ({'the paper' + chr(39) + 's + ' if not args.no_paper else ''}{args.rooms} random, "
          f"seed {args.seed}, noise seed {args.noise_seed}); budget {args.budget} captures; images {args.image_scale:g} x 640 x 480; "
          f"{args.jobs} process{'es' if args.jobs > 1 else ''}; {total:.0f} s; load average "
          f"{os.getloadavg()[0]:.1f} at the end")
    rows = aggregate(records, runs, strategies)
    print("success over the rooms where the target can be reached (walk: reachable walking, fly: only flying); "
          "nf ok: not-found ends where it cannot be; nf miss: findable rooms not solved")
    print_table(rows, BASELINE)
    timing = None
    if args.json:  # the records first: the console's timing below starts a whole session
        Path(args.json).write_text(json.dumps({"rows": rows, "records": records, "timing": timing,
                                               "config": vars(args), "seconds": total}, indent=1) + "\n")
    if args.repeat:
        try:
            m, b, why = choice_time(args.repeat)
        except Exception as exc:  # the table above stands; say why the timing is missing
            print(f"next viewpoint in the console's session: not measured ({type(exc).__name__}: {exc})")
        else:
            timing = {"median_s": m, "baseline_median_s": b, "choice": why}
            print(f"next viewpoint in the console's session, paper's room after one capture: median {1000 * m:.0f} ms "
                  f"over {args.repeat} (nearest-frontier spot {1000 * b:.0f} ms, ratio {m / b:.1f}x); target <= 500 ms: "
                  f"{'met' if m <= 0.5 else 'NOT met'}")
    prod = [r for r in rows if r["strategy"] == "search"]
    base = {r["run"]: r for r in rows if r["strategy"] == BASELINE}
    for r in prod:
        b = base.get(r["run"])
        if b is None:  # the baseline not run (--strategies): no ratio, no verdict
            spl = f"SPL not compared ({BASELINE} not run)"
        else:
            ratio = r["spl_cost"] / b["spl_cost"] if b["spl_cost"] else math.inf
            ratio_m = r["spl_m"] / b["spl_m"] if b["spl_m"] else math.inf
            spl = (f"SPL {ratio_m:.2f}x (m) / {ratio:.2f}x (cost) the frontier's (>= 1.3x: "
                   f"{'met' if min(ratio, ratio_m) >= 1.3 else 'NOT met'})")
        print(f"targets ({r['run']}): success {100 * r['success']:.1f}% (>= 95 %: {'met' if r['success'] >= 0.95 else 'NOT met'}); "
              f"{spl}; collisions {r['collisions']} "
              f"({'met' if r['collisions'] == 0 else 'NOT met'}); paper's room choice median {r['paper_choose_ms']:.0f} ms")
    if args.json:
        Path(args.json).write_text(json.dumps({"rows": rows, "records": records, "timing": timing,
                                               "config": vars(args), "seconds": total}, indent=1) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
