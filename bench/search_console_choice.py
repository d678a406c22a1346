"""The search's next-viewpoint choice inside the running console, against the scoring alone.

Starts the console (``ConsoleApp``: session, views, mission manager, the simulated robot in the paper's
room, no browser) and a step-mode search; at each proposed move (the search waits for Approve, so nothing
else runs) it times, on the console's own session state:

- ``console``: the console's choice (:func:`console.session.search_choose.choose_viewpoint`, as the
  search calls it: grids cached, the session's rule untouched);
- ``score``: :func:`planner.search_viewpoints.score_viewpoints` alone on the session's grid (the baseline:
  what the planner needs, without the console around it);
- ``unknown``: the console's choice over unknown space (the grid with unknown space allowed built aside);
- ``toggle``: the choice as the console made it before (switching the session's "plan into unknown
  space" rule to build the grid over unknown space, then back: a grid rebuild, a save and a redraw
  of every tab's grid each way), measured for a choice over unknown space.

Prints the medians [ms] and the ratios to ``score`` in the same run. Times are wall-clock [s].

    .venv/bin/python bench/search_console_choice.py            # 6 proposed moves, 3 repeats each
    .venv/bin/python bench/search_console_choice.py --moves 3 --repeat 2
"""

from __future__ import annotations

import argparse
import statistics
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))


def _until(cond, timeout: float = 600.0) -> bool:
    end = time.monotonic() + timeout
    while not cond():
        if time.monotonic() > end:
            return False
        time.sleep(0.02)
    return True


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0], formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--moves", type=int, default=6, help="proposed moves to measure at (default 6)")
    ap.add_argument("--repeat", type=int, default=3, help="timings of each method per move (default 3)")
    args = ap.parse_args(argv)
    if args.moves < 1 or args.repeat < 1:
        ap.error("--moves and --repeat: must be at least 1")

    from console.app import ConsoleApp, ConsoleConfig
    from console.link.sim import SimConfig, SimRobot
    from console.session.search import SearchConfig
    from console.session.search_choose import GridCache, choose_viewpoint
    from planner.route import Route
    from planner.search_viewpoints import score_viewpoints

    tmp = Path(tempfile.mkdtemp(prefix="bench-choice-"))
    app = ConsoleApp(ConsoleConfig(robot="sim", session_dir=tmp / "session", scene_dir=tmp / "scenes", port=0,
                                   fresh=True, record=False), link=SimRobot(config=SimConfig(time_scale=8.0)))
    app.start()
    times: dict[str, list[float]] = {"console": [], "score": [], "unknown": [], "toggle": []}
    try:
        s, job = app.session, app.search
        _until(lambda: s.robot is not None, 60)
        job.start(SearchConfig("robot dog", mode="step", max_captures=args.moves + 2, target_height=0.4))
        for move in range(args.moves):
            if not _until(lambda: job.waiting_approval or not job.running):
                print("timed out waiting for a proposed move", file=sys.stderr)
                return 1
            if not job.running:
                break
            _until(lambda: not s.run.active, 60)
            st = app.link.latest_state()
            here = tuple(float(v) for v in st.position)
            state = s.known_space.state()
            for _ in range(args.repeat):
                t = time.perf_counter()
                choose_viewpoint(s, here, 0.4, job._looked, GridCache())  # a fresh cache: the worst case
                times["console"].append(time.perf_counter() - t)
                grid = s.grid
                start = (here[0], here[1], max(here[2], grid.workspace.floor))
                cost = Route(grid, start, s.weights).cost_array
                t = time.perf_counter()
                score_viewpoints(state, grid, cost, grid.workspace.cell_of(start), 0.4, limit=3, looked=job._looked)
                times["score"].append(time.perf_counter() - t)
                t = time.perf_counter()  # now, over unknown space: the grid built aside (a fresh cache), the rule untouched
                g1 = GridCache().grid(s, "allow")
                score_viewpoints(state, g1, Route(g1, start, s.weights).cost_array, g1.workspace.cell_of(start), 0.4,
                                 seen_only=False, limit=3, looked=job._looked)
                times["unknown"].append(time.perf_counter() - t)
                t = time.perf_counter()  # before: the session's rule switched to build the unknown-space grid, and back
                s.set_plan_unknown(True)
                g2 = s.grid
                score_viewpoints(state, g2, Route(g2, start, s.weights).cost_array, g2.workspace.cell_of(start), 0.4,
                                 seen_only=False, limit=3, looked=job._looked)
                s.set_plan_unknown(False)
                times["toggle"].append(time.perf_counter() - t)
            print(f"move {move + 1}: console {1000 * times['console'][-1]:.0f} ms, score {1000 * times['score'][-1]:.0f} ms, "
                  f"over unknown {1000 * times['unknown'][-1]:.0f} ms, toggle {1000 * times['toggle'][-1]:.0f} ms", flush=True)
            job.approve()
            _until(lambda: not job.waiting_approval or not job.running)  # the approved move is under way
        job.stop()
        job.wait(120)
    finally:
        app.stop()
    med = {k: statistics.median(v) for k, v in times.items() if v}
    if "score" not in med:
        print("nothing measured", file=sys.stderr)
        return 1
    print(f"\nnext-viewpoint choice in the console (paper's room, {len(times['score'])} timings each; median):")
    for k in ("score", "console", "unknown", "toggle"):
        print(f"  {k:8s} {1000 * med[k]:7.0f} ms  x{med[k] / med['score']:.2f} of score")
    print(f"  over unknown space: before (toggle) / now (unknown) = x{med['toggle'] / med['unknown']:.2f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
