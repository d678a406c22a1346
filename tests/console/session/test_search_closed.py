"""The search never plans through space no capture has seen (console/session/search.py, search_moves.py,
search_finish.py), on a small known space: when the only spots beside the found target are unseen, the
search never plans a route or switches the session's rule to unknown space allowed: it looks to open the
floor beside the target (a different look each time, every move planned over seen space) and ends
"found, not reached" with where and why when the budget is used; a goal where the robot already is
counts as arrived."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from pipeline.scene import Scene, SceneObject
from planner.grid import CostWeights, Workspace
from planner.object_goal import ObjectGoalError, goal_beside
from planner.route import Route

from console.session.known_space_state import empty_known, grid_for
from console.session.search import SearchConfig, SearchJob, SearchResult

WS = Workspace((0.0, 0.0, 0.0), (5.0, 8.0, 3.0))
MARGIN = 0.35
ROBOT = (2.5, 1.0, 0.0)


def _known(lo: tuple[float, float, float], hi: tuple[float, float, float]):
    """All unknown except the cells whose centres lie in the box ``lo``..``hi`` (seen free)."""
    k = empty_known(WS)
    idx = np.argwhere(np.ones(k.shape, dtype=bool))
    c = k.centers(idx)
    free = np.zeros(k.shape, dtype=bool)
    inside = np.all((c >= np.asarray(lo)) & (c <= np.asarray(hi)), axis=1)
    free[tuple(idx[inside].T)] = True
    return k.updated(free, np.zeros(k.shape, dtype=bool))


class _Cache:
    """The search's grid cache, recording which unknown-space rule was asked for."""

    def __init__(self, scene: Scene, known) -> None:
        self.scene, self.known, self.policies = scene, known, []

    def grid(self, session, policy: str):
        self.policies.append(policy)
        return grid_for(self.scene, WS, MARGIN, self.known, policy)


class _Session:
    """The few session calls the search's last approach makes, recording the planning rule of each goal."""

    def __init__(self, scene: Scene, goal_reply: str = "") -> None:
        self.scene, self.weights, self.plan_unknown = scene, CostWeights(), "closed"
        self.run = SimpleNamespace(active=False, state="idle", message="")
        self.job = SimpleNamespace(message="mapped", fraction=0.5, error=None)
        self.capture, self.known_space = None, None
        self.rules_set: list[bool] = []
        self.goals: list[tuple[tuple[float, ...], str]] = []
        self._reply = goal_reply

    def subscribe(self, fn) -> None:
        pass

    def set_job(self, job) -> None:
        self.job = SimpleNamespace(message=job.message, fraction=job.fraction, error=None)

    def notify(self, *a) -> None:
        pass

    def set_plan_unknown(self, allow: bool) -> None:
        self.rules_set.append(allow)
        self.plan_unknown = "allow" if allow else "closed"

    def route_snapshot(self):
        return SimpleNamespace(registered=False, candidate=None)

    def add_goal(self, goal):
        self.goals.append((tuple(goal), self.plan_unknown))
        return SimpleNamespace(ok=False, message=self._reply)


def _job(session: _Session, cache: _Cache, captures: list[str]) -> SearchJob:
    link = SimpleNamespace(latest_state=lambda: SimpleNamespace(position=ROBOT, yaw=0.0, battery=0.9),
                           run_segment=lambda seg: SimpleNamespace(done=True, status="done", wait=lambda t: None),
                           hold=lambda: None)
    mapping = SimpleNamespace(run_as=lambda what: captures.append(what) or True)
    job = SearchJob(session, link, mapping, runner=None)  # type: ignore[arg-type]
    job.config = SearchConfig("robot dog", max_captures=16, target_height=0.4)
    job.result = SearchResult(target="robot dog")
    job._grids = cache  # type: ignore[assignment]
    return job


def _dog(y: float) -> SceneObject:
    return SceneObject("robot_dog-1", "robot_dog", (2.5, y, 0.2), (0.28, 0.4, 0.645))


