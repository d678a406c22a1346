"""A job's last event already reads 'not running': the panels redraw on that event, and a search (or a look)
whose thread was still alive when it said it ended left the Find panel stuck with Pause / Stop shown and
Start disabled until the operator pressed Stop."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from console.cli.search_cmd import HeadlessRig
from console.link.world_file import paper_world
from console.session.search import SearchConfig
from console.session.session import JOB


def test_the_search_is_not_running_when_its_end_is_announced(tmp_path: Path) -> None:
    rig = HeadlessRig(paper_world(), tmp_path / "s", time_scale=8.0)
    seen: list[tuple[Any, bool, bool]] = []
    rig.session.subscribe(lambda t, p: seen.append((p, rig.search.running, rig.search.paused))
                          if t == JOB and p is not None and str(p.name).startswith("Find") else None)
    try:
        rig.search.start(SearchConfig("robot dog", max_captures=1, target_height=0.4))
        assert rig.search.wait(600)
        ends = [(running, paused) for p, running, paused in seen if not p.running]
        assert ends, [p.message for p, _, _ in seen]
        assert ends[-1] == (False, False), ends  # the end event reads: not running, not paused
        assert rig.search.result is not None and "budget" in rig.search.result.reason, rig.search.result.reason
    finally:
        rig.close()
