"""The search benchmark (bench/search.py) runs on two rooms: its table's shape, every strategy in
every run, and no collision with the hidden room."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]


def test_search_benchmark_two_rooms(tmp_path: Path) -> None:
    out = tmp_path / "search.json"
    done = subprocess.run([sys.executable, str(ROOT / "bench" / "search.py"), "--rooms", "2", "--no-paper", "--jobs", "1",
                           "--budget", "6", "--repeat", "0", "--json", str(out)],
                          capture_output=True, text=True, timeout=600, cwd=ROOT)
    assert done.returncode == 0, done.stderr
    assert "success" in done.stdout and "SPL m" in done.stdout and "/ frontier" in done.stdout
    data = json.loads(out.read_text())
    rows, records = data["rows"], data["records"]
    strategies = {"search", "frontier", "random", "manual"}
    assert {(r["run"], r["strategy"]) for r in rows} == {(run, s) for run in ("noise", "miss10") for s in strategies}
    assert len(records) == 2 * 2 * 4  # rooms x runs x strategies
    for r in rows:
        assert r["rooms"] == 2
        assert 0.0 <= r["success"] <= 1.0 and 0.0 <= r["spl_m"] <= 1.0 and 0.0 <= r["spl_cost"] <= 1.0
        assert 1.0 <= r["captures"] <= 6.0
    for rec in records:
        assert rec["collisions"] == 0, rec
        assert 1 <= rec["captures"] <= 6 and rec["path_m"] >= 0.0 and rec["reason"]
        assert rec["success"] <= rec["found"]  # success needs a found end
    assert sum(r["success"] for r in records) >= 1  # someone finds the dog in two findable rooms
