"""The search's last approach and its retries (mixed into :class:`console.session.search.SearchJob`).

:meth:`SearchFinish._finish` goes beside the found target over seen space only (unknown space
closed: the search never plans through space no capture has seen). When no seen-free spot beside it
can be reached yet (the floor round it not seen: a target seen over a line of boxes, from the air),
it looks to open that floor as Go look does (:func:`look_beside`: go to a seen-free spot that sees the
approach spot's unseen cells, face it, capture), or, with no such look left, explores on from the
search's next viewpoint, and plans again, as long as the capture budget lasts. When the nearest seen-free
spot beside it is farther than :data:`NEAR_GAP` from it (the floor nearer it not seen: it could end 1 m
off), it takes one such look first and plans again. A move that ends in a contact with something the map did not show is counted (``contacts``
in the result), followed by a capture and a new plan from where the robot stopped, and never
repeated from the same spot to the same goal (:func:`repeats`, :func:`untried`). A target that map fusion
merges into another object meanwhile is followed to that object (a step names both); one it removes ends the
search *found, not reached* with the reason (:meth:`SearchFinish._followed`). World frame (z up) [m].
"""

from __future__ import annotations

import math
from typing import Any, Sequence

from planner.grid import CostWeights, PlanningGrid
from planner.object_goal import ObjectGoalError, goal_beside
from planner.route import Route
from planner.search_viewpoints import Viewpoint
from pipeline.scene import Scene

from console.session.go_look import looked_from
from console.session.object_follow import RemovedObject, UnknownObject
from console.session.search_choose import choose_viewpoint
from console.session.search_moves import BATTERY, PAUSED, STOPPED

SAME = 0.3
"""Starts and goals closer than this [m] make the same route."""

NEAR_GAP = 0.6
"""An approach spot farther than this [m] from the target's footprint (the robot's radius and one cell;
approach spots reach 1 m) means the floor nearer it was not seen: one look towards it first, then plan again."""

Routes = list[tuple[tuple[float, ...], tuple[float, ...]]]


def is_contact(why: str | None) -> bool:
    """Whether a move's end (its reason) was a contact with an object (the simulator's and the autopilot's
    words: ``contact with ...``)."""
    return bool(why) and "contact with" in str(why)


def repeats(start: Sequence[float], goal: Sequence[float], hit: Routes) -> bool:
    """Whether a move from ``start`` to ``goal`` is one that already ended in a contact."""
    return any(math.dist(start, a) < SAME and math.dist(goal, b) < SAME for a, b in hit)


def untried(choice: Any, here: Sequence[float], hit: Routes) -> Viewpoint | None:
    """The chosen viewpoint, or the best other candidate when the move to it from ``here`` already ended
    in a contact; ``None`` when none is left (or none was chosen)."""
    if choice.viewpoint is None:
        return None
    for vp in (choice.viewpoint, *choice.candidates):
        if not repeats(here, vp.goal, hit):
            return vp
    return None


def look_beside(scene: Scene, closed: PlanningGrid, allow: PlanningGrid, obj_id: str, here: Sequence[float],
                weights: CostWeights | None, avoid: Sequence[Any] = ()) -> tuple[Any, str]:
    """The next look that opens the floor beside the found object ``obj_id`` when no seen-free spot
    beside it can be reached: the approach spot it would have with unknown space allowed (``allow``,
    only to know *where* to look: no route goes there) and Go look's next look towards it
    (:meth:`planner.route.Route.look_for` on the ``closed`` grid: a seen-free spot reachable over seen
    space, facing the spot); ``avoid``: ``(camera position [m], heading [rad])`` of earlier captures.
    ``(look, "")``, or ``(None, why there is none)``. World frame [m]."""
    weights = weights if weights is not None else CostWeights()
    try:
        _, app = goal_beside(scene, allow, obj_id, here, Route(allow, here, weights))
    except ObjectGoalError as exc:
        return None, f"not even through unseen space: {exc}"
    look = Route(closed, here, weights).look_for(app.goal, avoid=avoid)
    if look is None:
        return None, (f"no reachable seen-free spot sees the floor at ({app.goal[0]:.2f}, {app.goal[1]:.2f}) m "
                      "beside it")
    return look, ""


