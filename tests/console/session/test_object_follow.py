"""An object merged away or removed by map fusion while the operator uses it (console/session/object_follow.py):
the selection and a goal chosen by object follow the merge to the surviving object, with a notice naming
both, or are dropped with a notice; registered and mission stops are told; no id that left the map stays.

Fusion is driven through the session's own map update (:meth:`Session.spawn` of crafted captures, as the
mapping job spawns a capture): the duplicate chair of the noisy tour (tests/pipeline/mapping/test_map_merge.py)
and its false chair that a later look does not see (test_map_misses.py). World frame, z up [m].
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import pytest

from console.session.session import NOTICE, SELECTION, RunStatus, Session, SessionError
from pipeline.scene import Scene
from tests.pipeline.mapping import test_map_merge as merge_case
from tests.pipeline.mapping import test_map_misses as miss_case

START = (2.5, 0.7, 0.0)


@pytest.fixture()
def session(tmp_path: Path) -> Session:
    return Session(tmp_path / "s", start=START, autosave=False)


def _heard(s: Session) -> list[tuple[str, Any]]:
    events: list[tuple[str, Any]] = []
    s.subscribe(lambda topic, payload: events.append((topic, payload)))
    return events


def _notices(events: list[tuple[str, Any]]) -> list[str]:
    return [f"{p.title}: {p.body}" for t, p in events if t == NOTICE]


def _spawn(s: Session, capture: Scene) -> None:
    s.spawn(capture, origin=f"capture {capture.captures[0].id}")


def _two_chairs(s: Session) -> None:
    """office_chair-1 and office_chair-2: one chair mapped twice (0.65 m apart)."""
    c = merge_case
    _spawn(s, c._capture("a", (1.2, -1.5, 0.35), c._chair("office_chair-1", (1.2, 2.55, 0.525), "a", (250, 60, 420, 360))))
    _spawn(s, c._capture("b", (1.8, -1.7, 0.35), c._chair("office_chair-1", (1.8, 2.3, 0.525), "b", (200, 60, 370, 360))))
    assert {o.id for o in s.scene.objects} == {"office_chair-1", "office_chair-2"}


def _merge(s: Session) -> None:
    """A view between the two pulls one onto the other: office_chair-2 merged into office_chair-1."""
    c = merge_case
    _spawn(s, c._capture("c", (1.5, 1.2, 0.35), c._chair("office_chair-1", (1.45, 2.35, 0.525), "c", (250, 60, 420, 360))))
    assert [o.id for o in s.scene.objects] == ["office_chair-1"]


def _beside(s: Session, goal: Any, oid: str) -> float:
    """Distance [m] in plan from ``goal`` to the centre of object ``oid``."""
    return math.dist(goal[:2], s.scene.object(oid).position[:2])


def test_the_selected_object_merged_away_is_replaced_by_the_one_it_was_merged_into(session: Session) -> None:
    _two_chairs(session)
    session.select("office_chair-2")
    events = _heard(session)
    _merge(session)
    assert session.selected is not None and session.selected.id == "office_chair-1"
    assert (SELECTION, "office_chair-1") in events
    assert "Selection follows the merge: office_chair-2 was merged into office_chair-1: office_chair-1 is selected" \
        in _notices(events)
    assert session.resolve_object("office_chair-2") == "office_chair-1"  # a stale pick follows too


def test_a_goal_chosen_by_object_is_planned_again_beside_the_object_it_was_merged_into(session: Session) -> None:
    _two_chairs(session)
    res, obj, _ = session.go_to_object("office_chair-2")
    assert res.ok and obj.id == "office_chair-2"
    before = session.route_snapshot().candidate_goal
    events = _heard(session)
    _merge(session)
    after = session.route_snapshot().candidate_goal
    assert after is not None and after != before
    assert _beside(session, after, "office_chair-1") < 1.5  # beside the chair that stays
    assert "Goal follows the merge: office_chair-2 was merged into office_chair-1: the candidate is planned again " \
        "beside office_chair-1" in _notices(events)
    res, obj, _ = session.go_to_object("office_chair-2")  # "go to office_chair-2" after the merge: its survivor
    assert res.ok and obj.id == "office_chair-1"


def test_registered_and_mission_stops_beside_a_merged_object_are_told_and_kept(session: Session) -> None:
    _two_chairs(session)
    res, _, _ = session.go_to_object("office_chair-2")
    assert res.ok
    session.register()
    stop = tuple(session.route_snapshot().registered[-1][-1])
    session.set_run(RunStatus("running", 0, 0.2))
    events = _heard(session)
    _merge(session)
    said = _notices(events)
    assert any(n.startswith("Stop follows the merge: office_chair-2 was merged into office_chair-1: the running "
                            "mission stop 1 at") for n in said), said
    assert session.route_snapshot().registered and tuple(session.route_snapshot().registered[-1][-1]) == stop


def test_a_removed_object_clears_the_selection_and_drops_its_goal_with_the_reason(session: Session) -> None:
    c = miss_case
    _spawn(session, c._the_bad_capture())
    assert {o.id for o in session.scene.objects} == {"office_chair-1", "office_chair-2"}
    res, _, _ = session.go_to_object("office_chair-2")
    assert res.ok and session.route_snapshot().candidate_goal is not None
    session.select("office_chair-2")
    events = _heard(session)
    look = c._capture("look", (2.0, 1.0, 0.35), math.pi / 2,
                      c._obj("office_chair-1", "office_chair", (1.35, 2.45, 0.525), c.CHAIR, "look", (40, 60, 260, 380)))
    _spawn(session, look)
    assert [o.id for o in session.scene.objects] == ["office_chair-1"]
    assert session.selected is None and session.route_snapshot().candidate_goal is None
    said = _notices(events)
    assert any(n.startswith("Selection cleared: office_chair-2 left the map: seen by one capture only") for n in said), said
    assert any(n.startswith("Goal dropped: the candidate went beside office_chair-2, which left the map (seen by one "
                            "capture only") for n in said), said
    assert (SELECTION, None) in events
    with pytest.raises(SessionError, match=r"office_chair-2 was removed from the map: seen by one capture only"):
        session.go_to_object("office_chair-2")
    with pytest.raises(SessionError, match=r"no object 'nothing-9'"):
        session.resolve_object("nothing-9")


def test_after_an_undo_of_the_merge_the_id_is_its_own_again(session: Session) -> None:
    _two_chairs(session)
    _merge(session)
    session.undo_edit()
    assert {o.id for o in session.scene.objects} == {"office_chair-1", "office_chair-2"}
    assert session.resolve_object("office_chair-2") == "office_chair-2"
