"""``morphonavi console``: its folder options checked before anything starts (no server, no recording).

``--session DIR`` (written: the session, its recordings) and ``--scene DIR`` (read: the watched folder)
must be folders, or not exist yet (they are created), and must not hold one another (the watched folder
would read the session's own files). A file given for either is named with what it is and what to give
instead (``--session .../session.json: is the console's session file; give its folder: --session ...``),
never the operating system's "[Errno 17] File exists".
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from console.cli.errors import CliError


def not_a_folder(option: str, path: Path, what: str, example: str) -> str:
    """The refusal of a file given where a folder is wanted: what the file is, and ``what`` to give instead."""
    from pipeline.file_kind import KINDS, describe_file

    kind = describe_file(path)
    if option == "--session" and kind == "session":
        return (f"{option} {path}: is the console's session file; give the folder holding it: "
                f"{option} {path.parent}")
    found = f"is {KINDS[kind].what}" if kind not in ("json", "unknown") else "is a file"
    hint = ""
    if option == "--scene" and kind == "scene":
        hint = f"; to add this scene to the map, copy it into the watched folder (e.g. {path.parent / 'scenes'})"
    return f"{option} {path}: {found}, not a folder: {what}, e.g. {option} {example}{hint}"


def check_console_folders(args: Any, default_scenes: Path) -> None:
    """Refuse unusable ``--session`` / ``--scene`` folders before the console starts.

    Raises:
        CliError: A file where a folder is wanted, a path under a file, or the two folders nested.
    """
    from console.cli.outputs import OutputError, check_folders_apart

    session = Path(args.session).expanduser()
    scenes = Path(args.scene).expanduser() if args.scene is not None else default_scenes
    for option, path, what in (("--session", session, "give the folder the console saves the session in "
                                                       "(created if missing)"),
                               ("--scene", scenes, "give the folder the console watches for scene files "
                                                   "(created if missing)")):
        if path.exists() and not path.is_dir():
            raise CliError(not_a_folder(option, path, what, str(path.parent / ("session" if option == "--session"
                                                                                  else "scenes"))))
        for parent in path.parents:  # a file on the way: mkdir would fail with "Not a directory"
            if parent.exists():
                if not parent.is_dir():
                    raise CliError(f"{option} {path}: {parent} is a file, not a folder")
                break
    try:
        check_folders_apart([("--session", session), ("--scene", scenes)])
    except OutputError as exc:
        raise CliError(str(exc)) from None


__all__ = ["check_console_folders", "not_a_folder"]
