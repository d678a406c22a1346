"""``Session.resolve_object`` tells an object removed from the map (:class:`RemovedObject`, saying why) from one
never in it (:class:`UnknownObject`) by type, both :class:`SessionError` (console/session/object_follow.py); the
search's last approach tells them apart the same way (console/session/search_finish.py). World frame [m]."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from console.session.object_follow import RemovedObject, UnknownObject
from console.session.session import Session
from console.session.session_types import SessionError
from tests.console.session.test_search_finish_merges import _job
from tests.pipeline.mapping import test_map_merge as merge_case
from tests.pipeline.mapping import test_map_misses as miss_case

START = (2.5, 0.7, 0.0)


@pytest.fixture()
def session(tmp_path: Path) -> Session:
    return Session(tmp_path / "s", start=START, autosave=False)


def _spawn(s: Session, capture) -> None:  # noqa: ANN001 - a crafted capture Scene
    s.spawn(capture, origin=f"capture {capture.captures[0].id}")


def test_removed_and_unknown_ids_raise_their_own_types(session: Session) -> None:
    c = miss_case
    _spawn(session, c._the_bad_capture())
    _spawn(session, c._capture("look", (2.0, 1.0, 0.35), math.pi / 2,
                               c._obj("office_chair-1", "office_chair", (1.35, 2.45, 0.525), c.CHAIR, "look",
                                      (40, 60, 260, 380))))
    assert [o.id for o in session.scene.objects] == ["office_chair-1"]
    with pytest.raises(RemovedObject, match=r"^office_chair-2 was removed from the map: seen by one capture only"):
        session.resolve_object("office_chair-2")
    with pytest.raises(UnknownObject, match=r"^no object 'nothing-9' in the map$"):
        session.resolve_object("nothing-9")
    assert issubclass(RemovedObject, SessionError) and issubclass(UnknownObject, SessionError)  # callers keep working
    assert not issubclass(RemovedObject, UnknownObject) and not issubclass(UnknownObject, RemovedObject)


def test_a_found_target_deleted_by_hand_ends_the_search_saying_it_is_no_longer_in_the_map(session: Session) -> None:
    c = merge_case
    _spawn(session, c._capture("a", (1.2, -1.5, 0.35),
                               c._chair("office_chair-1", (1.2, 2.55, 0.525), "a", (250, 60, 420, 360))))
    found = session.scene.object("office_chair-1")
    goals: list[tuple[tuple[float, ...], str]] = []
    job = _job(session, goals, [])
    session.delete_object("office_chair-1")  # neither merged nor removed by fusion: unknown to resolve_object
    reason = job._finish(found)
    assert reason == "found, not reached: office_chair-1 is no longer in the map", (reason, job.steps)
    assert not goals and not job.result.found  # type: ignore[union-attr]
