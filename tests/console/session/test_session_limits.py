"""The session file is size-checked before it is parsed, and a file of another kind under its name is named."""

from __future__ import annotations

import json
import time
from pathlib import Path

import pytest

from console.session.session_store import read_session_file
from console.session.session_types import SessionError
from pipeline.file_kind import MAX_BYTES, MB


def test_a_session_file_over_the_limit_is_refused_unread_with_the_numbers(tmp_path: Path) -> None:
    path = tmp_path / "session.json"
    with open(path, "wb") as f:  # sparse: 60 MB on paper, nothing on disk
        f.truncate(MAX_BYTES["session"] + 10 * MB)
    t0 = time.monotonic()
    with pytest.raises(SessionError) as e:
        read_session_file(path, tmp_path)
    assert time.monotonic() - t0 < 5.0  # from its size alone, not after parsing
    assert "session.json is 60.0 MB, over the 50 MB limit for a session file: not read" in str(e.value)


def test_a_session_file_at_the_limit_is_read(tmp_path: Path) -> None:
    path = tmp_path / "session.json"
    head, tail = '{"version": 2, "kind": "morphonavi-session", "pad": "', '"}'
    path.write_text(head + "x" * (MAX_BYTES["session"] - len(head) - len(tail)) + tail)
    assert path.stat().st_size == MAX_BYTES["session"]
    assert read_session_file(path, tmp_path)["kind"] == "morphonavi-session"


@pytest.mark.parametrize("data,said", [
    ({"version": 1, "objects": []}, "session.json is a scene, not a console session"),
    ({"version": 1, "id": "x", "bounds": {}, "segments": []}, "session.json is a mission"),
])
def test_another_kind_under_the_session_name_is_named(tmp_path: Path, data: dict, said: str) -> None:
    (tmp_path / "session.json").write_text(json.dumps(data))
    with pytest.raises(SessionError, match=said):
        read_session_file(tmp_path / "session.json", tmp_path)


def test_the_autosave_notice_says_the_failure_in_words(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    import errno

    from console.session import session_store
    from console.session.session import Session
    from console.session.topics import NOTICE
    from pipeline.scene import Scene, SceneObject, Source

    s = Session(tmp_path / "s", start=(2.5, 0.7, 0.0))
    told: list = []
    s.subscribe(lambda topic, payload: told.append(payload) if topic == NOTICE else None)

    def refuse(path: Path, data: dict) -> None:
        raise OSError(errno.EROFS, "Read-only file system", str(path))

    monkeypatch.setattr(session_store, "write_session_file", refuse)
    s.spawn(Scene(objects=(SceneObject("box-1", "cardboard_box", (1.0, 5.0, 0.2), (0.4, 0.4, 0.4),
                                       source=Source(method="ground_truth")),)))
    [notice] = [n for n in told if n.title == "Changes are not being saved"]
    assert f"{s.folder} is on a read-only file system" in notice.body and "Errno" not in notice.body
