"""One helper keeps a bad file aside for the session file and the undo history alike
(console/session/file_aside.py): the ``<name>.unreadable-<time>[-n]`` name, the move or the copy; the
session's caller raises saying what to do, the history's returns the words."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from console.session import file_aside
from console.session.file_aside import aside_path, put_aside
from console.session.history_file import set_aside
from console.session.session_store import keep_aside
from console.session.session_types import SessionError


def test_the_name_takes_the_next_number_when_taken(tmp_path: Path) -> None:
    f = tmp_path / "session.json"
    f.write_text("x")
    assert aside_path(f, "20261202-101500").name == "session.json.unreadable-20261202-101500"
    (tmp_path / "session.json.unreadable-20261202-101500").write_text("old")
    (tmp_path / "session.json.unreadable-20261202-101500-2").write_text("older")
    assert aside_path(f, "20261202-101500").name == "session.json.unreadable-20261202-101500-3"
    assert re.fullmatch(r"session\.json\.unreadable-\d{8}-\d{6}", aside_path(f).name)


def test_moved_or_copied_the_same_way_for_the_session_and_the_history(tmp_path: Path,
                                                                      monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(file_aside.time, "strftime", lambda fmt: "20261202-101500")
    s, h = tmp_path / "session.json", tmp_path / "history.json"
    for f in (s, h):
        f.write_text(f.name)
    kept = keep_aside(s, "bad", move=False)
    assert s.exists() and kept.read_text() == "session.json" and kept.name == "session.json.unreadable-20261202-101500"
    assert keep_aside(s, "bad", move=True).name == "session.json.unreadable-20261202-101500-2" and not s.exists()
    assert set_aside(h, move=False) == "a copy kept as history.json.unreadable-20261202-101500" and h.exists()
    assert set_aside(h, move=True) == "kept aside as history.json.unreadable-20261202-101500-2" and not h.exists()
    assert put_aside(tmp_path / "session.json.unreadable-20261202-101500", move=True).name.endswith("-101500.unreadable-20261202-101500")


def test_a_folder_that_refuses_raises_for_the_session_and_gives_words_for_the_history(tmp_path: Path) -> None:
    gone = tmp_path / "gone.json"  # nothing to move: the same OSError a read-only folder gives
    with pytest.raises(SessionError, match=r"cannot be kept aside .*--fresh .*--session DIR"):
        keep_aside(gone, "bad", move=True)
    assert set_aside(gone, move=False).startswith("not kept aside: no such file or directory")
