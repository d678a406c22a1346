"""``morphonavi search``: find an object headless on the simulator (the console's Find loop, no browser).

Prints each step of the search (:class:`console.session.search.SearchJob`) and writes the result as
JSON (``--out``): found, target id, final position, distance to the target, path length, captures,
time and the reason it ended. Perception is the simulator's ground truth (its rendered depth for the
known space). Registered by :mod:`console.cli.morphonavi`.
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

from console.cli.errors import CliError
from console.session.search import target_height
from console.session.operator_state import BATTERY_LOW
from console.session.search_types import BATTERY_RESERVE


class HeadlessRig:
    """A simulated robot, a session, capture & map (ground truth), the mission runner and a search,
    wired as the console wires them (the link's states reach the session)."""

    def __init__(self, world: Any, folder: Path, time_scale: float = 8.0, perception: str = "exact") -> None:
        from console.link.sim import SimRobot
        from console.link.sim_config import SimConfig
        from console.session.mapping_job import MappingJob, simulator_perceiver
        from console.session.search import SearchJob
        from console.session.session import Session
        from console.session.session_types import robot_snapshot
        from console.views.mission_view import make_runner

        opts = world.link_options(config=SimConfig(time_scale=time_scale))
        self.robot = SimRobot(**opts)
        self.robot.connect()
        start = world.start.translation
        self.session = Session(folder, start=(float(start[0]), float(start[1]), float(start[2])),
                               workspace=world.workspace(), autosave=False)
        self._unsub = self.robot.subscribe(lambda st: self.session.set_robot(robot_snapshot(st)))
        st = self.robot.latest_state()
        if st is not None:
            self.session.set_robot(robot_snapshot(st))
        self.mapping = MappingJob(self.session, self.robot.capture, simulator_perceiver(perception))
        self.runner = make_runner(self.robot, self.session)
        self.search = SearchJob(self.session, self.robot, self.mapping, self.runner)
        from console.session.vehicle_commands import VehicleCommands

        self.commands = VehicleCommands(self.session, self.robot, self.runner)  # Hold / Land here / Return

    def close(self) -> None:
        self.search.stop()
        self.search.wait(60)
        if self.runner is not None:
            self.runner.close()
        self._unsub()
        self.robot.close()


def cmd_search(args: argparse.Namespace) -> int:
    from console.link.world_file import WorldError, load_world, paper_world
    from console.session.search import SearchConfig
    from console.session.session import JOB, SessionError

    try:
        world = load_world(args.world) if args.world is not None else paper_world()
    except (WorldError, OSError) as exc:
        raise CliError(f"--world {exc}") from None
    out = Path(args.out) if args.out else None
    if out is not None and (out.is_dir() or not out.parent.is_dir()):
        raise CliError(f"--out {out}: must be a file name in an existing folder")
    pct = args.battery_reserve
    if not (math.isfinite(pct) and 100 * BATTERY_LOW <= pct < 100):
        raise CliError(f"--battery-reserve: must be within {100 * BATTERY_LOW:.0f}..100 [%] (below "
                       f"{100 * BATTERY_LOW:.0f} % the console refuses new moves), got {pct:g}")
    try:
        cfg = SearchConfig(args.target, mode="auto", max_captures=args.max_captures, max_time=args.max_time,
                           target_height=target_height(args.target), min_battery=args.battery_reserve / 100.0)
    except SessionError as exc:
        raise CliError(str(exc)) from None
    with tempfile.TemporaryDirectory(prefix="morphonavi-search-") as tmp:
        rig = HeadlessRig(world, Path(tmp) / "session", time_scale=args.time_scale,
                          perception=getattr(args, "perception", "exact"))
        printed = [0]

        def show(topic: str, _payload: Any) -> None:
            if topic != JOB:
                return
            steps = rig.search.steps
            while printed[0] < len(steps):
                print(steps[printed[0]], flush=True)
                printed[0] += 1

        rig.session.subscribe(show)
        try:
            print(f"searching the simulator's room '{world.name}' for {args.target!r} "
                  f"({'noisy ' if getattr(args, 'perception', 'exact') == 'noisy' else ''}ground-truth perception, "
                  f"time x{args.time_scale:g})", flush=True)
            rig.search.start(cfg)
            while not rig.search.wait(0.5):
                pass
            result = rig.search.result
        except KeyboardInterrupt:
            rig.search.stop()
            rig.search.wait(60)
            result = rig.search.result
        finally:
            rig.close()
    assert result is not None
    for line in result.steps[printed[0]:]:
        print(line)
    d = f"{result.distance_to_target:.2f} m from it" if result.distance_to_target is not None else "not located"
    print(f"{'FOUND' if result.found else 'NOT FOUND'}: {result.reason}; target {result.target_id or '-'} ({d}); "
          f"{result.captures} captures, {result.path_length:.1f} m travelled, {result.time:.0f} s")
    if out is not None:
        data = dataclasses.asdict(result)
        import json

        out.write_text(json.dumps(data, indent=1) + "\n")
        print(f"result written to {out}")
    return 0 if result.found else 1


def add_search_parser(sub: argparse._SubParsersAction) -> None:  # type: ignore[type-arg]
    p = sub.add_parser("search", help="find an object headless on the simulator: choose viewpoints, move, "
                                      "capture and map until it is found",
                       description="Find an object in the simulator's room with the console's search loop "
                                   "(no browser): prints each step and writes the result as JSON.")
    p.add_argument("--target", required=True, help="what to find: a catalog class (e.g. 'robot dog')")
    p.add_argument("--world", type=Path, default=None, metavar="FILE",
                   help="the simulator's hidden room (a world file; default the paper's room)")
    p.add_argument("--out", default=None, metavar="FILE", help="write the result as JSON here (e.g. result.json)")
    p.add_argument("--max-captures", type=int, default=20, help="capture budget (default 20)")
    p.add_argument("--max-time", type=float, default=900.0, help="time budget [s] (default 900)")
    p.add_argument("--battery-reserve", type=float, default=100 * BATTERY_RESERVE, metavar="PCT",
                   help=f"end the search when the charge falls below this [%%] (default {100 * BATTERY_RESERVE:.0f}; "
                        "at least 25, where the console refuses new moves)")
    p.add_argument("--time-scale", type=float, default=8.0,
                   help="simulated seconds per wall-clock second (default 8)")
    p.add_argument("--perception", choices=("exact", "noisy"), default="exact",
                   help="'exact' (default, the render's ground truth) or 'noisy' (box jitter, 10 %% missed and "
                        "occasional false detections, as morphonavi console --perception noisy)")
    p.set_defaults(func=cmd_search, command="search")


__all__ = ["HeadlessRig", "add_search_parser", "cmd_search", "target_height"]
