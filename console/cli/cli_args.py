"""Option types, option groups and defaults shared by several ``morphonavi`` subcommands (``plan``, ``describe``;
``console``, ``mcp``).

Values are world frame (z up) [m]; a bad value is an argparse error naming the option.
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path
from typing import Callable


def _numbers(option: str, counts: tuple[int, ...], form: str) -> Callable[[str], list[float]]:
    """An argparse ``type`` for a comma-separated list of finite numbers (negative ones included)."""
    from pipeline.option_values import ValueListError, parse_numbers

    def parse(text: str) -> list[float]:
        try:
            return parse_numbers(text, option, counts, form)
        except ValueListError as exc:  # argparse names the option itself ("argument --start: ...")
            raise argparse.ArgumentTypeError(str(exc).removeprefix(f"{option}: ")) from None

    parse.__name__ = form  # argparse names the type in some messages
    return parse


def _vec3(option: str) -> Callable[[str], tuple[float, float, float]]:
    parse = _numbers(option, (3,), "x,y,z in metres")

    def vec3(text: str) -> tuple[float, float, float]:
        v = parse(text)
        return (v[0], v[1], v[2])

    return vec3


def _bounds(text: str) -> tuple[tuple[float, float, float], tuple[float, float, float]]:
    v = _numbers("--bounds", (6,), "xmin,ymin,zmin,xmax,ymax,zmax in metres")(text)
    if not (v[0] < v[3] and v[1] < v[4] and v[2] < v[5]):
        raise argparse.ArgumentTypeError(f"every minimum must be below its maximum, got {text!r}")
    return (v[0], v[1], v[2]), (v[3], v[4], v[5])


def _positive(unit: str = "") -> Callable[[str], float]:
    """An argparse ``type``: a finite number > 0 (argparse names the option in its message)."""

    def positive(text: str) -> float:
        try:
            v = float(text)
        except ValueError:
            v = math.nan
        if not (math.isfinite(v) and v > 0):
            raise argparse.ArgumentTypeError(f"must be a number > 0{unit}, got {text}")
        return v

    positive.__name__ = "positive number"
    return positive


def _add_planner_args(p: argparse.ArgumentParser) -> None:
    g = p.add_argument_group("grid and costs (world frame, metres)")
    g.add_argument("--bounds", type=_bounds, default=((0.0, 0.0, 0.0), (5.0, 8.0, 3.0)),
                   help="workspace 'xmin,ymin,zmin,xmax,ymax,zmax' (default: the paper's 5 x 8 x 3 m room)")
    g.add_argument("--resolution", type=_positive(" [m]"), default=0.25, help="cell size [m] (default 0.25)")
    g.add_argument("--margin", type=float, default=0.35, help="robot radius: dangerous margin [m] (default 0.35)")
    g.add_argument("--w-ground", type=_positive(), default=1.0, help="ground layer cost per metre")
    g.add_argument("--w-takeoff", type=_positive(), default=12.0, help="first air layer (take-off/landing) cost per metre")
    g.add_argument("--w-flight", type=_positive(), default=3.0, help="higher layers cost per metre")
    g.add_argument("--w-danger", type=_positive(), default=5.0, help="multiplier for dangerous cells")


def package_version() -> str:
    """The installed package's version (``morphonavi --version``), from its metadata (pyproject.toml)."""
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version("morphonavi")
    except PackageNotFoundError:
        return "unknown (not installed: pip install -e .)"


DEFAULT_SESSION = Path(".morphonavi/session")
"""The console's session folder unless ``--session`` says another (``console`` and ``mcp``)."""
