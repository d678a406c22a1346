"""Why searches failed: the search benchmark's records (``bench/search.py --json FILE``) sorted into kinds.

Every search of a room where the target can be reached that did not end beside it gets one kind, and
every collision one line (what the simulator's body touched, whether the map had it and how far off):

- ``budget, never in view``: the capture budget ran out and no capture had the target in view;
- ``budget, missed in view``: it ran out although a capture had the target in view (a missed detection);
- ``budget, seen once``: it ran out with the target seen once, not confirmed;
- ``nothing left to look at``: no reachable viewpoint showed unknown space where the target can be;
- ``found, not reached``: confirmed, but no seen-free spot beside it could be reached (or the move there
  stopped);
- ``found, ended away``: the search said found but the robot did not end on the floor within 1 m;
- ``wrong object``: found in a room without a reachable target (the wrong object taken for it).

    .venv/bin/python bench/search.py --json /tmp/search.json
    .venv/bin/python bench/search_failures.py /tmp/search.json [--strategy search] [--rooms]
"""

from __future__ import annotations

import argparse
import json
import sys
from collections import Counter
from pathlib import Path

KINDS = ("budget, never in view", "budget, missed in view", "budget, seen once", "nothing left to look at",
         "found, not reached", "found, ended away", "wrong object", "other")


def kind(rec: dict) -> str | None:
    """The failure kind of one search's record (``None``: not a failure)."""
    if not rec["findable"]:
        return "wrong object" if rec["found"] else None
    if rec["success"]:
        return None
    reason = rec["reason"]
    views = rec.get("target_views") or {}
    if reason.startswith("budget used (target seen once"):
        return "budget, seen once"
    if reason.startswith("not found: budget"):
        return "budget, missed in view" if views.get("missed", 0) or views.get("too_near", 0) else \
            "budget, never in view"
    if reason.startswith("not found: nowhere"):
        return "nothing left to look at"
    if reason.startswith("found, not reached") or reason.startswith("found but"):
        return "found, not reached"
    if rec["found"]:
        return "found, ended away"
    return "other"


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("json", type=Path, help="the benchmark's records (bench/search.py --json FILE)")
    ap.add_argument("--strategy", default=None, help="only this strategy (default: every one)")
    ap.add_argument("--rooms", action="store_true", help="also list each failed search (room, kind, reason)")
    args = ap.parse_args(argv)
    try:
        records = json.loads(args.json.read_text())["records"]
    except (OSError, ValueError, KeyError) as exc:
        ap.error(f"{args.json}: not a bench/search.py --json file ({exc})")
    if args.strategy:
        records = [r for r in records if r["strategy"] == args.strategy]
    groups = list(dict.fromkeys((r["run"], r["strategy"]) for r in records))
    print(f"{'run':7} {'strategy':8} {'fail':>4}  " + "  ".join(f"{k}" for k in KINDS) + "  collisions")
    for run, strat in groups:
        rs = [r for r in records if r["run"] == run and r["strategy"] == strat]
        c = Counter(k for k in map(kind, rs) if k)
        print(f"{run:7} {strat:8} {sum(c.values()):4d}  " + "  ".join(f"{c.get(k, 0):{len(k)}d}" for k in KINDS)
              + f"  {sum(r['collisions'] for r in rs):10d}")
    print()
    print("collisions (what the body touched; mapped: the map had the object, off: its mapped centre's error [m]; "
          "distance: the mapped box's footprint to the body's axis [m]; cells: known-space states round it)")
    for r in records:
        for c in r.get("contacts", []):
            print(f"  {r['run']:7} {r['strategy']:8} {r['room']:22} capture {c['captures']:2d} at {c['at']} -> "
                  f"{c['goal']}: {c['object']} ({c['label']}) mapped {c.get('mapped')} off {c.get('mapped_off')} "
                  f"distance {c.get('mapped_distance')} cells {c.get('cells')}")
    if args.rooms:
        print()
        for r in records:
            k = kind(r)
            if k:
                print(f"  {r['run']:7} {r['strategy']:8} {r['room']:22} {k:24} {r['captures']:2d} captures: {r['reason']}"
                      f" (target views {r.get('target_views')})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
