"""Search benchmark (partial): the next-viewpoint choice's time on the paper's room.

After one capture from the start (the simulator, ground-truth perception), times
:func:`planner.search_viewpoints.score_viewpoints` (every candidate's gain by ray casting, the planner's
path costs) against a named baseline in the same run: the nearest-frontier spot of
:func:`planner.viewpoint.frontier_spot` (no gain, no ray casting), and prints the ratio.

Not yet here: the random rooms, the strategies' success rate / SPL / captures / collisions.

    .venv/bin/python bench/search.py --repeat 10
"""

from __future__ import annotations

import argparse
import statistics
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--repeat", type=int, default=10, help="timed choices per method (default 10)")
    args = ap.parse_args(argv)
    if args.repeat < 1:
        ap.error("--repeat must be >= 1")
    from console.cli.search_cmd import HeadlessRig
    from console.link.world_file import paper_world
    from planner.route import Route
    from planner.search_viewpoints import score_viewpoints
    from planner.viewpoint import frontier_spot

    rig = HeadlessRig(paper_world(), Path(tempfile.mkdtemp(prefix="bench-search-")) / "s")
    try:
        assert rig.mapping.run(), rig.session.job
        s = rig.session
        grid = s.grid
        start = (2.5, 0.7, 0.0)
        cell = grid.workspace.cell_of(start)
        state = s.known_space.state()
        ours, base = [], []
        vp = None
        for _ in range(args.repeat):
            t0 = time.perf_counter()
            cost = Route(grid, start, s.weights).cost_array
            vp = score_viewpoints(state, grid, cost, cell, 0.4, limit=1)
            ours.append(time.perf_counter() - t0)
            t0 = time.perf_counter()
            route = Route(grid, start, s.weights)
            passable = __import__("numpy").isfinite(route.cost_array)
            frontier_spot(grid, passable, cell, (2.5, 6.3, 0.2))
            base.append(time.perf_counter() - t0)
        m, b = statistics.median(ours), statistics.median(base)
        print(f"paper's room, grid {grid.workspace.shape}, after one capture")
        print(f"next viewpoint (search_viewpoints): median {1000 * m:.1f} ms over {args.repeat}")
        print(f"baseline nearest frontier (viewpoint.frontier_spot): median {1000 * b:.1f} ms")
        print(f"ratio search / nearest frontier: {m / b:.1f}x; target <= 500 ms: {'met' if m <= 0.5 else 'NOT met'}")
        if vp:
            print(f"chosen: {vp[0].why}")
    finally:
        rig.close()
    return 0


if __name__ == "__main__":
    sys.exit(main())
