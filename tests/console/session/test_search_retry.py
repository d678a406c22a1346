"""The search's retries (console/session/search_finish.py, search.py): a move that ends in a contact is
counted, followed by a capture and a new plan, never repeated from the same spot to the same goal; a
target seen once whose confirming capture missed it is confirmed from another viewpoint, not by
capturing again from the same spot until the budget runs out."""

from __future__ import annotations

import time
from types import SimpleNamespace

import console.session.search as search_mod
from console.session.search_choose import Choice
from console.session.search_finish import is_contact, repeats, untried
from test_search_closed import _Cache, _dog, _job, _known, _Session

from pipeline.scene import Scene

CONTACT = "the move stopped: contact with an unmapped obstacle ahead at (2.50, 1.20, 0.10)"


def _vp(x: float, y: float):
    return SimpleNamespace(goal=(x, y, 0.0))


def test_contact_words_and_the_same_route_rule() -> None:
    assert is_contact(CONTACT) and not is_contact("no route to the viewpoint: refused") and not is_contact(None)
    hit = [((1.0, 1.0, 0.0), (3.0, 3.0, 0.0))]
    assert repeats((1.1, 1.0, 0.0), (3.0, 3.1, 0.0), hit)
    assert not repeats((2.0, 1.0, 0.0), (3.0, 3.0, 0.0), hit)  # from elsewhere: another route
    first, other = _vp(3.0, 3.0), _vp(4.0, 1.0)
    choice = Choice(first, "over seen space", False, (first, other), 0.0)  # type: ignore[arg-type]
    assert untried(choice, (1.0, 1.0, 0.0), hit) is other
    assert untried(choice, (1.0, 1.0, 0.0), []) is first
    assert untried(Choice(first, "", False, (first,), 0.0), (1.0, 1.0, 0.0), hit) is None  # type: ignore[arg-type]


def test_a_move_beside_the_target_ending_in_contact_is_counted_mapped_again_and_not_repeated() -> None:
    dog = _dog(2.5)
    scene = Scene(objects=(dog,))
    session, cache, captures = _Session(scene), _Cache(scene, _known((0.0, 0.0, 0.0), (5.0, 8.0, 3.0))), []
    job = _job(session, cache, captures)
    goals = []
    job._go = lambda goal, what: goals.append(goal) or CONTACT  # type: ignore[method-assign]
    reason = job._finish(dog)  # the robot did not move (the fake link): the same route again is refused
    assert len(goals) == 1, goals
    assert job.result.contacts == 1
    assert len(captures) == 1 and captures[0].endswith("after the move beside robot_dog-1 stopped"), captures
    assert reason == "found, not reached: robot_dog-1: the route beside it ended in contact before (not repeated)"
    assert not job.result.found


def test_a_confirming_capture_that_missed_is_not_taken_again_from_the_same_spot(monkeypatch) -> None:
    dog = _dog(5.0)
    scene = Scene(objects=(dog,))
    session, cache, captures = _Session(scene), _Cache(scene, _known((0.0, 0.0, 0.0), (5.0, 8.0, 3.0))), []
    job = _job(session, cache, captures)
    job._target = lambda: (dog, 1)  # type: ignore[method-assign]  # seen once, never confirmed
    chosen = []

    def choose(*a, **k):
        chosen.append(a[1])
        return Choice(None, "no reachable viewpoint shows unknown space where the target can be", False, (), 0.0)
    monkeypatch.setattr(search_mod, "choose_viewpoint", choose)
    reason = job._loop(job.config, time.monotonic())  # type: ignore[arg-type]
    assert captures[0].endswith("where the robot stands")
    assert [c for c in captures if "confirming" in c] == [captures[1]] and len(captures) == 2, captures
    assert chosen, "the search went on to another viewpoint"
    assert reason.startswith("not found: no reachable viewpoint")
    assert any("confirming from another viewpoint" in s for s in job.steps)
