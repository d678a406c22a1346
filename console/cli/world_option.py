"""``--world FILE``: the simulator's hidden room, read for ``morphonavi console`` and ``morphonavi search``, every
problem said in words naming the option (a folder, another kind of MorphoNavi file, unreadable JSON, a bad
field), never an errno."""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

from console.cli.errors import CliError

WORLD_EXAMPLE = "examples/worlds/office.world.json"


def load_world_option(path: Path | None, option: str = "--world") -> Any:
    """The simulator's room from ``--world`` (``None``: the paper's room); :class:`CliError` in words."""
    from console.link.world_file import WorldError, load_world, paper_world

    if path is None:
        return paper_world()
    p = Path(path).expanduser()
    if p.is_dir():
        raise CliError(f"{option} {path}: is a folder; give a world file such as {WORLD_EXAMPLE}")
    if p.exists() and not os.access(p, os.R_OK):
        raise CliError(f"{option} {path}: cannot read it: no permission to read it")
    if p.is_file():  # empty, not text, or another MorphoNavi file: said before it is read as a world
        from console.cli.input_files import check_input_file

        check_input_file(p, "world", option)
    try:
        return load_world(p)
    except WorldError as exc:
        raise CliError(f"{option} {exc}") from None
    except OSError as exc:
        from pipeline.file_kind import os_error_words

        raise CliError(f"{option} {path}: cannot read it: {os_error_words(exc, p)}") from None


__all__ = ["WORLD_EXAMPLE", "load_world_option"]