class SearchFinish:
    """Mixin: the search's last approach (see the module docstring). Uses the job's ``result``, ``config``,
    ``_session``, ``_grids``, ``_looked``, ``_contact_routes``, ``_go``, ``_turn``, ``_capture``, ``_pos``, ``_step``,
    ``_wait_paused``, ``_battery_end``, ``_pause`` and ``_stop``."""

    def _finish(self, obj: Any) -> str:
        """Go beside the found target over seen space only (never through space no capture has seen).

        When no seen-free spot beside it is reachable, look to open the floor beside it
        (:func:`look_beside`: go to the look's seen-free spot, face the approach spot, capture) and plan
        again, while the capture budget lasts; when no such look is left, explore on from the search's
        next viewpoint (:func:`console.session.search_choose.choose_viewpoint`) and plan again; when
        none is left either, end *found, not reached* with where and why. A move that stops (a contact, a refusal) is followed by a capture and a new plan
        from where the robot is, never the same route again.
        """
        r = self.result
        assert r is not None
        s = self._session
        budget = self.config.max_captures if self.config else 0
        looks: list[tuple[tuple[float, ...], float]] = []  # the looks taken here (never taken twice)
        closer = False  # a look for a nearer spot than a far one (NEAR_GAP) was taken
        for _ in range(budget + 4):
            if not self._wait_paused():
                return STOPPED
            here = self._pos()
            obj, end = self._followed(obj)  # as mapped now: merged away, the object it was merged into
            if end:
                return end
            grid = self._grids.grid(s, "closed")
            try:
                _, app = goal_beside(s.scene, grid, obj.id, here, Route(grid, here, s.weights))
            except ObjectGoalError as exc:
                where = f"{obj.id} at ({obj.position[0]:.2f}, {obj.position[1]:.2f}) m"
                if r.captures >= budget:
                    return f"found, not reached: {where}: no seen-free spot beside it is reachable ({exc})"
                look, none = look_beside(s.scene, grid, self._grids.grid(s, "allow"), obj.id, here, s.weights,
                                         looked_from(s) + looks)
                if look is None:  # no look towards it is left: explore on (the search's own next viewpoint)
                    choice = choose_viewpoint(s, here, self.config.target_height if self.config else 0.6,
                                              self._looked, self._grids)
                    look = untried(choice, here, self._contact_routes)
                    if look is None:
                        return f"found, not reached: {where}: no seen-free spot beside it is reachable ({exc}); {none}"
                    self._step("move", f"no seen-free spot beside {where} is reachable ({exc}); {none}: exploring "
                               f"on from the next viewpoint {choice.why}: {look.why}", level="warning")
                else:
                    self._step("move", f"no seen-free spot beside {where} is reachable ({exc}): looking from "
                               f"{look.why}", level="warning")
                looks.append((tuple(look.eye), float(look.yaw)))
                end = self._take_look(look, obj.id, here)
                if end:
                    return end
                continue
            if app.gap > NEAR_GAP and not closer and r.captures < budget:  # the floor nearer it not seen yet
                closer = True
                look, _ = look_beside(s.scene, grid, self._grids.grid(s, "allow"), obj.id, here, s.weights,
                                      looked_from(s) + looks)
                if look is not None:
                    self._step("move", f"the nearest seen-free spot beside {obj.id} is {app.gap:.2f} m from it: "
                               f"looking from {look.why} for a nearer one")
                    looks.append((tuple(look.eye), float(look.yaw)))
                    end = self._take_look(look, obj.id, here)
                    if end:
                        return end
                    continue
            if math.dist(here[:2], app.goal[:2]) < 0.2 and here[2] < 0.1:
                r.found = True
                return "found"
            goal = tuple(float(v) for v in app.goal)
            if repeats(here, goal, self._contact_routes):
                return f"found, not reached: {obj.id}: the route beside it ended in contact before (not repeated)"
            why = self._go(goal, f"beside {obj.id}")
            if why is None:
                r.found = True
                return "found"
            if why == STOPPED or self._stop.is_set():
                return STOPPED
            if why == BATTERY:
                return self._battery_end() or "battery: the console's battery rule ended the move"
            if why == PAUSED:
                continue
            if is_contact(why):
                r.contacts += 1
                self._contact_routes.append((here, goal))
            self._step("move", f"the move beside {obj.id} did not end there: {why}; mapping again and planning "
                       "from here", level="warning")
            self._capture(f"after the move beside {obj.id} stopped")
        return "found but the move beside it failed"

    def _followed(self, obj: Any) -> tuple[Any, str | None]:
        """The found target as mapped now: itself, or the object map fusion merged it into (followed through
        later merges by the session's :meth:`~console.session.object_follow.ObjectFollow.resolve_object`, as
        the console's selection and goals are; a step names both and the result's target becomes the
        survivor). ``(object, None)``, or ``(obj, end)`` with the search's end when it was removed from the
        map (the reason given)."""
        s = self._session
        now = next((o for o in s.scene.objects if o.id == obj.id), None)
        resolve = getattr(s, "resolve_object", None)
        if now is not None or resolve is None:
            return (now if now is not None else obj), None
        try:
            oid = resolve(obj.id)
        except RemovedObject as exc:
            return obj, f"found, not reached: {exc}"
        except UnknownObject:  # deleted by hand, or its capture undone: neither merged nor removed by fusion
            return obj, f"found, not reached: {obj.id} is no longer in the map"
        kept = next((o for o in s.scene.objects if o.id == oid), None)
        if kept is None:  # the map changed again meanwhile: the next pass resolves it
            return obj, None
        r = self.result
        if r is not None:
            r.target_id, r.target_position = kept.id, [round(v, 3) for v in kept.position]
        self._step("seen", f"{obj.id} was merged into {kept.id} (one object mapped twice): going beside {kept.id}",
                   target_id=kept.id)
        return kept, None

    def _take_look(self, look: Any, obj_id: str, here: Sequence[float]) -> str | None:
        """Go to a look's seen-free spot, face its heading and capture. The search's end when the move
        ended it (stopped, battery), else ``None`` (plan again: also after a pause or a stopped move)."""
        r = self.result
        assert r is not None
        if math.dist(here, look.goal) > 0.2:
            why = self._go(tuple(float(v) for v in look.goal), f"a look beside {obj_id}")
            if why == STOPPED or self._stop.is_set():
                return STOPPED
            if why == BATTERY:
                return self._battery_end() or "battery: the console's battery rule ended the move"
            if why == PAUSED:
                return None
            if is_contact(why):
                r.contacts += 1
                self._contact_routes.append((tuple(here), tuple(float(v) for v in look.goal)))
            if why is not None:
                self._step("move", f"the move to the look did not end there: {why}; capturing here", level="warning")
        if not self._turn(look.yaw) and (self._pause.is_set() or self._stop.is_set()):
            return None
        self._capture(f"looking at the floor beside {obj_id}")
        return None


__all__ = ["NEAR_GAP", "SAME", "SearchFinish", "is_contact", "look_beside", "repeats", "untried"]
