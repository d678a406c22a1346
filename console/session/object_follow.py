"""Objects that map fusion merges away or removes while the operator uses them: the selection and the
goals chosen by object follow the merge, or are dropped, each with a notice naming the objects.

Map fusion (:func:`pipeline.mapping.map_fusion.fuse`) may merge an object into an older one of its class
(``office_chair-3 merged into office_chair-1``: one object mapped twice) or remove one seen by a single
capture that later captures should have seen and did not. The session remembers both (``merged into`` and
``removed``, for the session's life), so that:

- the **selected object**, merged away, is replaced by the object it was merged into (a notice names both);
  removed, the selection is cleared (a notice says why);
- a **goal chosen by object** (:meth:`ObjectFollow.go_to_object`, "go to office_chair-3") follows the merge:
  the candidate is planned again beside the surviving object (a notice names both), or dropped when that
  fails or the object was removed; registered stops and a running mission's stops keep their point (already
  re-checked against the new map) and are told which object they now stand beside;
- an id typed or picked after it left the map resolves to the object it was merged into
  (:meth:`ObjectFollow.resolve_object`), or is refused saying it was removed and why (:class:`RemovedObject`;
  an id never in the map: :class:`UnknownObject`).

An object the operator deletes (:meth:`~console.session.session.Session.delete_object`) is recorded too: its id
is refused as ``office_chair-1 was deleted by the operator`` (:class:`RemovedObject`), and resolves again while
an Undo has it back in the map. Of a merge, a removal by fusion and a deletion of the same id (an Undo brought
it back in between), the newest speaks for it.

A goal planned beside an object by another caller (the MCP agent's ``plan_to_object``) joins the same rule with
:meth:`ObjectFollow.link_goal`; :meth:`ObjectFollow.followed_goal` tells it where its candidate went.

No id of an object that left the map is kept as a goal or a selection. World frame [m].
"""

from __future__ import annotations

import math
from typing import Any, Sequence

from planner.object_goal import ObjectGoalError, goal_beside
from planner.route import PlanResult, Route, path_points

from console.session.session_core import SessionCore
from console.session.session_types import Notice, SessionError, Vec3, fmt_point


class UnknownObject(SessionError):
    """No object of this id was ever in the map (as far as this session knows)."""


class RemovedObject(SessionError):
    """The object (or the one it was merged into) was removed from the map by fusion or deleted by the
    operator; the message says which and why."""


def _near(a: Sequence[float], b: Sequence[float], tol: float) -> bool:
    return math.dist(a, b) <= tol


