"""The ``morphonavi`` command: wires subcommands to the modules that do the work."""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path
from typing import Callable, Sequence

from console.cli.cli_args import _add_planner_args, _vec3, package_version
from console.cli.errors import CliError


def join_negative_values(parser: argparse.ArgumentParser, argv: Sequence[str]) -> list[str]:
    """``--pose -1,2,0,90`` -> ``--pose=-1,2,0,90`` for every option that takes one value.

    argparse takes a value that starts with ``-`` for an option ("expected one argument") unless it
    is a plain negative number; a list such as ``-1,2,0,90`` (or ``-.5``, ``-inf``) can never be an
    option name, so it is attached to the option before it.
    """
    from pipeline.option_values import looks_like_negative_value

    takes_value: set[str] = set()

    def collect(p: argparse.ArgumentParser) -> None:
        for action in p._actions:
            if isinstance(action, argparse._SubParsersAction):
                for sub in action.choices.values():
                    collect(sub)
            elif action.option_strings and action.nargs is None and action.const is None and \
                    not isinstance(action, (argparse._StoreTrueAction, argparse._StoreFalseAction,
                                            argparse._CountAction, argparse._HelpAction, argparse._VersionAction)):
                takes_value.update(action.option_strings)

    collect(parser)
    out: list[str] = []
    args = list(argv)
    i = 0
    while i < len(args):
        tok = args[i]
        if tok == "--":
            out.extend(args[i:])
            break
        if tok in takes_value and i + 1 < len(args) and looks_like_negative_value(args[i + 1]):
            out.append(f"{tok}={args[i + 1]}")
            i += 2
            continue
        out.append(tok)
        i += 1
    return out


# --- plan ---------------------------------------------------------------------------------------


def cmd_plan(args: argparse.Namespace) -> int:
    from pipeline.scene import SceneError
    from planner.grid import CostWeights, GridError, Workspace, build_grid
    from planner.mission import MissionError
    from planner.route import Route
    from console.cli.object_goal_cli import resolve_stop
    from console.cli.plan_known import plan_grid
    from console.session.goal_rules import zero_length

    from console.cli.outputs import check_output, write_error
    from pipeline.file_kind import FileKindError, load_scene_file

    try:  # the argument first: its error before any about the default --out
        scene = load_scene_file(args.scene)
    except FileKindError as exc:
        raise CliError(str(exc)) from None
    except SceneError as exc:
        raise CliError(f"{args.scene}: {exc}") from None
    out = check_output(args.out, [("scene", args.scene)], example="mission.json")
    try:
        ws = Workspace(args.bounds[0], args.bounds[1], args.resolution)
    except GridError as exc:  # the workspace is made of --bounds and --resolution: name them
        raise CliError(f"--bounds / --resolution: {exc}") from None
    try:
        weights = CostWeights(args.w_ground, args.w_takeoff, args.w_flight, args.w_danger)
        grid, rule_lines = plan_grid(args, scene, ws)
    except GridError as exc:
        raise CliError(str(exc)) from None
    c = grid.counts()
    print(f"grid {ws.shape} at {ws.resolution} m: {c['occupied']} occupied, {c['dangerous']} dangerous, {c['free']} free")
    for line in rule_lines:
        print(line)
    route = Route(grid, args.start, weights)
    if route.start_warning:
        print(f"warning: {route.start_warning}", file=sys.stderr)
    cell, why = route.check_point(args.start, "start")
    if cell is None:
        raise CliError(why)
    if not args.goal:
        raise CliError("give at least one stop: --goal x,y,z or --goal-object ID_OR_LABEL")
    for goal in args.goal:
        goal = resolve_stop(goal, scene, route)
        why = zero_length(goal, route, grid.workspace)  # the console's rule: no 0 m mission
        if why is not None:
            raise CliError(f"--goal {goal[0]:g},{goal[1]:g},{goal[2]:g}: {why}")
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
    try:
        mission.save(out)
    except OSError as exc:
        raise write_error(exc, args.out) from None
    print(f"mission written to {out}")
    return 0


# --- models -------------------------------------------------------------------------------------


