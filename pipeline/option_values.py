"""Command-line option values shared by every ``morphonavi`` command.

- One parser for every comma-separated list of numbers a user types (command-line options, pose
  strings): finite numbers only, a stated count, and errors that name the option.
- One name for the model-folder option, ``--model-dir DIR`` (each command's old name kept as an
  alias), and one check of it and of ``$MORPHONAVI_MODELS``.

``parse_numbers("-1,2,0,90", "--pose", (2, 3, 4), "x,y[,z[,yaw_deg]]")`` -> ``[-1.0, 2.0, 0.0, 90.0]``.
Negative values are fine here; :func:`console.cli.morphonavi.main` makes sure argparse hands them over (an
option value starting with ``-`` is otherwise taken for an option).
"""

from __future__ import annotations

import math
import os
from pathlib import Path
from typing import Any, Sequence

MODELS_ENV = "MORPHONAVI_MODELS"
MODEL_DIR_HELP = "folder of model weights (default: $MORPHONAVI_MODELS, else the user cache dir)"


class OptionError(ValueError):
    """A command-line value that cannot be used; the message names the option."""


class ValueListError(OptionError):
    """A list of numbers that cannot be used; the message names the option and the expected form."""


def parse_numbers(text: str, where: str, counts: Sequence[int], form: str) -> list[float]:
    """The finite numbers of ``text`` (comma-separated, spaces ignored).

    Args:
        text: What the user typed, e.g. ``"2.5,0.7,0"``.
        where: Name of the option or field for error messages, e.g. ``"--start"``.
        counts: Accepted numbers of values, e.g. ``(3,)``.
        form: The expected form for error messages, e.g. ``"x,y,z"`` (units belong here).

    Raises:
        ValueListError: Empty text, a non-number, a NaN/infinite value, or a wrong count.
    """
    if not isinstance(text, str):
        raise ValueListError(f"{where}: expected '{form}', got {text!r}")
    stripped = text.replace(" ", "")
    if not stripped:
        raise ValueListError(f"{where}: empty value; expected '{form}'")
    parts = stripped.split(",")
    values: list[float] = []
    for i, part in enumerate(parts):
        try:
            v = float(part)
        except ValueError:
            raise ValueListError(f"{where}: value {i + 1} ({part!r}) is not a number; expected '{form}'") from None
        if not math.isfinite(v):
            raise ValueListError(f"{where}: value {i + 1} must be finite, got {part!r}")
        values.append(v)
    if len(values) not in counts:
        n = " or ".join(str(c) for c in counts)
        raise ValueListError(f"{where}: expected {n} numbers '{form}', got {len(values)} in {text!r}")
    return values


def looks_like_negative_value(token: str) -> bool:
    """True for a command-line token that is a (list of) negative number(s), such as ``-1,2,0,90``,
    ``-.5`` or ``-inf``, and so can never be an option name."""
    if len(token) < 2 or token[0] != "-" or token[1] == "-":
        return False
    head = token[1:].split(",", 1)[0].lower()
    return bool(head) and (head[0].isdigit() or head[0] == "." or head in ("inf", "nan", "infinity"))


def add_model_dir_option(p: Any, *aliases: str, dest: str = "model_dir", default: Any = None,
                         help: str = MODEL_DIR_HELP) -> None:
    """Add ``--model-dir DIR`` (and a command's old names as ``aliases``) to an argparse parser."""
    p.add_argument("--model-dir", *aliases, dest=dest, type=Path, default=default, metavar="DIR", help=help)


def check_model_dir(explicit: str | os.PathLike[str] | None, option: str = "--model-dir") -> Path | None:
    """``explicit`` as a path when it is usable, else ``None`` once ``$MORPHONAVI_MODELS`` is checked.

    Raises:
        OptionError: The option or ``$MORPHONAVI_MODELS`` names a file (or anything but a folder).
    """
    if explicit is not None and str(explicit).strip():
        p = Path(explicit).expanduser()
        if p.exists() and not p.is_dir():
            raise OptionError(f"{option} {explicit}: is a file, not a folder of model weights")
        return p
    env = os.environ.get(MODELS_ENV, "").strip()
    if env and Path(env).expanduser().exists() and not Path(env).expanduser().is_dir():
        raise OptionError(f"{MODELS_ENV}={env}: is a file, not a folder of model weights "
                          "(point it at the folder holding the model folders, or unset it)")
    return None


POSE_XY_LIMIT_M = 10000.0
"""Largest ``|x|``, ``|y|`` of a robot pose on the command line [m] (world frame: a site, not a planet)."""
POSE_Z_LIMIT_M = 1000.0
"""Largest ``|z|`` of a robot pose on the command line [m]."""
POSE_YAW_LIMIT_DEG = 360.0
"""Largest ``|yaw|`` of a robot pose on the command line [deg]."""


def check_pose_range(text: str, where: str = "--pose") -> list[float]:
    """The numbers of a pose ``x,y[,z[,yaw_deg]]`` (world frame, metres, degrees), each within its range.

    Like the camera file's ``mount.position`` (robot body frame, within +-10 m) a pose is range-checked,
    with world-sized limits: ``|x|, |y|`` <= :data:`POSE_XY_LIMIT_M`, ``|z|`` <= :data:`POSE_Z_LIMIT_M`,
    ``|yaw_deg|`` <= :data:`POSE_YAW_LIMIT_DEG`.

    Raises:
        ValueListError: Not 2-4 finite numbers, or one out of its range (the option, the value and the range named).
    """
    values = parse_numbers(text, where, (2, 3, 4), "x,y[,z[,yaw_deg]] in metres and degrees")
    limits = (("x", POSE_XY_LIMIT_M, "m"), ("y", POSE_XY_LIMIT_M, "m"), ("z", POSE_Z_LIMIT_M, "m"),
              ("yaw_deg", POSE_YAW_LIMIT_DEG, "deg"))
    for v, (name, limit, unit) in zip(values, limits):
        if abs(v) > limit:
            raise ValueListError(f"{where}: {name} must be within {-limit:g}..{limit:g} {unit}, got {v:g}")
    return values


def check_out_not_input(out: str | os.PathLike[str], inputs: Sequence[tuple[str, Any]], option: str = "--out") -> None:
    """Refuse an output path that is one of the command's input files (it would be overwritten).

    Args:
        out: The output file the user gave.
        inputs: ``(what, path)`` pairs, e.g. ``("photo", "a.jpg")``; ``None`` paths are skipped.
        option: The output option's name for the message.

    Raises:
        OptionError: ``out`` resolves to (or is a link to) one of ``inputs``; the message names both.
    """
    target = Path(out).expanduser()
    resolved = target.resolve()
    for what, path in inputs:
        if path is None or not str(path):
            continue
        p = Path(path).expanduser()
        same = p.resolve() == resolved
        if not same and target.exists() and p.exists():
            try:
                same = os.path.samefile(target, p)
            except OSError:
                same = False
        if same:
            raise OptionError(f"{option} {out}: is the {what} {path} read by this command; writing there would "
                              f"overwrite it: give {option} another file name")


__all__ = ["MODEL_DIR_HELP", "OptionError", "POSE_XY_LIMIT_M", "POSE_YAW_LIMIT_DEG", "POSE_Z_LIMIT_M",
           "ValueListError", "add_model_dir_option", "check_model_dir", "check_out_not_input", "check_pose_range",
           "looks_like_negative_value", "parse_numbers"]
