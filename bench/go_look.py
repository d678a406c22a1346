"""Go look benchmark: how many looks open a goal behind an obstacle, and what a suggestion costs.

For each shipped world (the paper's room, ``gap_line``, ``office``) and its goal behind the obstacles,
on the simulated robot with ground-truth perception (the console's session, capture & map, mission
runner: ``morphonavi search``'s headless rig): one Capture & map from the start, then **Go look**
(:class:`console.session.go_look.GoLookJob`) until the goal's route is planned (at most ``--max-looks``);
then the route is executed and the end checked (on the floor within 0.5 m of the goal, no refusal).

Prints per world: the looks taken, the moves' segment kinds, the final route's kinds, where the robot
ended, and the time of one look suggestion (:func:`planner.goal_look.next_look`, median of
``--repeat`` on the grid after the first capture) against the baseline in the same run: the nearest
frontier spot (:func:`planner.viewpoint.frontier_spot`, what the refusal offered before: no gain, no
ray casting), as a ratio.

    .venv/bin/python bench/go_look.py
    .venv/bin/python bench/go_look.py --worlds paper --repeat 5
"""

from __future__ import annotations

import argparse
import math
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

WORLDS = {
    "paper": (None, (2.5, 5.0)),
    "gap_line": ("examples/worlds/gap_line.world.json", (2.0, 5.0)),
    "office": ("examples/worlds/office.world.json", (0.5, 5.7)),  # behind a cabinet from the start
}
"""World name -> (world file, ``None``: the paper's room; the floor goal behind the obstacles (x, y) [m])."""


def _timing(rig, goal: tuple[float, float, float], repeat: int) -> tuple[float, float]:
    """Median seconds of a look suggestion and of the nearest-frontier baseline on the session's grid."""
    import numpy as np

    from planner.goal_look import next_look
    from planner.route import Route
    from planner.viewpoint import frontier_spot

    s = rig.session
    p = rig.robot.latest_state().position
    start = (float(p[0]), float(p[1]), max(float(p[2]), s.workspace.floor))
    grid = s.grid
    cost = Route(grid, start, s.weights).cost_array
    cell = grid.workspace.cell_of(start)
    a, b = [], []
    for _ in range(repeat):
        t = time.perf_counter()
        next_look(grid, cost, cell, goal)
        a.append(time.perf_counter() - t)
        t = time.perf_counter()
        frontier_spot(grid, np.isfinite(cost), cell, goal)
        b.append(time.perf_counter() - t)
    return statistics.median(a), statistics.median(b)


def run_world(name: str, path: str | None, goal_xy: tuple[float, float], max_looks: int, repeat: int,
              time_scale: float) -> dict:
    from console.cli.search_cmd import HeadlessRig
    from console.link.world_file import load_world, paper_world
    from console.session.go_look import GoLookJob

    world = paper_world() if path is None else load_world(Path(path))
    goal = (goal_xy[0], goal_xy[1], 0.0)
    with tempfile.TemporaryDirectory(prefix="bench-go-look-") as tmp:
        rig = HeadlessRig(world, Path(tmp) / "session", time_scale=time_scale)
        job = GoLookJob(rig.session, rig.robot, rig.mapping, rig.runner)
        s = rig.session
        try:
            rig.mapping.run_as("start")
            first = s.add_goal(goal)
            t_look, t_base = _timing(rig, goal, repeat)
            rec = {"world": name, "goal": goal_xy, "first": "planned" if first.ok else "refused", "looks": 0,
                   "moves": [], "final": "", "end": None, "ok": False, "note": "",
                   "t_look": t_look, "t_base": t_base}
            if not first.ok:
                for _ in range(max_looks):
                    job.start(goal_xy)
                    job.wait(1800)
                    if job.outcome.planned or job.outcome.next_look is None:
                        break
                rec["looks"], rec["moves"] = job.outcome.looks, list(job.outcome.kinds)
                rec["note"] = job.outcome.message
                if not job.outcome.planned:
                    return rec
            s.register()
            mission = s.build_mission()
            rec["final"] = "-".join(dict.fromkeys(mission.kinds()))
            states: list[str] = []  # this mission's states (the last look's move ended "done" too)
            s.subscribe(lambda t, p: states.append(p.state) if t == "run" else None)
            rig.runner.execute(mission)
            end = time.monotonic() + 900
            while time.monotonic() < end and not ("running" in states and states[-1] in ("done", "aborted", "failed")):
                time.sleep(0.05)
            pos = rig.robot.latest_state().position
            rec["end"] = tuple(round(float(v), 2) for v in pos)
            rec["ok"] = s.run.state == "done" and pos[2] < 0.05 and math.dist(pos[:2], goal_xy) < 0.5
            if s.run.state != "done":
                rec["note"] = f"the final route ended {s.run.state}: {s.run.message}"
            return rec
        finally:
            job.stop()
            job.wait(60)
            rig.close()


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--worlds", default=",".join(WORLDS), help=f"comma-separated, of {', '.join(WORLDS)}")
    ap.add_argument("--max-looks", type=int, default=6, help="most looks per goal (default 6)")
    ap.add_argument("--repeat", type=int, default=7, help="timings per suggestion (default 7)")
    ap.add_argument("--time-scale", type=float, default=10.0, help="simulated seconds per wall second (default 10)")
    args = ap.parse_args(argv)
    names = [n.strip() for n in args.worlds.split(",") if n.strip()]
    bad = [n for n in names if n not in WORLDS]
    if bad:
        ap.error(f"--worlds: unknown {', '.join(bad)} (known: {', '.join(WORLDS)})")
    if args.max_looks < 1 or args.repeat < 1:
        ap.error("--max-looks and --repeat: must be at least 1")
    import logging

    logging.disable(logging.WARNING)
    print(f"load average {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores")
    print(f"{'world':9} {'goal':12} {'looks':>5}  {'moves to the looks':34} {'final route':22} {'end':20} ok   "
          f"suggest [ms]  frontier baseline [ms]  ratio")
    for n in names:
        path, goal = WORLDS[n]
        r = run_world(n, path, goal, args.max_looks, args.repeat, args.time_scale)
        moves = ", ".join(r["moves"]) or "-"
        print(f"{n:9} {str(r['goal']):12} {r['looks']:5d}  {moves:34} {r['final'] or '-':22} {str(r['end']):20} "
              f"{'yes' if r['ok'] else 'NO ':4} {1000 * r['t_look']:11.0f}  {1000 * r['t_base']:22.1f}  "
              f"{r['t_look'] / max(r['t_base'], 1e-9):5.0f}x")
        if not r["ok"] and r["note"]:
            print(f"          {r['note']}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