class ObjectFollow(SessionCore):
    """The follow-the-merge half of :class:`~console.session.session.Session` (mixed into it)."""

    @property
    def _fusion_log(self) -> tuple[dict[str, str], dict[str, str], dict[Vec3, str]]:
        """``(merged into, removed with why, goal point -> object id)``, made on first use."""
        d = self.__dict__
        return d.setdefault("_merged_into", {}), d.setdefault("_removed", {}), d.setdefault("_goal_objects", {})

    @property
    def _deleted(self) -> dict[str, str]:
        """Object id -> how the operator took it out of the map (``deleted by the operator``), made on first use."""
        return self.__dict__.setdefault("_deleted_by_operator", {})

    def _record_deletion_locked(self, object_id: str) -> None:
        """The operator deleted ``object_id``: :meth:`resolve_object` says so from now on (and resolves it again
        while an Undo has it back in the map). The newest news of the id: a merge or a removal by fusion
        recorded before (an Undo brought the object back since) no longer speaks for it."""
        merged, removed, _ = self._fusion_log
        merged.pop(object_id, None)
        removed.pop(object_id, None)
        self._deleted[object_id] = "deleted by the operator"

    def resolve_object(self, object_id: str) -> str:
        """The map object ``object_id`` is now: itself, or the object it was merged into (followed through
        later merges). Raises :class:`RemovedObject` for an object removed from the map by fusion (saying
        why) or deleted by the operator (``office_chair-1 was deleted by the operator``), :class:`UnknownObject`
        for an id never in it (both are :class:`SessionError`)."""
        with self._lock:
            if any(o.id == object_id for o in self._scene.objects):
                return object_id  # in the map (again, after an Undo of the merge)
            merged, removed, _ = self._fusion_log
            oid, seen = object_id, set()
            while oid in merged and oid not in seen:
                seen.add(oid)
                oid = merged[oid]
            if any(o.id == oid for o in self._scene.objects):
                return oid
            if oid in removed:
                raise RemovedObject(f"{oid} was removed from the map: {removed[oid]}")
            if oid in self._deleted:
                raise RemovedObject(f"{oid} was {self._deleted[oid]}")
            raise UnknownObject(f"no object {object_id!r} in the map")

    def link_goal(self, goal: Sequence[float], object_id: str) -> None:
        """Remember ``goal`` (world [m], the candidate's goal just planned beside ``object_id``) as that object's,
        as :meth:`go_to_object` does: when map fusion later merges the object away, a candidate still at this
        goal is planned again beside the surviving object (notice "Goal follows the merge"), and dropped when
        the object is removed. :meth:`followed_goal` says where it went."""
        g = tuple(float(v) for v in goal)
        with self._lock:
            self._fusion_log[2][g] = object_id  # type: ignore[index]
            self._goal_moves.pop(g, None)  # planned here afresh: where an older candidate here went is history

    @property
    def _goal_moves(self) -> dict[Vec3, Vec3]:
        """Candidate goal -> the goal it was planned again to after its object was merged away."""
        return self.__dict__.setdefault("_goal_moves", {})

    def followed_goal(self, goal: Sequence[float]) -> Vec3:
        """Where a candidate planned to ``goal`` (world [m]) is now: ``goal`` itself, or the goal it was planned
        again to beside the surviving object after its object was merged away (followed through later merges)."""
        g: Vec3 = tuple(float(v) for v in goal)  # type: ignore[assignment]
        with self._lock:
            moves, seen = self._goal_moves, set()
            while g in moves and g not in seen:
                seen.add(g)
                g = moves[g]
        return g

    def go_to_object(self, object_id: str, _moved_from: Vec3 | None = None) -> tuple[PlanResult, Any, Any]:
        """Plan a candidate to the free floor beside ``object_id`` (an id, followed through merges, or a label:
        the nearest such object); the goal is remembered as this object's, so it follows a later merge.
        Returns ``(result, object, approach)`` (:func:`planner.object_goal.goal_beside`); raises
        :class:`SessionError` when the object is gone or cannot be reached. ``_moved_from`` (internal): the
        goal of the candidate this one replaces after a merge (:meth:`followed_goal`)."""
        with self._lock:
            merged, removed, _ = self._fusion_log
            left = object_id in merged or object_id in removed or object_id in self._deleted
        oid = self.resolve_object(object_id) if left else object_id
        with self._lock:
            start = self._route.last_node()
            scene, grid, weights = self._scene, self._grid, self._weights
        try:
            obj, app = goal_beside(scene, grid, oid, start, Route(grid, start, weights))
        except ObjectGoalError as exc:
            raise SessionError(str(exc)) from None
        goal = tuple(float(v) for v in app.goal)
        moved = _moved_from is not None and _moved_from != goal
        with self._lock:
            if moved:  # known before the route event, so that listeners read where the candidate went
                self._goal_moves[_moved_from] = goal  # type: ignore[index]
        res = self.add_goal(goal)  # type: ignore[attr-defined]  # Session
        with self._lock:
            if res.ok:
                self._fusion_log[2][goal] = obj.id  # type: ignore[index]
                self._goal_moves.pop(goal, None)  # type: ignore[arg-type]
            elif moved:
                self._goal_moves.pop(_moved_from, None)  # type: ignore[arg-type]
        return res, obj, app

    def _follow_fusion_locked(self, merged: Sequence[tuple[str, str]], removed: Sequence[tuple[str, str]],
                              selected_before: str | None, run_active: bool) -> tuple[bool, str | None]:
        """After a spawn whose fusion merged ``(kept, gone)`` pairs and removed ``(id, why)`` objects: the
        selection follows or is cleared, registered and mission stops are told, and the candidate goal is
        returned for :meth:`_replan_followed` when its object was merged (``(selection changed, new object
        id or None)``). Notices go to the outbox."""
        into, gone_why, goals = self._fusion_log
        into.update({gone: kept for kept, gone in merged})
        gone_why.update({oid: why for oid, why in removed})
        if not merged and not removed:
            return False, None

        def now(oid: str) -> str | None:
            try:
                return self.resolve_object(oid)
            except SessionError:
                return None

        changed = False
        if selected_before is not None and selected_before in into | gone_why:
            kept = now(selected_before)
            self._selected = kept
            changed = True
            self._outbox.append(
                Notice("Selection follows the merge", f"{selected_before} was merged into {kept}: {kept} is selected")
                if kept is not None else
                Notice("Selection cleared", f"{selected_before} left the map: {gone_why.get(selected_before, 'merged away')}",
                       "warning"))
        tol = self._grid.workspace.resolution
        cand = self._route.candidate_goal
        follow: str | None = None
        stops = [tuple(path_points(seg, self._grid)[-1]) for seg in self._route.registered if len(seg)]
        for point, oid in list(goals.items()):
            if oid not in into and oid not in gone_why:
                continue
            kept = now(oid)
            is_candidate = cand is not None and _near(point, cand, 1e-6)
            at_stop = [i + 1 for i, s in enumerate(stops) if _near(point, s, 2 * tol)]
            if kept is None:
                del goals[point]
                if is_candidate:
                    self._route.discard()
                    self._save_locked()
                    self._outbox.append(Notice("Goal dropped", f"the candidate went beside {oid}, which left the map "
                                               f"({gone_why.get(oid, 'merged away')}): choose another goal", "warning"))
                elif at_stop:
                    self._outbox.append(Notice("Stop beside a removed object", (
                        f"{'the running mission' if run_active else 'registered'} stop {at_stop[0]} at "
                        f"{fmt_point(point)} went beside {oid}, which left the map ({gone_why.get(oid, '')}); "
                        "the stop stays where it is"), "warning"))
                continue
            goals[point] = kept
            if is_candidate:
                follow = kept
                self._outbox.append(Notice("Goal follows the merge", f"{oid} was merged into {kept}: the candidate "
                                           f"is planned again beside {kept}"))
            elif at_stop:
                self._outbox.append(Notice("Stop follows the merge", (
                    f"{oid} was merged into {kept}: {'the running mission' if run_active else 'registered'} stop "
                    f"{at_stop[0]} at {fmt_point(point)} now stands beside {kept} (kept where it is; "
                    "re-checked against the new map)")))
        return changed, follow

    def _replan_followed(self, object_id: str) -> None:
        """Plan the candidate again beside ``object_id`` (its goal's object was merged into it); dropped with
        a notice when that fails."""
        with self._lock:
            cand = self._route.candidate_goal
        try:
            res, _, _ = self.go_to_object(object_id, tuple(float(v) for v in cand) if cand is not None else None)
            why = None if res.ok else res.message
        except SessionError as exc:
            why = str(exc)
        if why is not None:
            self.discard()  # type: ignore[attr-defined]  # Session
            self.notify("Goal dropped", f"the candidate could not be planned again beside {object_id}: {why}",
                        "warning")  # type: ignore[attr-defined]


__all__ = ["ObjectFollow", "RemovedObject", "UnknownObject"]
