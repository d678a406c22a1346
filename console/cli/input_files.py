"""The first check of every file a ``morphonavi`` command reads: it exists, is a file, is not empty, and is not
another kind of MorphoNavi file (:mod:`pipeline.file_kind`), before the command reads it as its own.

Each refusal names the option (or the argument) as typed, what the file is and what the command wants
(``--known-space history.json is a console undo history (morphonavi-history, ...), not a known space: ...``),
never an errno or a codec's message. A TOML file (the catalog, a camera file) is parsed here too, so that a
syntax error names the option with its place (``--catalog list.json: not valid TOML (line 1, column 3): ...``);
:func:`named_error` puts the option first on what a reader then says of a bad field.
"""

from __future__ import annotations

import argparse
import json
import os
import re
import sys
from pathlib import Path
from typing import Any

from console.cli.errors import CliError

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover - Python 3.10 only: the same parser as the tomli package
    import tomli as tomllib

TEXT_KINDS = ("scene", "session", "history", "mission", "scene_graph", "search_result", "search_bench",
              "known_space", "json_schema", "world", "dataset_camera", "dataset_index", "bench_report",
              "camera_toml", "catalog")
"""Kinds that are text (JSON or TOML): a file expected to be one of them must be UTF-8 text."""
TOML_KINDS = ("camera_toml", "catalog")
"""Kinds that are TOML (a camera file may also be a photo's camera JSON): parsed here, so that a syntax error
names the option (``--catalog list.json: not valid TOML (line 1, column 3): ...``)."""


def check_input_file(path: str | os.PathLike[str], expected: str, option: str = "",
                     also: tuple[str, ...] = ()) -> Path:
    """``path`` when it is a readable, non-empty file that is not another MorphoNavi kind than ``expected``.

    Args:
        path: The file the user gave.
        expected: The kind key the command reads (:data:`pipeline.file_kind.KINDS`: ``recording``,
            ``known_space``, ``world``, ``photo`` ...).
        option: The option that named it (``--world``), or ``""`` for a positional argument.
        also: Other kind keys the command accepts as well (``plan --known-space`` also reads a scene).

    Raises:
        CliError: Missing, a folder, unreadable, empty, not UTF-8 text where JSON is wanted, of another
            MorphoNavi kind (naming what it is and which command reads it), or not valid TOML where TOML is
            wanted (:data:`TOML_KINDS`: with the line and column).
    """
    from pipeline.file_kind import KINDS, describe_file, wrong_kind

    p = Path(path).expanduser()
    label = f"{option} {path}" if option else str(path)
    what = KINDS[expected].what
    what_file = what if "file" in what else f"{what} file"
    if not p.exists():
        raise CliError(f"{label}: no such file (expected {what_file})")
    if p.is_dir():
        raise CliError(f"{label}: is a folder, not {what_file}")
    try:
        with open(p, "rb") as f:
            head = f.read(4096)
    except OSError as exc:
        from pipeline.file_kind import os_error_words

        raise CliError(f"{label}: cannot read it: {os_error_words(exc, p)}") from None
    if not head.strip():
        raise CliError(f"{label}: is empty: expected {what_file}")
    found = describe_file(p)  # a recording or a photo is binary: named as what it is first
    if found not in (expected, *also, "json", "json_file", "unknown") and found in KINDS:
        raise CliError(wrong_kind("", label, found, expected))
    if expected in TEXT_KINDS:
        try:
            head.decode("utf-8-sig")
        except UnicodeDecodeError as exc:
            if exc.start < len(head) - 4:  # not a character cut by the 4 KiB window
                raise CliError(f"{label}: is not text (not UTF-8): expected {what_file}") from None
    if expected in TOML_KINDS:
        _check_toml(p, label, expected, what_file)
    return p


