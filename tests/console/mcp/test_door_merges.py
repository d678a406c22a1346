"""The agent door follows objects through map fusion (console/mcp/door.py, console/mcp/object_names.py), as the
console's selection and Go to do (console/session/object_follow.py): ``plan_to_object`` with an id merged into
another object plans beside the object it was merged into, saying so (naming both) in its answer and in the
operator's notice; an id removed from the map is refused with the reason; an id never mapped is refused listing
the labels, as before. ``plan_to_object`` is the only door request that takes an object id (``propose_search``
takes a class to find).

Fusion is driven through the session's own map update (:meth:`Session.spawn` of crafted captures): the duplicate
chair of the noisy tour (tests/pipeline/mapping/test_map_merge.py) and its false chair that a later look does not
see (test_map_misses.py). World frame, z up [m].
"""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from console.mcp.door import AgentDoor, AgentError
from console.session.session import NOTICE, Session
from pipeline.scene import Scene
from tests.pipeline.mapping import test_map_merge as merge_case
from tests.pipeline.mapping import test_map_misses as miss_case

START = (2.5, 0.7, 0.0)


@pytest.fixture()
def door(tmp_path: Path):
    d = AgentDoor(Session(tmp_path / "s", start=START, autosave=False), robot_spec="sim")
    yield d
    d.close()


def _spawn(s: Session, capture: Scene) -> None:
    s.spawn(capture, origin=f"capture {capture.captures[0].id}")


def _merged(s: Session) -> None:
    """office_chair-1 and office_chair-2 mapped apart, then a view between them: office_chair-2 merged into 1."""
    c = merge_case
    _spawn(s, c._capture("a", (1.2, -1.5, 0.35), c._chair("office_chair-1", (1.2, 2.55, 0.525), "a", (250, 60, 420, 360))))
    _spawn(s, c._capture("b", (1.8, -1.7, 0.35), c._chair("office_chair-1", (1.8, 2.3, 0.525), "b", (200, 60, 370, 360))))
    assert {o.id for o in s.scene.objects} == {"office_chair-1", "office_chair-2"}
    _spawn(s, c._capture("c", (1.5, 1.2, 0.35), c._chair("office_chair-1", (1.45, 2.35, 0.525), "c", (250, 60, 420, 360))))
    assert [o.id for o in s.scene.objects] == ["office_chair-1"]


def test_plan_to_an_object_merged_away_plans_beside_the_survivor_naming_both(door: AgentDoor) -> None:
    s = door.session
    _merged(s)
    notices: list[str] = []
    s.subscribe(lambda topic, p: notices.append(f"{p.title}: {p.body}") if topic == NOTICE else None)
    out = door.call("plan_to_object", {"object": "office_chair-2", "why": "the agent read list_objects earlier"},
                    allow_actions=True)
    assert out["object"] == {"id": "office_chair-1", "label": "office_chair"}, out
    assert out["merged"] == ("office_chair-2 was merged into office_chair-1 (one object mapped twice): planned "
                             "beside office_chair-1"), out
    goal = s.route_snapshot().candidate_goal
    assert goal is not None and tuple(round(v, 3) for v in goal) == tuple(out["goal"])
    assert math.dist(goal[:2], s.scene.object("office_chair-1").position[:2]) < 1.5  # beside the chair that stays
    assert any(n.startswith("Agent planned a candidate: to office chair office_chair-1 (beside it, by walking); "
                            "office_chair-2 was merged into office_chair-1") for n in notices), notices


def test_plan_to_an_object_removed_from_the_map_is_refused_with_the_reason(door: AgentDoor) -> None:
    s, c = door.session, miss_case
    _spawn(s, c._the_bad_capture())
    _spawn(s, c._capture("look", (2.0, 1.0, 0.35), math.pi / 2,
                         c._obj("office_chair-1", "office_chair", (1.35, 2.45, 0.525), c.CHAIR, "look",
                                (40, 60, 260, 380))))
    assert [o.id for o in s.scene.objects] == ["office_chair-1"]
    with pytest.raises(AgentError, match=r"^object: office_chair-2 was removed from the map: seen by one capture only"):
        door.call("plan_to_object", {"object": "office_chair-2"}, allow_actions=True)
    assert s.route_snapshot().candidate_goal is None


def test_ids_and_labels_in_the_map_and_unknown_names_answer_as_before(door: AgentDoor) -> None:
    s = door.session
    _merged(s)
    out = door.call("plan_to_object", {"object": "office_chair-1"}, allow_actions=True)
    assert out["object"]["id"] == "office_chair-1" and "merged" not in out
    out = door.call("plan_to_object", {"object": "office chair"}, allow_actions=True)  # a label
    assert out["object"]["id"] == "office_chair-1" and "merged" not in out
    with pytest.raises(AgentError, match=r"^object: no object with id or label 'nothing-9' in the scene \(labels: "
                                         r"office_chair\)"):
        door.call("plan_to_object", {"object": "nothing-9"}, allow_actions=True)


