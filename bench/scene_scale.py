"""How ``describe``, ``plan`` and the console's scene summary scale with the number of objects.

Writes a synthetic world-frame scene of N objects (catalog-sized boxes of a few labels: chairs, tables,
boxes stacked on tables, rows of chairs, at a fixed density of one object per ``--area`` square metres
on a floor that grows with N; the robot at one corner), then times, in this process:

- ``describe``: ``morphonavi describe SCENE --robot ... --bounds ...`` (scene graph + summary);
- ``plan``: ``morphonavi plan SCENE --start ... --goal ...`` (grid + A* + mission);
- ``summary``: :func:`planner.scene_graph.build_scene_graph` + :func:`planner.scene_summary.summarize`
  without reachability (what the console's scene summary computes when the map changes).

Each figure is printed as seconds and as a ratio against the named baseline, the same work on
``--baseline`` objects in the same run (near-linear work gives a ratio near N / baseline)::

    .venv/bin/python bench/scene_scale.py --objects 10000 --baseline 1000
"""

from __future__ import annotations

import argparse
import contextlib
import io
import json
import math
import random
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))


def make_scene(n: int, area: float, seed: int = 0) -> tuple[dict, float]:
    """A scene dict of ``n`` objects and the side of its square floor [m]."""
    rng = random.Random(seed)
    side = max(5.0, math.sqrt(n * area))
    objs = []
    kinds = [("chair", (0.5, 0.9, 0.5)), ("table", (0.8, 0.75, 1.4)), ("cardboard_box", (0.3, 0.3, 0.4)),
             ("plant", (0.4, 1.0, 0.4))]
    i = 0
    while len(objs) < n:
        label, (w, h, l) = kinds[i % len(kinds)]
        x, y = rng.uniform(0.5, side - 0.5), rng.uniform(0.5, side - 0.5)
        objs.append({"id": f"{label}-{i}", "label": label, "frame": "world", "position": [x, y, h / 2],
                     "size": [w, h, l], "yaw": rng.uniform(-math.pi, math.pi), "score": 0.9})
        if label == "table" and len(objs) < n:  # a box on the table
            i += 1
            objs.append({"id": f"cardboard_box-{i}", "label": "cardboard_box", "frame": "world",
                         "position": [x, y, h + 0.15], "size": [0.3, 0.3, 0.4], "yaw": 0.0, "score": 0.8})
        i += 1
    return {"version": 1, "objects": objs[:n], "captures": []}, side


def _timed(fn) -> float:
    """CPU seconds of this process for ``fn()`` (on a shared, loaded machine wall time mostly measures the
    others; ``--wall`` for wall time)."""
    clock = time.perf_counter if WALL else time.process_time
    t0 = clock()
    with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):
        rc = fn()
    if rc not in (0, None):
        raise SystemExit(f"failed with status {rc}")
    return clock() - t0


WALL = False


def measure(n: int, area: float, folder: Path, what: list[str]) -> dict[str, float]:
    from console.cli.morphonavi import main
    from pipeline.scene import scene_from_dict
    from planner.scene_graph import build_scene_graph
    from planner.scene_summary import summarize

    data, side = make_scene(n, area)
    path = folder / f"scene_{n}.json"
    path.write_text(json.dumps(data))
    bounds = f"--bounds=0,0,0,{math.ceil(side)},{math.ceil(side)},3"
    out: dict[str, float] = {}
    if "describe" in what:
        out["describe"] = _timed(lambda: main(["describe", str(path), "--robot", "0.2,0.2,0,45", bounds]))
    if "plan" in what:
        out["plan"] = _timed(lambda: main(["plan", str(path), "--start", "0.2,0.2,0", "--goal",
                                           f"{side - 0.3:.2f},{side - 0.3:.2f},0", bounds,
                                           "--out", str(folder / "m.json")]))
    if "summary" in what:
        scene = scene_from_dict(data)
        out["summary"] = _timed(lambda: summarize(build_scene_graph(scene, (0.2, 0.2, 0.0, 0.8))) and None)
    return out


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--objects", type=int, default=10000, help="objects in the measured scene (10000)")
    ap.add_argument("--baseline", type=int, default=1000, help="objects in the baseline scene (1000)")
    ap.add_argument("--area", type=float, default=4.0, help="floor area per object [m^2] (4)")
    ap.add_argument("--only", action="append", choices=("describe", "plan", "summary"),
                    help="measure only these (repeatable; default all)")
    ap.add_argument("--wall", action="store_true", help="wall-clock seconds instead of this process's CPU seconds")
    args = ap.parse_args()
    global WALL
    WALL = args.wall
    what = args.only or ["describe", "plan", "summary"]
    with tempfile.TemporaryDirectory() as tmp:
        base = measure(args.baseline, args.area, Path(tmp), what)
        big = measure(args.objects, args.area, Path(tmp), what)
    print(f"{'wall' if WALL else 'CPU'} seconds")
    print(f"{'work':10s} {args.baseline:>8d} obj [s] {args.objects:>8d} obj [s]  ratio (linear: "
          f"{args.objects / args.baseline:.0f})")
    for k in what:
        print(f"{k:10s} {base[k]:14.2f} {big[k]:14.2f}  {big[k] / max(base[k], 1e-9):6.1f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
