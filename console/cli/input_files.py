"""The first check of every file a ``morphonavi`` command reads: it exists, is a file, is not empty, and is not
another kind of MorphoNavi file (:mod:`pipeline.file_kind`), before the command reads it as its own.

Each refusal names the option (or the argument) as typed, what the file is and what the command wants
(``--known-space history.json is a console undo history (morphonavi-history, ...), not a known space: ...``),
never an errno or a codec's message.
"""

from __future__ import annotations

import os
from pathlib import Path

from console.cli.errors import CliError

TEXT_KINDS = ("scene", "session", "history", "mission", "scene_graph", "search_result", "search_bench",
              "known_space", "json_schema", "world", "dataset_camera", "dataset_index", "bench_report",
              "camera_toml", "catalog")
"""Kinds that are text (JSON or TOML): a file expected to be one of them must be UTF-8 text."""


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
        CliError: Missing, a folder, unreadable, empty, not UTF-8 text where JSON is wanted, or of another
            MorphoNavi kind (naming what it is and which command reads it).
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
    return p


__all__ = ["TEXT_KINDS", "check_input_file"]
