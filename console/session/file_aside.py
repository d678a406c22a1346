"""Keeping a bad file aside: moved or copied to ``<name>.unreadable-<time>`` beside it (``-2``, ``-3``...
when that name is taken), so nothing the operator may need is lost when the console starts over.

The one place that chooses the name and does the move or copy, for the session file
(:func:`console.session.session_store.keep_aside`, which raises :class:`~console.session.session_types.SessionError`
saying what to do) and the undo history (:func:`console.session.history_file.set_aside`, which returns the
words for the operator). ``<time>`` is local time, ``YYYYmmdd-HHMMSS``.
"""

from __future__ import annotations

import shutil
import time
from pathlib import Path

UNREADABLE = ".unreadable-"
"""What the kept file's name adds to the original's, before the time."""


def aside_path(path: Path, stamp: str | None = None) -> Path:
    """The first free ``<name>.unreadable-<stamp>[-n]`` beside ``path`` (``stamp``: now, ``YYYYmmdd-HHMMSS``)."""
    stamp = time.strftime("%Y%m%d-%H%M%S") if stamp is None else stamp
    kept, n = path.with_name(f"{path.name}{UNREADABLE}{stamp}"), 1
    while kept.exists():
        n += 1
        kept = path.with_name(f"{path.name}{UNREADABLE}{stamp}-{n}")
    return kept


def put_aside(path: Path, move: bool) -> Path:
    """Move (``move``) or copy ``path`` to :func:`aside_path`; returns where it was kept.

    Raises ``OSError`` when the folder does not allow it (read-only, full, the file gone)."""
    kept = aside_path(path)
    if move:
        path.replace(kept)
    else:
        shutil.copy2(path, kept)
    return kept


__all__ = ["UNREADABLE", "aside_path", "put_aside"]