def _check_toml(p: Path, label: str, expected: str, what_file: str) -> None:
    """Parse ``p`` as TOML (a camera file starting with ``{`` as its JSON form); :class:`CliError` naming
    ``label`` with the line and column of a syntax error, and saying so when the file is JSON instead."""
    from pipeline.file_kind import MAX_BYTES, MB, os_error_words

    limit = MAX_BYTES.get(expected, 5 * MB)
    try:
        size = p.stat().st_size
        if size > limit:
            raise CliError(f"{label}: {size / MB:.1f} MB is over the {limit / MB:g} MB limit for {what_file}: not read")
        text = p.read_bytes().decode("utf-8-sig")
    except OSError as exc:
        raise CliError(f"{label}: cannot read it: {os_error_words(exc, p)}") from None
    except UnicodeDecodeError:
        raise CliError(f"{label}: is not text (not UTF-8): expected {what_file}") from None
    if expected == "camera_toml" and text.lstrip().startswith("{"):  # a photo's camera JSON
        try:
            json.loads(text)
        except json.JSONDecodeError as exc:
            raise CliError(f"{label}: not valid JSON (line {exc.lineno}, column {exc.colno}): {exc.msg}") from None
        except RecursionError:
            raise CliError(f"{label}: not usable JSON: nested too deeply") from None
        return
    try:
        tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        said = toml_error_words(exc)
        try:
            json.loads(text)
        except (ValueError, RecursionError):
            raise CliError(f"{label}: {said}") from None
        raise CliError(f"{label}: {said}; the file holds JSON, not TOML") from None
    except RecursionError:
        raise CliError(f"{label}: not usable TOML: nested too deeply") from None


def toml_error_words(exc: BaseException) -> str:
    """A TOML syntax error in words, the place first: ``not valid TOML (line 1, column 3): Expected ...``
    (``tomllib`` says ``Expected ... (at line 1, column 3)``)."""
    text = str(exc)
    m = re.fullmatch(r"(?s)(.*) \(at line (\d+), column (\d+)\)", text)
    if m:
        return f"not valid TOML (line {m[2]}, column {m[3]}): {m[1]}"
    m = re.fullmatch(r"(?s)(.*) \(at end of document\)", text)
    if m:
        return f"not valid TOML (at the end of the file): {m[1]}"
    return f"not valid TOML: {text}"


def named_error(label: str, path: str | os.PathLike[str], exc: BaseException | str) -> CliError:
    """The :class:`CliError` for a reader's refusal of the file ``path`` given as ``label``
    (``--catalog list.json``): ``"{label}: {what the reader said}"``, the reader's own mention of the file
    dropped (``camera file c.toml: intrinsics.fy: is required`` -> ``--camera-file c.toml: intrinsics.fy:
    is required``), so that every error names the option first and the file once."""
    text = str(exc)
    names = {str(path), str(Path(path)), str(Path(path).expanduser())}
    for name in sorted(names, key=len, reverse=True):
        for noun in ("camera file ", "catalog file ", "cannot read catalog file ", ""):
            lead = f"{noun}{name}"
            if text.startswith(lead + ": "):
                rest = text[len(lead) + 2:]
                return CliError(f"{label}: {'cannot read it: ' if noun.startswith('cannot') else ''}{rest}")
            if text.startswith(lead + " is "):
                return CliError(f"{label}: {text[len(lead) + 4:]}")
        if text.endswith(f": {name}"):
            return CliError(f"{label}: {text[:-len(name) - 2]}")
    return CliError(f"{label}: {text}")


def typed_option(args: Any, dest: str, default: str) -> str:
    """The option string the user typed for ``dest`` (``--camera`` or ``--camera-file``), recorded by
    :class:`TypedStore`, else ``default``."""
    return str(getattr(args, f"{dest}_typed", None) or default)


class TypedStore(argparse.Action):
    """``store``, also recording which of the option's names was typed (``<dest>_typed``): for an option with
    an old name, so that its errors name what the user typed."""

    def __call__(self, parser: argparse.ArgumentParser, namespace: argparse.Namespace, values: Any,
                 option_string: str | None = None) -> None:
        setattr(namespace, self.dest, values)
        setattr(namespace, f"{self.dest}_typed", option_string)


__all__ = ["TEXT_KINDS", "TOML_KINDS", "TypedStore", "check_input_file", "named_error", "toml_error_words", "typed_option"]
