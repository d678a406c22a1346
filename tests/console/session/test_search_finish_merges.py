"""The search's last approach follows its found target through map fusion (console/session/search_finish.py),
as the console's selection and goals do (console/session/object_follow.py): a target merged into another object
while the search goes to it is approached beside the object it was merged into (a step names both, the result's
target is the survivor), not refused as "not reachable"; a target removed from the map ends the search
*found, not reached* with the reason.

Fusion is driven through the session's own map update (:meth:`Session.spawn` of crafted captures, as the
mapping job spawns a capture): the duplicate chair of the noisy tour (tests/pipeline/mapping/test_map_merge.py)
and its false chair that a later look does not see (test_map_misses.py). World frame, z up [m].
"""

from __future__ import annotations

import math
from pathlib import Path
from types import SimpleNamespace

import pytest

from console.session.search import SearchConfig, SearchJob, SearchResult
from console.session.session import Session
from pipeline.scene import Scene
from tests.pipeline.mapping import test_map_merge as merge_case
from tests.pipeline.mapping import test_map_misses as miss_case

START = (2.5, 0.7, 0.0)


@pytest.fixture()
def session(tmp_path: Path) -> Session:
    return Session(tmp_path / "s", start=START, autosave=False)


def _spawn(s: Session, capture: Scene) -> None:
    s.spawn(capture, origin=f"capture {capture.captures[0].id}")


def _job(s: Session, goals: list[tuple[tuple[float, ...], str]], captures: list[str]) -> SearchJob:
    """A search job on ``s`` whose moves arrive (recorded in ``goals``) and whose captures map nothing new."""
    link = SimpleNamespace(latest_state=lambda: SimpleNamespace(position=START, yaw=0.0, battery=0.9),
                           hold=lambda: None)
    mapping = SimpleNamespace(run_as=lambda what: captures.append(what) or True)
    job = SearchJob(s, link, mapping, runner=None)  # type: ignore[arg-type]
    job.config = SearchConfig("office chair", max_captures=3, target_height=1.0)
    job.result = SearchResult(target="office chair")
    job._go = lambda goal, what: goals.append((tuple(goal), what)) or None  # type: ignore[method-assign]
    return job


def test_a_found_target_merged_into_another_is_approached_beside_the_survivor(session: Session) -> None:
    c = merge_case
    _spawn(session, c._capture("a", (1.2, -1.5, 0.35),
                               c._chair("office_chair-1", (1.2, 2.55, 0.525), "a", (250, 60, 420, 360))))
    _spawn(session, c._capture("b", (1.8, -1.7, 0.35),
                               c._chair("office_chair-1", (1.8, 2.3, 0.525), "b", (200, 60, 370, 360))))
    found = session.scene.object("office_chair-2")  # the search found this one and goes beside it
    goals: list[tuple[tuple[float, ...], str]] = []
    job = _job(session, goals, [])
    job.result.target_id = found.id  # type: ignore[union-attr]
    # a capture between the two (the search's own, or the operator's) shows one chair mapped twice
    _spawn(session, c._capture("c", (1.5, 1.2, 0.35),
                               c._chair("office_chair-1", (1.45, 2.35, 0.525), "c", (250, 60, 420, 360))))
    assert [o.id for o in session.scene.objects] == ["office_chair-1"]
    reason = job._finish(found)
    assert reason == "found", (reason, job.steps)
    assert len(goals) == 1 and goals[0][1] == "beside office_chair-1", goals
    kept = session.scene.object("office_chair-1")
    assert math.dist(goals[0][0][:2], kept.position[:2]) < 1.5  # beside the chair that stays
    assert job.result.found and job.result.target_id == "office_chair-1"  # type: ignore[union-attr]
    assert job.result.target_position == [round(v, 3) for v in kept.position]  # type: ignore[union-attr]
    assert any("office_chair-2 was merged into office_chair-1 (one object mapped twice): going beside "
               "office_chair-1" in step for step in job.steps), job.steps


def test_a_found_target_removed_from_the_map_ends_the_search_with_the_reason(session: Session) -> None:
    c = miss_case
    _spawn(session, c._the_bad_capture())
    found = session.scene.object("office_chair-2")
    goals: list[tuple[tuple[float, ...], str]] = []
    captures: list[str] = []
    job = _job(session, goals, captures)
    look = c._capture("look", (2.0, 1.0, 0.35), math.pi / 2,
                      c._obj("office_chair-1", "office_chair", (1.35, 2.45, 0.525), c.CHAIR, "look", (40, 60, 260, 380)))
    _spawn(session, look)  # the false chair, seen by one capture only, is not seen by this look: removed
    assert [o.id for o in session.scene.objects] == ["office_chair-1"]
    reason = job._finish(found)
    assert reason.startswith("found, not reached: office_chair-2 was removed from the map: seen by one capture "
                             "only"), reason
    assert not goals and not captures  # no move and no look towards an object that is not there
    assert not job.result.found  # type: ignore[union-attr]


def test_a_found_target_still_in_the_map_is_approached_as_before(session: Session) -> None:
    c = merge_case
    _spawn(session, c._capture("a", (1.2, -1.5, 0.35),
                               c._chair("office_chair-1", (1.2, 2.55, 0.525), "a", (250, 60, 420, 360))))
    goals: list[tuple[tuple[float, ...], str]] = []
    job = _job(session, goals, [])
    assert job._finish(session.scene.object("office_chair-1")) == "found"
    assert [what for _, what in goals] == ["beside office_chair-1"]
    assert not any("merged" in step for step in job.steps), job.steps
