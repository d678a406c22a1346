"""``Session.resolve_object`` tells an object removed from the map (:class:`RemovedObject`, saying why: by map
fusion, or deleted by the operator) from one never in it (:class:`UnknownObject`) by type, both
:class:`SessionError` (console/session/object_follow.py); an Undo of the delete makes the id resolve again. The
search's last approach, the agent's ``plan_to_object`` and Go to tell them apart the same way
(console/session/search_finish.py, console/mcp/object_names.py). World frame [m]."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from console.mcp.door import AgentDoor, AgentError
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


def test_a_found_target_deleted_by_hand_ends_the_search_saying_the_operator_deleted_it(session: Session) -> None:
    c = merge_case
    _spawn(session, c._capture("a", (1.2, -1.5, 0.35),
                               c._chair("office_chair-1", (1.2, 2.55, 0.525), "a", (250, 60, 420, 360))))
    found = session.scene.object("office_chair-1")
    goals: list[tuple[tuple[float, ...], str]] = []
    job = _job(session, goals, [])
    session.delete_object("office_chair-1")  # neither merged nor removed by fusion: deleted by the operator
    reason = job._finish(found)
    assert reason == "found, not reached: office_chair-1 was deleted by the operator", (reason, job.steps)
    assert not goals and not job.result.found  # type: ignore[union-attr]


def _chair_a(s: Session) -> None:
    c = merge_case
    _spawn(s, c._capture("a", (1.2, -1.5, 0.35), c._chair("office_chair-1", (1.2, 2.55, 0.525), "a", (250, 60, 420, 360))))


def test_an_object_the_operator_deleted_is_reported_deleted_and_undo_brings_it_back(session: Session) -> None:
    _chair_a(session)
    session.delete_object("office_chair-1")
    with pytest.raises(RemovedObject, match=r"^office_chair-1 was deleted by the operator$"):
        session.resolve_object("office_chair-1")
    with pytest.raises(RemovedObject, match=r"^office_chair-1 was deleted by the operator$"):
        session.go_to_object("office_chair-1")  # the console's Go to says so too
    assert session.route_snapshot().candidate_goal is None
    session.undo_edit()  # the deletion undone: the id is back
    assert session.resolve_object("office_chair-1") == "office_chair-1"
    res, obj, _ = session.go_to_object("office_chair-1")
    assert res.ok and obj.id == "office_chair-1", res.message
    session.discard()
    session.redo_edit()  # deleted again
    with pytest.raises(RemovedObject, match=r"^office_chair-1 was deleted by the operator$"):
        session.resolve_object("office_chair-1")
    with pytest.raises(UnknownObject):
        session.resolve_object("office_chair-9")  # never in the map: still unknown


def test_the_agent_is_told_the_operator_deleted_the_object(session: Session) -> None:
    _chair_a(session)
    session.delete_object("office_chair-1")
    door = AgentDoor(session, robot_spec="sim")
    try:
        with pytest.raises(AgentError, match=r"^object: office_chair-1 was deleted by the operator$"):
            door.call("plan_to_object", {"object": "office_chair-1", "why": "listed earlier"}, allow_actions=True)
        session.undo_edit()
        out = door.call("plan_to_object", {"object": "office_chair-1", "why": "it is back"}, allow_actions=True)
        assert out["object"]["id"] == "office_chair-1" and "merged" not in out, out
    finally:
        door.close()


def test_an_id_merged_into_an_object_the_operator_deleted_says_the_survivor_was_deleted(session: Session) -> None:
    c = merge_case
    _chair_a(session)
    _spawn(session, c._capture("b", (1.8, -1.7, 0.35),
                               c._chair("office_chair-1", (1.8, 2.3, 0.525), "b", (200, 60, 370, 360))))
    _spawn(session, c._capture("c", (1.5, 1.2, 0.35),
                               c._chair("office_chair-1", (1.45, 2.35, 0.525), "c", (250, 60, 420, 360))))
    assert [o.id for o in session.scene.objects] == ["office_chair-1"]  # office_chair-2 merged into it
    session.delete_object("office_chair-1")
    with pytest.raises(RemovedObject, match=r"^office_chair-1 was deleted by the operator$"):
        session.resolve_object("office_chair-2")


def test_the_newest_of_a_removal_by_fusion_and_a_deletion_speaks_for_the_id(session: Session) -> None:
    c = miss_case
    _spawn(session, c._the_bad_capture())
    look = c._capture("look", (2.0, 1.0, 0.35), math.pi / 2,
                      c._obj("office_chair-1", "office_chair", (1.35, 2.45, 0.525), c.CHAIR, "look", (40, 60, 260, 380)))
    _spawn(session, look)  # fusion removes office_chair-2 (seen by one capture only)
    session.undo_edit()  # office_chair-2 is back
    session.delete_object("office_chair-2")  # then the operator deletes it: the newer news
    with pytest.raises(RemovedObject, match=r"^office_chair-2 was deleted by the operator$"):
        session.resolve_object("office_chair-2")
    session.undo_edit()  # back again; this time fusion removes it: the newer news
    _spawn(session, look)
    assert [o.id for o in session.scene.objects] == ["office_chair-1"]
    with pytest.raises(RemovedObject, match=r"^office_chair-2 was removed from the map: seen by one capture only"):
        session.resolve_object("office_chair-2")
