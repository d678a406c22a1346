"""The agent's proposals: what it asks the operator to approve, never carried out by the request itself.

:class:`ProposalOps` is mixed into :class:`console.mcp.door.AgentDoor` (which checks that proposals are
allowed before any of these runs, and announces every call): a candidate path to a point or beside an
object (planned in the session like the console's Go to: it only moves when a mission runs), and Capture &
map, Look around, Find and Execute mission put in the approval queue
(:class:`~console.mcp.proposals.ProposalQueue`) with the action an operator's Approve runs; the agent may
withdraw its own pending proposal.

Errors: :class:`~console.mcp.door_args.AgentError` naming the bad field, or the session's
:class:`~console.session.session_types.SessionError` (the door turns both into the agent's refusal).
Frames and units: world frame (z up) [m].
"""

from __future__ import annotations

from typing import Any, Mapping

from console.mcp.door_args import NAME_MAX, WHY_MAX, AgentError, number_arg, text_arg
from console.mcp.proposals import ProposalQueue
from console.session.session_types import SessionError
from console.wording import plural


class ProposalOps:
    """The proposal requests of :class:`~console.mcp.door.AgentDoor` (``_op_<name>``, mixed into it).

    Uses the door's ``session``, ``queue``, ``runner``, ``mapping``, ``look``, ``search`` and ``agent_goal``
    (see :class:`~console.mcp.door.AgentDoor`).
    """

    session: Any
    queue: ProposalQueue
    runner: Any
    mapping: Any
    look: Any
    search: Any
    agent_goal: tuple[float, float, float] | None

    def _op_plan_to_point(self, args: Mapping[str, Any]) -> dict[str, Any]:
        from console.views.picking import typed_goal

        why = text_arg(args, "why", WHY_MAX)
        goal = typed_goal([args.get("x"), args.get("y"), args.get("z", self.session.workspace.floor)],
                          self.session.workspace)
        return self._plan(goal, f"point ({goal[0]:.2f}, {goal[1]:.2f}, {goal[2]:.2f})", why)

    def _op_plan_to_object(self, args: Mapping[str, Any]) -> dict[str, Any]:
        from planner.object_goal import ObjectGoalError, goal_beside
        from planner.route import Route

        from console.mcp.object_names import ObjectGone, followed_object

        name = text_arg(args, "object", NAME_MAX, required=True)
        why = text_arg(args, "why", WHY_MAX)
        s = self.session
        snap = s.route_snapshot()
        start = tuple(snap.registered[-1][-1]) if snap.registered else snap.start
        grid = s.grid
        try:
            oid, merged = followed_object(s, name)  # an id merged away: the object it was merged into
            obj, app = goal_beside(s.scene, grid, oid, start, Route(grid, start, s.weights))
        except (ObjectGoalError, ObjectGone) as exc:
            raise AgentError(f"object: {exc}") from None
        how = {"walk": "walking", "fly": "flying over what is in the way"}.get(app.mode, app.mode)
        goal = tuple(float(v) for v in app.goal)
        out = self._plan(goal, f"{obj.label.replace('_', ' ')} {obj.id} (beside it, by {how})"
                         + (f"; {merged}" if merged else ""), why)
        if hasattr(s, "link_goal"):  # like the console's Go to: the candidate follows a later merge of its object
            s.link_goal(goal, obj.id)
        out["object"] = {"id": obj.id, "label": obj.label}
        if merged:
            out["merged"] = f"{merged}: planned beside {obj.id}"
        return out

    def _plan(self, goal: tuple[float, float, float], what: str, why: str) -> dict[str, Any]:
        before, self.agent_goal = self.agent_goal, tuple(float(v) for v in goal)  # type: ignore[assignment]
        res = self.session.add_goal(goal)  # the panel labels the new candidate as the agent's (route event)
        if not res.ok:
            self.agent_goal = before
            raise AgentError(f"goal: {res.message}")
        self.session.notify("Agent planned a candidate", f"to {what}: {res.message}. It is proposed by the agent: "
                            "Register or Discard it, or wait for the agent's mission proposal"
                            + (f". Why: {why}" if why else ""), "info")
        snap = self.session.route_snapshot()
        pts = snap.candidate
        return {"goal": [round(v, 3) for v in goal], "message": res.message,
                "path_points": len(pts) if pts is not None else 0,
                "max_height_m": round(float(pts[:, 2].max() - self.session.workspace.floor), 3) if pts is not None and len(pts) else None,
                "note": "a candidate only: nothing moves; propose_mission asks the operator to execute it"}

    def _op_propose_capture_and_map(self, args: Mapping[str, Any]) -> dict[str, Any]:
        why = text_arg(args, "why", WHY_MAX, required=True)
        if self.mapping is None:
            raise AgentError("this console cannot capture (no mapping job)")

        def act() -> str:
            if not self.mapping.start():
                raise SessionError("a capture is already being mapped")
            return "capture and map started"

        p = self.queue.propose("capture", "Capture & map: take a photo from where the robot is and map it", why, act)
        return p.to_dict()

    def _op_propose_search(self, args: Mapping[str, Any]) -> dict[str, Any]:
        from console.session.search import SearchConfig, target_height

        why = text_arg(args, "why", WHY_MAX, required=True)
        target = text_arg(args, "target", NAME_MAX, required=True)
        mode = text_arg(args, "mode", 16) or "auto"
        captures = number_arg(args, "max_captures", 20.0)
        if captures != int(captures):
            raise AgentError(f"max_captures: must be a whole number, got {captures!r}")
        try:
            config = SearchConfig(target, mode=mode, max_captures=int(captures), target_height=target_height(target))
        except SessionError as exc:
            raise AgentError(str(exc)) from None
        if self.search is None:
            raise AgentError("this console has no search (Find)")

        def act() -> str:
            self.search.start(config)
            return f"search for {target!r} started ({mode} mode, at most {plural(config.max_captures, 'capture')})"

        p = self.queue.propose("search", f"Find {target!r}: choose viewpoints, move, capture and map until it is "
                               f"found ({mode} mode, at most {plural(config.max_captures, 'capture')})", why, act)
        return p.to_dict()

    def _op_propose_look_around(self, args: Mapping[str, Any]) -> dict[str, Any]:
        from console.session.look import DEFAULT_HEADINGS

        why = text_arg(args, "why", WHY_MAX, required=True)
        if self.look is None:
            raise AgentError("this console has no Look around (no robot link that turns)")

        def act() -> str:
            self.look.look_around()
            return f"look around started: {DEFAULT_HEADINGS} headings, a capture and map at each"

        p = self.queue.propose("look", f"Look around: turn in place through {DEFAULT_HEADINGS} headings, capturing and "
                               "mapping at each", why, act)
        return p.to_dict()

    def _op_propose_mission(self, args: Mapping[str, Any]) -> dict[str, Any]:
        from console.views.mission_view import built_text, segment_table

        why = text_arg(args, "why", WHY_MAX, required=True)
        s = self.session
        if self.runner is None:
            raise AgentError("this console has no mission manager: missions cannot run")
        if s.run.active:
            raise AgentError("a mission is under way (running or paused): wait for it to end")
        if s.route_snapshot().candidate is not None:
            s.register()  # the candidate (the agent's or the operator's) joins the route
        try:
            mission = s.build_mission()
        except SessionError as exc:
            raise AgentError(f"mission: {exc}") from None
        mid = mission.id

        def act() -> str:
            current = s.mission
            if current is None or current.id != mid:
                raise SessionError(f"the mission changed since the agent proposed {mid}: not executed")
            blocker = s.operator_state(True).execute_blocker
            if blocker is not None:
                raise SessionError(f"Execute is off: {blocker}")
            self.runner.execute(current)
            return f"mission {mid} started: {built_text(current)}"

        p = self.queue.propose("mission", f"Execute mission {mid}: {built_text(mission)}, {mission.length:.1f} m", why,
                               act, details=segment_table(mission))
        return {**p.to_dict(), "mission": mission.to_dict()}

    def _op_withdraw_proposal(self, args: Mapping[str, Any]) -> dict[str, Any]:
        pid = text_arg(args, "proposal_id", 64, required=True)
        return self.queue.withdraw(pid, text_arg(args, "why", WHY_MAX) or "the agent gave up waiting").to_dict()


__all__ = ["ProposalOps"]