def cmd_models(args: argparse.Namespace) -> int:
    from pipeline.models.cli_support import models_fetch, models_list, models_verify
    from pipeline.option_values import check_model_dir

    model_dir = check_model_dir(args.model_dir, "--model-dir")
    if args.action == "list":
        print(models_list(model_dir))
        return 0
    if args.action == "fetch":
        return models_fetch(args.names, model_dir)
    if model_dir is not None and not model_dir.exists():  # "no models found in it" hid the typo
        raise CliError(f"--model-dir {args.model_dir}: the folder does not exist (fetch models into it with "
                       "`morphonavi models fetch offline --model-dir DIR`)")
    text, code = models_verify(model_dir, args.names or None)
    print(text)
    return code


def _add_models_parser(sub: argparse._SubParsersAction) -> None:  # type: ignore[type-arg]
    from pipeline.option_values import add_model_dir_option

    p = sub.add_parser("models", help="list, fetch (download with checksums) or verify model weights",
                       description="Model weights live in --model-dir, else $MORPHONAVI_MODELS, else the user "
                                   "cache dir.")
    add_model_dir_option(p, "--dir")
    actions = p.add_subparsers(dest="action", required=True, metavar="ACTION")
    for name, helptext, names_help, nargs in (
        ("list", "known models, present or missing, and where they are looked for", None, None),
        ("fetch", "download models or sets with checksums (resumes partial files)",
         "model or set names: offline, default, cloud, yolox_nano, ...", "+"),
        ("verify", "check checksums, onnxruntime loading and the I/O signature of present models",
         "model or set names (default: every present model)", "*"),
    ):
        a = actions.add_parser(name, help=helptext, description=helptext[0].upper() + helptext[1:] + ".")
        if nargs is not None:
            a.add_argument("names", nargs=nargs, help=names_help)
        else:
            a.set_defaults(names=[])
        # also after the action (morphonavi models verify --model-dir DIR); SUPPRESS keeps the parent's value
        add_model_dir_option(a, "--dir", default=argparse.SUPPRESS)
    p.set_defaults(func=cmd_models)


# --- entry point --------------------------------------------------------------------------------


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="morphonavi",
        description="Monocular mapping, Aerial-Ground A* planning and a browser console for an aerial-ground robot.",
    )
    parser.add_argument("--version", action="version", version=f"%(prog)s {package_version()}")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")

    from console.cli.object_goal_cli import object_stop
    from console.cli.plan_known import add_known_space_args

    p = sub.add_parser("plan", help="plan a multi-stop Aerial-Ground A* path through a scene and write the mission",
                       description="Plan start -> goal1 -> goal2 ... on the scene's grid and write the mission JSON.")
    p.add_argument("scene", type=Path, help="scene JSON (world frame)")
    p.add_argument("--start", type=_vec3("--start"), required=True, help="start 'x,y,z' [m] (world frame)")
    p.add_argument("--goal", type=_vec3("--goal"), action="append",
                   help="goal 'x,y,z' [m]; repeat for stops")
    p.add_argument("--goal-object", type=object_stop, action="append", dest="goal", metavar="ID_OR_LABEL",
                   help="a stop beside an object, by id or label (e.g. 'robot dog'); mixes with --goal in order")
    p.add_argument("--out", default="mission.json", help="mission JSON to write (default mission.json)")
    _add_planner_args(p)
    add_known_space_args(p)
    p.set_defaults(func=cmd_plan)

    _add_models_parser(sub)
    for register in _extra_commands():
        register(sub)
    return parser


def _extra_commands() -> list[Callable[[argparse._SubParsersAction], None]]:  # type: ignore[type-arg]
    """Subcommands whose parsers live beside the code they run."""
    from console.cli.console_cmd import add_console_parser
    from console.cli.describe_cmd import add_describe_parser
    from console.cli.map_bench_cmd import add_bench_parser, add_calibrate_parser, add_map_parser

    from console.cli.mcp_cmd import add_mcp_parser
    from console.cli.replay_cmd import add_replay_parser
    from console.cli.search_cmd import add_search_parser

    return [add_console_parser, add_map_parser, add_bench_parser, add_describe_parser, add_calibrate_parser,
            add_replay_parser, add_mcp_parser, add_search_parser]


def main(argv: Sequence[str] | None = None) -> int:
    from pipeline.option_values import OptionError

    parser = build_parser()
    args = parser.parse_args(join_negative_values(parser, sys.argv[1:] if argv is None else argv))
    try:
        return int(args.func(args) or 0)
    except (CliError, OptionError) as exc:
        print(f"morphonavi {args.command}: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        return 130
    except BrokenPipeError:  # output piped into `head` & co.: the reader left, not an error of ours
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())  # so the interpreter's final flush does not complain
        return 0


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
