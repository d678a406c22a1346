"""``plan``'s robot-sized grid and known-space rule (registered by :mod:`console.cli.morphonavi`).

The grid is the robot's configuration space (:func:`planner.grid.build_grid`): ``--margin`` is
the robot's radius walking and flying (no route passes closer to an obstacle), ``--robot-height``
the walking body's height. Known space comes from the scene file's optional top-level
``"known_space"`` key (:meth:`pipeline.mapping.known_space.KnownSpace.to_dict`) or
``--known-space FILE`` (the same object, or a file holding it under that key); without it the
scene is fully known (hand-made maps keep working). ``--unknown allow`` plans into unknown space
deliberately; the route then says how many metres of it are unseen. ``plan`` prints the rule it used.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path
from typing import Any

from console.cli.errors import CliError
from console.wording import plural


def add_known_space_args(p: argparse.ArgumentParser) -> None:
    """``--unknown``, ``--known-space``, ``--robot-height`` and ``--flying-radius``."""
    g = p.add_argument_group("known space and the robot's size")
    g.add_argument("--unknown", choices=("closed", "allow"), default="closed",
                   help="unknown space (not seen by any capture): closed (default: routes go only through seen-free "
                        "space; a goal there is refused with where to look from) or allow (plan into it and say how "
                        "many metres are unseen); ignored when the scene has no known space (taken as fully known)")
    g.add_argument("--known-space", type=Path, metavar="FILE",
                   help="known space JSON (default: the scene file's 'known_space' key, if any)")
    g.add_argument("--robot-height", type=float, default=None, metavar="M",
                   help="height of the walking robot [m]: the space up to it must be free (default 0.45)")
    g.add_argument("--flying-radius", type=float, default=None, metavar="M",
                   help="radius of the flying robot [m] (default: --margin)")


def _known_from(path: Path, what: str) -> Any:
    from pipeline.mapping.known_space import KnownSpace, KnownSpaceError

    if what != "scene":  # the scene file was read by kind already; --known-space: a known space or a scene
        from console.cli.input_files import check_input_file

        check_input_file(path, "known_space", what, also=("scene",))
    try:
        data = json.loads(path.read_text(encoding="utf-8-sig"))
    except FileNotFoundError:
        raise CliError(f"{what} {path}: file not found") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise CliError(f"{what} {path}: cannot read: {getattr(exc, 'strerror', None) or exc}") from None
    except json.JSONDecodeError as exc:
        raise CliError(f"{what} {path}: not valid JSON (line {exc.lineno}, column {exc.colno}): {exc.msg}") from None
    except (ValueError, RecursionError) as exc:
        raise CliError(f"{what} {path}: not usable JSON ({exc})") from None
    if isinstance(data, dict) and "known_space" in data:
        data = data["known_space"]
    elif what == "scene":
        return None
    try:
        return KnownSpace.from_dict(data)
    except KnownSpaceError as exc:
        raise CliError(f"{what} {path}: {exc}") from None


def plan_grid(args: argparse.Namespace, scene: Any, ws: Any) -> tuple[Any, list[str]]:
    """The planning grid for ``plan`` and the lines saying which rule it used (raises CliError)."""
    from planner.grid import KNOWN_RULES, GridError, build_grid
    from planner.robot_model import RobotModel, RobotModelError

    known = _known_from(args.known_space, "--known-space") if args.known_space else _known_from(Path(args.scene), "scene")
    margin = args.margin
    try:
        robot = RobotModel(radius=margin, flying_radius=margin if args.flying_radius is None else args.flying_radius,
                           **({} if args.robot_height is None else {"height": args.robot_height}))
    except RobotModelError as exc:
        raise CliError(str(exc).replace("robot.radius", "--margin").replace("robot.height", "--robot-height")
                       .replace("robot.flying_radius", "--flying-radius")) from None
    except TypeError as exc:
        raise CliError(f"--margin: {exc}") from None
    try:
        grid = build_grid(scene, ws, robot=robot, known=known, unknown=args.unknown)
    except GridError as exc:
        raise CliError(str(exc)) from None
    lines = [f"{robot.describe()}; {KNOWN_RULES[grid.rule]}"]
    if known is not None:
        k = known.counts()
        lines.append(f"known space: {k['free']} seen-free, {k['occupied']} occupied, {k['unknown']} unknown cells "
                     f"({known.resolution:g} m); {plural(grid.unlabelled, 'unlabelled obstacle cell')}")
        if grid.floating:
            lines.append("floor closed beneath objects mapped floating (not seen free): " + ", ".join(grid.floating))
    return grid, lines


__all__ = ["add_known_space_args", "plan_grid"]
