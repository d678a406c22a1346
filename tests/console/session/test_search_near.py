"""The search's last approach ends near the target, not up to 1 m off: when the nearest seen-free spot
beside it is farther than NEAR_GAP (the floor nearer it not seen), it looks towards that floor once and plans
again (console/session/search_finish.py). Seen in the browser test that pauses and lands mid-search: the
approach ended 0.98 m from the dog's mapped footprint, 1.08 m from its centre."""

from __future__ import annotations

import math

import numpy as np

from pipeline.scene import Scene, SceneObject
from planner.object_goal import footprint_distance

from console.session.search import SearchConfig
from console.session.search_finish import NEAR_GAP
from test_search_closed import _Cache, _job, _known, _Session  # the same fakes as the closed-space tests

ARRIVED = "goal is where the robot already is (0.05 m): pick a goal at least one cell (0.05 m) away"


def test_a_far_approach_spot_takes_one_look_towards_the_target_then_ends_near_it() -> None:
    dog = SceneObject("robot_dog-1", "robot_dog", (2.5, 3.0, 0.2), (0.28, 0.4, 0.645))  # y 2.86-3.14
    scene = Scene(objects=(dog,))
    # seen free on the robot's side up to y = 2.25 and beyond y = 2.75; the floor band between, nearer the dog,
    # not seen (as under a hovering camera): over seen space the nearest spot beside it is 0.98 m off
    near_side = _known((0.0, 0.0, 0.0), (5.0, 2.25, 3.0))
    seen = _known((0.0, 0.0, 0.0), (5.0, 8.0, 3.0))
    session, cache, captures = _Session(scene, goal_reply=ARRIVED), _Cache(scene, near_side), []
    job = _job(session, cache, captures)
    job._mapping.run_as = lambda what: captures.append(what) or setattr(cache, "known", seen) or True  # the look sees it
    job.config = SearchConfig("robot dog", max_captures=8, target_height=0.4)
    assert job._finish(dog) == "found"
    looked = [s for s in job.steps if s.split(". ", 1)[1].startswith("the nearest seen-free spot beside")]
    assert len(looked) == 1 and "the nearest seen-free spot beside robot_dog-1 is 0.98 m from it" in looked[0], job.steps
    assert len(captures) == 1 and captures[0].endswith("looking at the floor beside robot_dog-1"), captures
    end = session.goals[-1][0]
    gap = float(footprint_distance(dog, np.array([end[:2]]))[0])
    assert gap <= NEAR_GAP and math.dist(end[:2], dog.position[:2]) < 1.0, (end, gap)
    assert all(rule == "closed" for _, rule in session.goals)  # every move over seen space


def test_a_near_approach_spot_goes_straight_there() -> None:
    dog = SceneObject("robot_dog-1", "robot_dog", (2.5, 3.0, 0.2), (0.28, 0.4, 0.645))
    scene = Scene(objects=(dog,))
    session, captures = _Session(scene, goal_reply=ARRIVED), []
    job = _job(session, _Cache(scene, _known((0.0, 0.0, 0.0), (5.0, 8.0, 3.0))), captures)
    assert job._finish(dog) == "found"
    assert captures == [] and not any("for a nearer one" in s for s in job.steps), job.steps
