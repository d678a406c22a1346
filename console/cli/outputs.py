"""One output rule for every ``morphonavi`` command that writes a file (``--out`` and the like).

:func:`check_output` runs before any work: an output path that is one of the command's inputs (the
same file, a link to it or a hard link), or that lies inside an input folder the command reads files
of that kind from (``calibrate photos/ --out photos/board_03.png``), is refused naming both; a folder
or a missing parent folder is refused too. :func:`write_output` then writes atomically (a temporary
file renamed into place, :func:`pipeline.scene.write_text_atomic`) with the user's normal file mode:
``0666`` less the umask for a new file, the old file's mode when one is replaced. Errors are
:class:`OutputError` (an :class:`pipeline.option_values.OptionError`: every command prints it as
``morphonavi <command>: error: ...``, exit status 2), in words, never an errno.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path
from typing import Iterable, Sequence, Union

from pipeline.option_values import OptionError

PathLike = Union[str, "os.PathLike[str]"]


class OutputError(OptionError):
    """An output path that must not be written; the message names the option, the path and why."""


@dataclass(frozen=True)
class InputFolder:
    """A folder the command reads files from: ``what`` (``photo``) and the ``suffixes`` it reads there.

    An output inside it with one of those suffixes would overwrite one of the files read, or be read
    as one of them on the next run; an empty ``suffixes`` means every file in it is read.
    """

    what: str
    path: PathLike
    suffixes: tuple[str, ...] = ()
    recursive: bool = False


Input = Union[tuple[str, "PathLike | None"], InputFolder]


def _same(a: Path, b: Path) -> bool:
    if a.resolve() == b.resolve():
        return True
    try:
        return a.exists() and b.exists() and os.path.samefile(a, b)
    except OSError:
        return False


def _inside(out: Path, folder: Path, recursive: bool) -> bool:
    parent = out.resolve().parent
    root = folder.resolve()
    if recursive:
        return parent == root or root in parent.parents
    return parent == root


def check_output(out: PathLike, inputs: Iterable[Input], option: str = "--out",
                 example: str = "output.json") -> Path:
    """The output path when it may be written; raises :class:`OutputError` otherwise.

    Args:
        out: The output the user gave.
        inputs: ``(what, path)`` for each input file (``None`` paths skipped; a folder path counts
            as every file in it) and :class:`InputFolder` for folders read by suffix.
        option: The output's option for messages (``--out``).
        example: A file name to suggest when ``out`` is a folder (``mission.json``).

    Raises:
        OutputError: ``out`` is a folder, its folder does not exist, it is (a link to) an input, or it
            lies in an input folder among the files read there. The message names both paths.
    """
    target = Path(out).expanduser()
    if target.is_dir():
        raise OutputError(f"{option} {out} is a directory; give a file name such as {target / example}")
    parent = target.parent
    if not parent.is_dir():
        if parent.exists():
            raise OutputError(f"{option} {out}: {parent} is a file, not a folder")
        raise OutputError(f"{option} {out}: the folder {parent} does not exist")
    for item in inputs:
        if isinstance(item, InputFolder):
            folder = Path(item.path).expanduser()
            if not folder.is_dir():
                continue
            if _inside(target, folder, item.recursive) and (
                    not item.suffixes or target.suffix.lower() in item.suffixes):
                kinds = "every file" if not item.suffixes else "its " + "/".join(item.suffixes) + " files"
                raise OutputError(
                    f"{option} {out}: is inside the {item.what} folder {item.path} read by this command "
                    f"({kinds} are read as {item.what}s); writing there would overwrite or add to them: "
                    f"give {option} a file outside it")
            continue
        what, path = item
        if path is None or not str(path):
            continue
        p = Path(path).expanduser()
        if p.is_dir():
            if _inside(target, p, True):
                raise OutputError(
                    f"{option} {out}: is inside the {what} folder {path} read by this command; writing there "
                    f"would overwrite or add to what it reads: give {option} a file outside it")
            continue
        if _same(target, p):
            raise OutputError(f"{option} {out}: is the {what} {path} read by this command; writing there would "
                              f"overwrite it: give {option} another file name")
    return target


def write_error(exc: OSError, out: PathLike, option: str = "--out") -> OutputError:
    """An :class:`OSError` of writing ``out`` in words (no errno): for ``raise write_error(exc, out)``."""
    from pipeline.file_kind import os_error_words

    return OutputError(f"{option} {out}: cannot write: {os_error_words(exc, out)}")


def write_output(out: PathLike, text: str, option: str = "--out") -> Path:
    """Write ``text`` to ``out`` atomically with the user's file mode; :class:`OutputError` in words."""
    from pipeline.scene import write_text_atomic

    try:
        return write_text_atomic(Path(out).expanduser(), text)
    except OSError as exc:
        raise write_error(exc, out, option) from None


def check_folders_apart(folders: Sequence[tuple[str, "PathLike | None"]]) -> None:
    """Refuse two of a command's folder options naming the same folder or one inside the other
    (``console --session X --scene X``: the watched folder would read the session's own files).

    Raises:
        OutputError: Naming both options and paths.
    """
    given = [(o, Path(p).expanduser().resolve()) for o, p in folders if p is not None and str(p)]
    for i, (oa, pa) in enumerate(given):
        for ob, pb in given[i + 1:]:
            if pa == pb:
                raise OutputError(f"{oa} {pa} and {ob} {pb}: the same folder; the console writes into {oa} and "
                                  f"reads {ob}: give them separate folders")
            if pa in pb.parents or pb in pa.parents:
                raise OutputError(f"{oa} {pa} and {ob} {pb}: one folder holds the other; the console writes "
                                  f"into {oa} and reads {ob}: give them separate folders")


__all__ = ["InputFolder", "OutputError", "check_folders_apart", "check_output", "write_error", "write_output"]
