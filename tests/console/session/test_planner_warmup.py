"""The planner's compiled kernels are made ready at console start (console/session/planner_warmup.py), so an
Add goal pressed right after the page loads is planned at once instead of waiting, silently, for numba.

Checked in a fresh Python process (this one may have planned already): before the warm-up no kernel is loaded,
after it every kernel a goal's plan uses is (both heuristics)."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[3]
KERNELS = {"planner.astar_kernel": ["_search", "_rekey", "_trace"],
           "planner.heuristic": ["_grid_scan", "_dijkstra2d", "_bottleneck", "_entry_distance", "_entry_rest"]}

SCRIPT = """
import importlib, json
from console.session.planner_warmup import warm_up
kernels = %r
def loaded():
    return {f"{m}.{n}": len(getattr(importlib.import_module(m), n).signatures) for m, ns in kernels.items() for n in ns}
before = loaded()
warm_up()
print(json.dumps({"before": before, "after": loaded()}))
"""


def test_the_warm_up_loads_every_kernel_a_plan_uses() -> None:
    out = subprocess.run([sys.executable, "-c", SCRIPT % (KERNELS,)], cwd=REPO, capture_output=True, text=True,
                         timeout=900)
    assert out.returncode == 0, out.stderr
    got = json.loads(out.stdout.strip().splitlines()[-1])
    assert set(got["before"].values()) == {0}, got["before"]  # nothing loaded before: the check can fail
    assert all(n >= 1 for n in got["after"].values()), got["after"]

