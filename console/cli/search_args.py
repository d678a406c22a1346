"""``morphonavi search``'s options and their checks: every option is checked where it enters, before the
simulator starts, and a bad one is refused naming the option as typed (exit status 2, no traceback).

The search's own inputs (``--target``, ``--max-captures``, ``--max-time``, ``--battery-reserve``) go through
:func:`console.session.search_inputs.search_config`, the check the console's Find panel uses too, so both
refuse the same values with the same words. The simulator's options (``--world``, ``--time-scale``,
``--perception``, ``--seed``) and the output (``--out``) are checked here.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import tempfile
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from console.cli.errors import CliError
from console.cli.world_option import load_world_option
from console.session.search_types import BATTERY_RESERVE, MAX_CAPTURES, MAX_TIME, MIN_TIME, SearchConfig

TIME_SCALE = (0.1, 50.0)
"""Range of ``--time-scale``: simulated seconds per wall-clock second."""
SEED_MAX = 2**32 - 1
PERCEPTIONS = ("exact", "noisy")


@dataclass(frozen=True)
class SearchRequest:
    """A checked ``morphonavi search`` command line.

    Attributes:
        config: The search.
        world: The simulator's room (:class:`console.link.world_file.World`).
        out: Where the result is written, or ``None``.
        time_scale: Simulated seconds per wall-clock second.
        perception: ``exact`` or ``noisy``.
        seed: The perception noise's seed (``noisy`` only), or ``None``.
    """

    config: SearchConfig
    world: Any
    out: Path | None
    time_scale: float
    perception: str
    seed: int | None


def _number(option: str, text: Any, lo: float, hi: float, what: str) -> float:
    try:
        v = float(str(text).strip())
    except ValueError:
        v = math.nan
    if not math.isfinite(v) or not lo <= v <= hi:
        raise CliError(f"{option}: must be a number within {lo:g}..{hi:g} ({what}), got {text}")
    return v


def check_seed(text: Any, perception: str) -> int | None:
    """``--seed``'s value: a whole number within 0..2^32-1, and only with ``--perception noisy``."""
    if text is None:
        return None
    try:
        n = int(str(text).strip())
    except ValueError:
        n = -1
    if not 0 <= n <= SEED_MAX:
        raise CliError(f"--seed: must be a whole number within 0..{SEED_MAX}, got {text}")
    if perception != "noisy":
        raise CliError("--seed: draws the perception noise: only with --perception noisy (exact perception has "
                       "no randomness)")
    return n


def _scene_file(world: Path | None) -> Path | None:
    """The scene file a world file names (``"scene": "<path>"``, relative to the world's folder), or ``None``
    (no world, the scene in place, or a world already refused by :func:`load_world_option`)."""
    if world is None:
        return None
    try:
        raw = json.loads(Path(world).read_text(encoding="utf-8")).get("scene")
    except (OSError, ValueError, AttributeError):
        return None
    return Path(world).parent / raw if isinstance(raw, str) and raw.strip() else None


def check_out(out: str | None, world: Path | None) -> Path | None:
    """``--out``'s path, refused before the search when it is a folder, in a missing folder, the world file,
    or in a folder this process cannot write to (a temporary file is made and removed there)."""
    if out is None:
        return None
    from console.cli.outputs import OutputError, check_output, write_error

    try:
        target = check_output(out, [("world file", world), ("world's scene file", _scene_file(world))],
                              example="result.json")
    except OutputError as exc:
        raise CliError(str(exc)) from None
    try:
        with tempfile.NamedTemporaryFile(dir=target.parent, prefix=".morphonavi-probe-"):
            pass
        if target.exists() and not os.access(target, os.W_OK):
            raise PermissionError(13, "Permission denied", str(target))
    except OSError as exc:
        raise CliError(str(write_error(exc, out))) from None
    return target


def search_request(args: argparse.Namespace) -> SearchRequest:
    """Every option of ``args`` checked, the cheap ones first; :class:`CliError` naming the first bad one."""
    from console.session.search_inputs import CLI_NAMES, search_config
    from console.session.session_types import SessionError

    try:
        config = search_config(CLI_NAMES, args.target, mode="auto", max_captures=args.max_captures,
                               max_time=args.max_time, battery_reserve=args.battery_reserve)
    except SessionError as exc:
        raise CliError(str(exc)) from None
    scale = _number("--time-scale", args.time_scale, *TIME_SCALE, "simulated seconds per wall-clock second")
    if args.perception not in PERCEPTIONS:
        raise CliError(f"--perception: must be one of {', '.join(PERCEPTIONS)}, got {args.perception}")
    seed = check_seed(args.seed, args.perception)
    world = load_world_option(args.world)
    out = check_out(args.out, args.world)
    return SearchRequest(config, world, out, scale, args.perception, seed)


def add_search_arguments(p: argparse.ArgumentParser) -> None:
    """The options of ``morphonavi search`` (values checked by :func:`search_request`, not by argparse)."""
    p.add_argument("--target", required=True, metavar="WHAT",
                   help="what to find: a catalog class, one of its synonyms or detector prompts (e.g. 'robot dog', "
                        "'quadruped'); other words are refused with the classes the perception can name")
    p.add_argument("--world", type=Path, default=None, metavar="FILE",
                   help="the simulator's hidden room (a world file; default the paper's room)")
    p.add_argument("--out", default=None, metavar="FILE", help="write the result as JSON here (e.g. result.json; "
                   "checked before the search: a file name in an existing folder you can write to)")
    p.add_argument("--max-captures", default="20", metavar="N", help=f"capture budget, 1..{MAX_CAPTURES} (default 20)")
    p.add_argument("--max-time", default="900", metavar="S",
                   help=f"time budget [s], {MIN_TIME:g}..{MAX_TIME:g} (default 900)")
    p.add_argument("--battery-reserve", default=f"{100 * BATTERY_RESERVE:.0f}", metavar="PCT",
                   help=f"end the search when the charge falls below this [%%] (default {100 * BATTERY_RESERVE:.0f}; "
                        "at least 25, where the console refuses new moves, and below 100)")
    p.add_argument("--time-scale", default="8", metavar="X",
                   help=f"simulated seconds per wall-clock second, {TIME_SCALE[0]:g}..{TIME_SCALE[1]:g} (default 8)")
    p.add_argument("--perception", default="exact", metavar="{" + ",".join(PERCEPTIONS) + "}",
                   help="'exact' (default, the render's ground truth) or 'noisy' (box jitter, 10 %% missed and "
                        "occasional false detections, as morphonavi console --perception noisy)")
    p.add_argument("--seed", default=None, metavar="N",
                   help="with --perception noisy: seed of the noise, for a repeatable run (default: a new draw)")


__all__ = ["PERCEPTIONS", "SearchRequest", "TIME_SCALE", "add_search_arguments", "check_out", "check_seed",
           "search_request"]
