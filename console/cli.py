"""The ``morphonavi`` command: wires subcommands to the modules that do the work."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Callable, Sequence


class CliError(Exception):
    """A user-facing error: printed without a traceback, exit status 2."""


def _vec3(text: str) -> tuple[float, float, float]:
    try:
        parts = [float(p) for p in text.split(",")]
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected 'x,y,z' in metres, got {text!r}") from None
    if len(parts) == 2:
        parts.append(0.0)
    if len(parts) != 3:
        raise argparse.ArgumentTypeError(f"expected 'x,y,z' in metres, got {text!r}")
    return (parts[0], parts[1], parts[2])


def _bounds(text: str) -> tuple[tuple[float, float, float], tuple[float, float, float]]:
    try:
        v = [float(p) for p in text.split(",")]
    except ValueError:
        v = []
    if len(v) != 6:
        raise argparse.ArgumentTypeError("expected 'xmin,ymin,zmin,xmax,ymax,zmax' in metres")
    return (v[0], v[1], v[2]), (v[3], v[4], v[5])


# --- plan ---------------------------------------------------------------------------------------


def _add_planner_args(p: argparse.ArgumentParser) -> None:
    g = p.add_argument_group("grid and costs (world frame, metres)")
    g.add_argument("--bounds", type=_bounds, default=((0.0, 0.0, 0.0), (5.0, 8.0, 3.0)),
                   help="workspace 'xmin,ymin,zmin,xmax,ymax,zmax' (default: the paper's 5 x 8 x 3 m room)")
    g.add_argument("--resolution", type=float, default=0.25, help="cell size [m] (default 0.25)")
    g.add_argument("--margin", type=float, default=0.35, help="robot radius: dangerous margin [m] (default 0.35)")
    g.add_argument("--w-ground", type=float, default=1.0, help="ground layer cost per metre")
    g.add_argument("--w-takeoff", type=float, default=12.0, help="first air layer (take-off/landing) cost per metre")
    g.add_argument("--w-flight", type=float, default=3.0, help="higher layers cost per metre")
    g.add_argument("--w-danger", type=float, default=5.0, help="multiplier for dangerous cells")


def cmd_plan(args: argparse.Namespace) -> int:
    from pipeline.scene import Scene, SceneError
    from planner.grid import CostWeights, GridError, Workspace, build_grid
    from planner.mission import MissionError
    from planner.route import Route

    try:
        scene = Scene.load(args.scene)
    except SceneError as exc:
        raise CliError(f"{args.scene}: {exc}") from None
    try:
        ws = Workspace(args.bounds[0], args.bounds[1], args.resolution)
        weights = CostWeights(args.w_ground, args.w_takeoff, args.w_flight, args.w_danger)
        grid = build_grid(scene, ws, args.margin)
    except GridError as exc:
        raise CliError(str(exc)) from None
    c = grid.counts()
    print(f"grid {ws.shape} at {ws.resolution} m: {c['occupied']} occupied, {c['dangerous']} dangerous, {c['free']} free")
    route = Route(grid, args.start, weights)
    cell, why = route.check_point(args.start, "start")
    if cell is None:
        raise CliError(why)
    for goal in args.goal:
        res = route.propose(goal)
        if not res.ok:
            raise CliError(res.message)
        print(f"goal ({goal[0]:.2f}, {goal[1]:.2f}, {goal[2]:.2f}): {res.message}, "
              f"{res.expanded} nodes expanded in {res.seconds * 1000:.1f} ms")
        route.register()
    try:
        mission = route.mission()
    except MissionError as exc:
        raise CliError(f"cannot build the mission: {exc}") from None
    print(mission.summary())
    out = Path(args.out)
    mission.save(out)
    print(f"mission written to {out}")
    return 0


# --- models -------------------------------------------------------------------------------------


def cmd_models(args: argparse.Namespace) -> int:
    from pipeline.models.cli_support import models_fetch, models_list, models_verify

    if args.action == "list":
        print(models_list(args.dir))
        return 0
    if args.action == "fetch":
        if not args.names:
            raise CliError("fetch needs a model or set name, e.g. 'morphonavi models fetch offline'")
        return models_fetch(args.names, args.dir)
    text, code = models_verify(args.dir, args.names or None)
    print(text)
    return code


def _add_models_parser(sub: argparse._SubParsersAction) -> None:  # type: ignore[type-arg]
    p = sub.add_parser("models", help="list, fetch (download with checksums) or verify model weights",
                       description="Model weights live in --dir, else $MORPHONAVI_MODELS, else the user cache dir.")
    p.add_argument("action", choices=("list", "fetch", "verify"))
    p.add_argument("names", nargs="*", help="model or set names (default, offline, cloud, yolox_nano, ...)")
    p.add_argument("--dir", type=Path, default=None, help="models directory")
    p.set_defaults(func=cmd_models)


# --- entry point --------------------------------------------------------------------------------


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="morphonavi",
        description="Monocular mapping, Aerial-Ground A* planning and a browser console for an aerial-ground robot.",
    )
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")

    p = sub.add_parser("plan", help="plan a multi-stop Aerial-Ground A* path through a scene and write the mission",
                       description="Plan start -> goal1 -> goal2 ... on the scene's grid and write the mission JSON.")
    p.add_argument("scene", type=Path, help="scene JSON (world frame)")
    p.add_argument("--start", type=_vec3, required=True, help="start 'x,y,z' [m] (world frame)")
    p.add_argument("--goal", type=_vec3, action="append", required=True, help="goal 'x,y,z' [m]; repeat for stops")
    p.add_argument("--out", default="mission.json", help="mission JSON to write (default mission.json)")
    _add_planner_args(p)
    p.set_defaults(func=cmd_plan)

    _add_models_parser(sub)
    for register in _extra_commands():
        register(sub)
    return parser


def _extra_commands() -> list[Callable[[argparse._SubParsersAction], None]]:  # type: ignore[type-arg]
    """Subcommands whose parsers live beside the code they run."""
    from console.console_cmd import add_console_parser
    from pipeline.cli_commands import add_bench_parser, add_map_parser

    return [add_console_parser, add_map_parser, add_bench_parser]


def main(argv: Sequence[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return int(args.func(args) or 0)
    except CliError as exc:
        print(f"morphonavi {args.command}: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        return 130


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