def test_the_agents_candidate_follows_a_later_merge_of_its_object_and_stays_the_agents(door: AgentDoor) -> None:
    """plan_to_object, then a capture whose fusion merges that object away: the candidate is planned again beside
    the surviving object (as the console's Go to is), the notice names both, and the path is still the agent's."""
    s, c = door.session, merge_case
    _spawn(s, c._capture("a", (1.2, -1.5, 0.35), c._chair("office_chair-1", (1.2, 2.55, 0.525), "a", (250, 60, 420, 360))))
    _spawn(s, c._capture("b", (1.8, -1.7, 0.35), c._chair("office_chair-1", (1.8, 2.3, 0.525), "b", (200, 60, 370, 360))))
    out = door.call("plan_to_object", {"object": "office_chair-2", "why": "the chair by the desk"}, allow_actions=True)
    assert out["object"]["id"] == "office_chair-2" and "merged" not in out, out
    before = s.route_snapshot().candidate_goal
    assert before is not None and door.call("mission_state")["route"]["candidate_by_agent"] is True
    notices: list[str] = []
    s.subscribe(lambda topic, p: notices.append(f"{p.title}: {p.body}") if topic == NOTICE else None)
    _spawn(s, c._capture("c", (1.5, 1.2, 0.35), c._chair("office_chair-1", (1.45, 2.35, 0.525), "c", (250, 60, 420, 360))))
    assert [o.id for o in s.scene.objects] == ["office_chair-1"]
    assert ("Goal follows the merge: office_chair-2 was merged into office_chair-1: the candidate is planned again "
            "beside office_chair-1") in notices, notices
    after = s.route_snapshot().candidate_goal
    assert after is not None and after != before, (before, after)  # planned again, not only kept
    assert door.agent_goal == after
    state = door.call("mission_state")
    assert state["route"]["candidate_by_agent"] is True, state["route"]
    res, obj, _ = s.go_to_object("office_chair-1")  # what the console's own Go to plans beside the survivor
    assert res.ok and obj.id == "office_chair-1" and s.route_snapshot().candidate_goal == after


def test_the_agents_candidate_is_dropped_when_a_later_capture_removes_its_object(door: AgentDoor) -> None:
    s, c = door.session, miss_case
    _spawn(s, c._the_bad_capture())
    out = door.call("plan_to_object", {"object": "office_chair-2"}, allow_actions=True)
    assert out["object"]["id"] == "office_chair-2" and s.route_snapshot().candidate_goal is not None
    notices: list[str] = []
    s.subscribe(lambda topic, p: notices.append(f"{p.title}: {p.body}") if topic == NOTICE else None)
    _spawn(s, c._capture("look", (2.0, 1.0, 0.35), math.pi / 2,
                         c._obj("office_chair-1", "office_chair", (1.35, 2.45, 0.525), c.CHAIR, "look",
                                (40, 60, 260, 380))))
    assert [o.id for o in s.scene.objects] == ["office_chair-1"]
    assert s.route_snapshot().candidate_goal is None
    assert any(n.startswith("Goal dropped: the candidate went beside office_chair-2, which left the map (seen by one "
                            "capture only") for n in notices), notices
    assert door.call("mission_state")["route"]["candidate_by_agent"] is False


def test_the_agent_panel_labels_the_candidate_planned_again_after_the_merge(door: AgentDoor) -> None:
    """The Agent panel redraws its label on the route event of the new candidate: it already reads the new goal."""
    import viser

    from console.views.approval_view import ApprovalView

    s, c = door.session, merge_case
    _spawn(s, c._capture("a", (1.2, -1.5, 0.35), c._chair("office_chair-1", (1.2, 2.55, 0.525), "a", (250, 60, 420, 360))))
    _spawn(s, c._capture("b", (1.8, -1.7, 0.35), c._chair("office_chair-1", (1.8, 2.3, 0.525), "b", (200, 60, 370, 360))))
    server = viser.ViserServer(host="127.0.0.1", port=0, verbose=False)
    view = ApprovalView(server, s, door)
    try:
        door.call("plan_to_object", {"object": "office_chair-2"}, allow_actions=True)
        assert view.labelled
        _spawn(s, c._capture("c", (1.5, 1.2, 0.35), c._chair("office_chair-1", (1.45, 2.35, 0.525), "c",
                                                             (250, 60, 420, 360))))
        after = s.route_snapshot().candidate_goal
        assert after is not None and door.agent_goal == after
        assert view.labelled and view.label_spots[0].position[:2] == pytest.approx(after[:2])
    finally:
        view.close()
        server.stop()
