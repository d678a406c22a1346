"""``morphonavi search``: find an object headless on the simulator (the console's Find loop, no browser).

Prints each step of the search (:class:`console.session.search.SearchJob`) and writes the result as
JSON (``--out``): found, target id, final position, distance to the target, path length, captures,
time and the reason it ended. Perception is the simulator's ground truth (its rendered depth for the
known space). Each step is printed once: the operator notices the steps already say (a capture's
*Mapped*, the search's own *Find: ...*) are not printed again; any other warning or error notice is
printed once on stderr (``notice: <title>: <text>``). The options and their checks are in :mod:`console.cli.search_args`. Registered by
:mod:`console.cli.morphonavi`.
"""

from __future__ import annotations

import argparse
import logging
import sys
import tempfile
from pathlib import Path
from typing import Any

from console.session.search_types import target_height


class HeadlessRig:
    """A simulated robot, a session, capture & map (ground truth), the mission runner and a search,
    wired as the console wires them (the link's states reach the session)."""

    def __init__(self, world: Any, folder: Path, time_scale: float = 8.0, perception: str = "exact",
                 seed: int | None = None) -> None:
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
        if perception == "noisy" and seed is not None:  # a repeatable draw of the perception noise
            from console.link.sim_perception_noise import noisy_bundle_for
            from console.session.mapping_job import NOISY_LABEL, MapperPerceiver

            perceiver: Any = MapperPerceiver(NOISY_LABEL, noisy_bundle_for(seed=seed))
        else:
            perceiver = simulator_perceiver(perception)
        self.mapping = MappingJob(self.session, self.robot.capture, perceiver)
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


STEP_NOTICES = ("Mapped", "Find")
"""Titles of the operator notices the printed steps already say (``Find: robot dog`` starts with ``Find``)."""


def said_by_steps(title: str) -> bool:
    """Whether a notice titled ``title`` repeats a printed step (a capture's result, the search's own report)."""
    return any(title == t or title.startswith(t + ":") for t in STEP_NOTICES)


class _NoticesOnce(logging.Filter):
    """Keeps the session's notices out of the log (Python prints unhandled warnings on stderr): the command
    prints each one once itself; the session's errors (a failed listener) still reach stderr."""

    def filter(self, record: logging.LogRecord) -> bool:
        return record.levelno >= logging.ERROR


def cmd_search(args: argparse.Namespace) -> int:
    from console.cli.outputs import write_output
    from console.cli.search_args import search_request
    from console.session.session import JOB, NOTICE
    from console.wording import plural

    req = search_request(args)  # every option checked before the simulator starts
    world, cfg, out = req.world, req.config, req.out
    with tempfile.TemporaryDirectory(prefix="morphonavi-search-") as tmp:
        rig = HeadlessRig(world, Path(tmp) / "session", time_scale=req.time_scale, perception=req.perception,
                          seed=req.seed)
        printed = [0]

        def show(topic: str, payload: Any) -> None:
            if topic == NOTICE and payload.level in ("warning", "error") and not said_by_steps(payload.title):
                print(f"notice: {payload.title}: {payload.body}", file=sys.stderr, flush=True)
            if topic != JOB:
                return
            steps = rig.search.steps
            while printed[0] < len(steps):
                print(steps[printed[0]], flush=True)
                printed[0] += 1

        rig.session.subscribe(show)
        session_log, quiet = logging.getLogger("console.session.session"), _NoticesOnce()
        session_log.addFilter(quiet)
        try:
            seed = f", noise seed {req.seed}" if req.seed is not None else ""
            print(f"searching the simulator's room '{world.name}' for {cfg.target!r} "
                  f"({'noisy ' if req.perception == 'noisy' else ''}ground-truth perception{seed}, "
                  f"time x{req.time_scale:g})", flush=True)
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
            session_log.removeFilter(quiet)
    assert result is not None
    for line in result.steps[printed[0]:]:
        print(line)
    d = f"{result.distance_to_target:.2f} m from it" if result.distance_to_target is not None else "not located"
    print(f"{'FOUND' if result.found else 'NOT FOUND'}: {result.reason}; target {result.target_id or '-'} ({d}); "
          f"{plural(result.captures, 'capture')}, {result.path_length:.1f} m travelled, {result.time:.0f} s")
    if result.left_unseen:
        print(f"left unseen: {result.left_unseen}")
    if out is not None:
        write_output(out, result.to_json() + "\n")
        print(f"result written to {out}")
    return 0 if result.found else 1


def add_search_parser(sub: argparse._SubParsersAction) -> None:  # type: ignore[type-arg]
    from console.cli.search_args import add_search_arguments

    p = sub.add_parser("search", help="find an object headless on the simulator: choose viewpoints, move, "
                                      "capture and map until it is found",
                       description="Find an object in the simulator's room with the console's search loop "
                                   "(no browser): prints each step and writes the result as JSON. Every option "
                                   "is checked before the simulator starts.")
    add_search_arguments(p)
    p.set_defaults(func=cmd_search, command="search")


__all__ = ["HeadlessRig", "STEP_NOTICES", "add_search_parser", "cmd_search", "said_by_steps", "target_height"]