def test_unseen_spot_beside_the_target_is_never_planned_through_it_looks_again_then_ends_not_reached() -> None:
    dog = _dog(6.5)
    scene = Scene(objects=(dog,))
    known = _known((0.0, 0.0, 0.0), (5.0, 3.0, 3.0))  # seen free on the robot's side only; the dog's side unseen
    allowed = grid_for(scene, WS, MARGIN, known, "allow")
    _, app = goal_beside(scene, allowed, dog.id, ROBOT, Route(allowed, ROBOT))  # through unknown space: a spot
    assert app.goal is not None
    closed = grid_for(scene, WS, MARGIN, known, "closed")
    with pytest.raises(ObjectGoalError):  # over seen space only: none
        goal_beside(scene, closed, dog.id, ROBOT, Route(closed, ROBOT))
    session, cache, captures = _Session(scene), _Cache(scene, known), []
    job = _job(session, cache, captures)
    job.config = SearchConfig("robot dog", max_captures=3, target_height=0.4)
    reason = job._finish(dog)
    assert reason.startswith("found, not reached: robot_dog-1 at (2.50, 6.50) m: no seen-free spot beside it"), reason
    assert True not in session.rules_set and session.plan_unknown == "closed"  # the session's rule stays closed
    assert session.goals and all(rule == "closed" for _, rule in session.goals)  # every move over seen space
    assert all(g[1] <= 3.0 + 1e-9 for g, _ in session.goals)  # only to seen-free spots: never beside the dog
    assert len(captures) == 3 and all("looking at the floor beside robot_dog-1" in c for c in captures)
    looks = [s for s in job.steps if s.split(". ", 1)[1].startswith("no seen-free spot beside")]
    assert len(looks) == 3 and len({s.split("looking from ")[1] for s in looks}) == 3  # a different look each time
    assert not job.result.found


def test_the_approach_plans_with_unknown_space_closed_and_a_goal_where_the_robot_is_counts_as_arrived() -> None:
    dog = _dog(2.0)
    scene = Scene(objects=(dog,))
    known = _known((0.0, 0.0, 0.0), (5.0, 8.0, 3.0))  # all seen free
    session = _Session(scene, goal_reply="goal is where the robot already is (0.05 m): pick a goal at least one "
                                         "cell (0.05 m) away, or nothing needs planning")
    session.plan_unknown = "allow"  # left on: the search's move switches it off before planning
    cache, captures = _Cache(scene, known), []
    job = _job(session, cache, captures)
    assert job._finish(dog) == "found"
    assert job.result.found
    assert len(session.goals) == 1 and session.goals[0][1] == "closed"
    assert set(cache.policies) == {"closed"}
    session.plan_unknown, session.goals = "closed", []
    session._reply = "no route: the goal is inside an obstacle"
    assert job._go((2.5, 1.6, 0.0), "the viewpoint").startswith("no route to the viewpoint: no route")


def test_with_no_look_beside_the_target_left_the_search_explores_on_then_ends_not_reached(monkeypatch) -> None:
    from console.session import search_finish
    from console.session.search_choose import Choice
    from planner.search_viewpoints import Viewpoint

    dog = _dog(6.5)
    scene = Scene(objects=(dog,))
    known = _known((0.0, 0.0, 0.0), (5.0, 3.0, 3.0))
    session, cache, captures = _Session(scene), _Cache(scene, known), []
    job = _job(session, cache, captures)
    job.config = SearchConfig("robot dog", max_captures=8, target_height=0.4)
    monkeypatch.setattr(search_finish, "look_beside", lambda *a: (None, "no reachable seen-free spot sees it"))
    vp = Viewpoint((1.0, 2.0, 0.0), (1.0, 2.0, 0.35), 0.5, "walk", 3.0, 2.0, 0.1, "(1.00, 2.00, 0.35) m on the floor")
    offered = [Choice(vp, "over seen space", False, (vp,), 0.01), Choice(None, "none left", False, (), 0.01)]
    asked = []
    monkeypatch.setattr(search_finish, "choose_viewpoint", lambda *a: asked.append(a[1]) or offered[len(asked) - 1])
    reason = job._finish(dog)
    assert len(asked) == 2  # explored once, then nothing was left
    assert reason.startswith("found, not reached: robot_dog-1 at (2.50, 6.50) m"), reason
    assert "no reachable seen-free spot sees it" in reason
    assert [g for g, _ in session.goals] == [(1.0, 2.0, 0.0)]  # went to the search's own next viewpoint ...
    assert len(captures) == 1  # ... and captured there
    assert any("exploring on from the next viewpoint over seen space" in s for s in job.steps)
