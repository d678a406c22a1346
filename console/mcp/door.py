"""The agent's door into a running console: reads the session, proposes, and only the safe commands act.

Like a view, :class:`AgentDoor` reads the session's state and turns requests into session calls;
it never drives the link itself except for the three commands that make things safer (Hold,
Land here, Return, carried out like the robot panel's buttons by
:class:`~console.session.vehicle_commands.VehicleCommands`). Everything that would move the robot
is a :class:`~console.mcp.proposals.Proposal` that an operator approves or rejects in the console
(:mod:`console.views.approval_view`).

Every request is one :meth:`AgentDoor.call` (``op``, JSON ``args``) returning a JSON-ready value or
raising :class:`AgentError` with a message naming the bad field, the same words as the console and
the CLI. The MCP server (:mod:`console.mcp.server`) calls it in-process or through the console's
loopback control API (:mod:`console.mcp.control_api`). Every call, proposal and decision is
announced on the session (topic ``agent``), so the recorder writes it to the session's MCAP
(``/agent/events`` and ``/log``) and replay shows it. The proposal requests are
:class:`~console.mcp.door_proposals.ProposalOps` (mixed in); the argument checks :mod:`console.mcp.door_args`.

Safety rules, enforced here whatever the client says:
- proposals only when the door was opened with ``allow_actions``, and never on a real
  (non-loopback) vehicle link unless the console was started with ``--agent-real-vehicle``;
- no request arms, executes or changes parameters by itself: Execute runs only from an operator's
  Approve, and only the mission that was proposed (a mission changed since is not run);
- Hold during a mission pauses it (the mission manager holds the robot); Land here and Return
  during a mission end it first (the robot holds), then land or return as the panel's buttons do.

Frames and units: world frame (z up) [m]; times [s].
"""

from __future__ import annotations

import base64
import logging
import math
import threading
import time
from collections import deque
from typing import Any, Mapping

from console.mcp import state_read as read
from console.mcp.door_args import WHY_MAX, AgentError
from console.mcp.door_args import number_arg as _number
from console.mcp.door_args import text_arg as _text
from console.mcp.door_proposals import ProposalOps
from console.mcp.proposals import Proposal, ProposalError, ProposalQueue
from console.session.session_types import SessionError

log = logging.getLogger(__name__)

WAIT_MAX = 30.0
"""Longest single wait for a decision [s] (the MCP server waits again until decided)."""
EVENTS_KEPT = 300
"""Recent events kept for ``recent_events``."""
READ_OPS = ("summary", "scene_graph", "scene_graph_schema", "objects", "robot_state", "mission_state", "mission_json",
            "scene_json", "last_photo", "recent_events", "proposals", "wait_proposal", "status", "unseen_space")
SAFE_OPS = ("hold", "land_here", "return_to_launch")
PROPOSAL_OPS = ("plan_to_point", "plan_to_object", "propose_capture_and_map", "propose_look_around", "propose_search",
                "propose_mission",
                "withdraw_proposal")


def link_is_real(robot_spec: str) -> bool:
    """Whether the console's robot link reaches beyond this machine: a serial port, or a network
    address other than loopback (``mavlink:udpin:0.0.0.0:14550`` listens on every interface)."""
    from console.hosts import is_loopback

    text = (robot_spec or "").strip()
    if text == "sim" or text.startswith("sim:"):
        return False
    conn = text[len("mavlink:"):] if text.startswith("mavlink:") else text
    parts = conn.split(":")
    if len(parts) >= 3 and parts[0] in ("udp", "udpin", "udpout", "tcp", "tcpin", "udpbcast"):
        return not is_loopback(parts[1])
    return True  # a serial device (/dev/ttyACM0, COM3) or anything unknown: a real vehicle


class AgentDoor(ProposalOps):
    """Serves an agent's requests on a running console (see the module docstring).

    Args:
        session: The console's session.
        commands: The console's vehicle commands (Hold, Land here, Return), or ``None``.
        runner: The mission runner (pause, abort, execute), or ``None``.
        mapping: The capture-and-map job (``start()``, ``running``), or ``None``.
        look: The Look around job (``look_around()``, ``running``, ``pause()``), or ``None``.
        search: The Find job (:class:`console.session.search.SearchJob`: ``start(config)``, ``running``,
            ``paused``, ``pause()``), or ``None``.
        robot_spec: The console's ``--robot`` (a real vehicle link turns proposals off unless ``real_vehicle``).
        real_vehicle: The console was started with ``--agent-real-vehicle``.
        queue: The approval queue (a new one by default).
    """

    def __init__(self, session: Any, commands: Any = None, runner: Any = None, mapping: Any = None,
                 robot_spec: str = "sim", real_vehicle: bool = False, queue: ProposalQueue | None = None,
                 look: Any = None, search: Any = None) -> None:
        self.session = session
        self.search = search
        self.commands = commands
        self.runner = runner
        self.mapping = mapping
        self.look = look
        self.robot_spec = robot_spec
        self.real_vehicle = bool(real_vehicle)
        self.queue = queue if queue is not None else ProposalQueue()
        self._agent_goal: tuple[float, float, float] | None = None  # the candidate goal the agent planned
        self._events: deque[str] = deque(maxlen=EVENTS_KEPT)
        self._lock = threading.Lock()
        self._unsubscribe = [session.subscribe(self._on_session), self.queue.subscribe(self._on_proposal)]

    @property
    def agent_goal(self) -> tuple[float, float, float] | None:
        """The goal of the candidate the agent planned (world [m]) or ``None``, followed when a merge of its object
        planned it again beside the survivor (:meth:`~console.session.object_follow.ObjectFollow.followed_goal`)."""
        goal = self._agent_goal
        follow = getattr(self.session, "followed_goal", None)
        return follow(goal) if goal is not None and follow is not None else goal

    @agent_goal.setter
    def agent_goal(self, goal: tuple[float, float, float] | None) -> None:
        self._agent_goal = goal

    def close(self) -> None:
        for pid in [p.id for p in self.queue.pending()]:
            self.queue.withdraw(pid, "the console is stopping")
        for u in self._unsubscribe:
            u()
        self._unsubscribe = []

    # --- the one entry point ----------------------------------------------------------------------------
    def call(self, op: str, args: Mapping[str, Any] | None = None, allow_actions: bool = False) -> Any:
        """Carry out request ``op`` with ``args``; proposal requests need ``allow_actions``.

        Returns a JSON-ready value; raises :class:`AgentError` (the reason) for a refused request.
        Every call is announced on the session (recorded), waits for decisions excepted.
        """
        args = dict(args or {})
        if not isinstance(op, str) or op not in READ_OPS + SAFE_OPS + PROPOSAL_OPS:
            raise AgentError(f"op: unknown request {op!r}")
        quiet = op in ("wait_proposal", "status")
        try:
            if op in PROPOSAL_OPS:
                why_not = self.actions_blocker(allow_actions)
                if why_not:
                    raise AgentError(why_not)
            result = getattr(self, f"_op_{op}")(args)
        except (AgentError, SessionError, ProposalError) as exc:
            if not quiet:
                self._announce({"event": "tool_call", "tool": op, "args": _brief(args), "ok": False, "error": str(exc)},
                               f"agent {op}: refused: {exc}", "warning")
            raise AgentError(str(exc)) from None
        if not quiet:
            self._announce({"event": "tool_call", "tool": op, "args": _brief(args), "ok": True},
                           f"agent {op}" + (f" ({_brief_text(args)})" if args else ""))
        return result

    def actions_blocker(self, allow_actions: bool) -> str | None:
        """Why proposals are off for this request, or ``None``."""
        if not allow_actions:
            return "proposals are off: start the MCP server with --allow-actions (reading, Hold, Land here and Return stay on)"
        if link_is_real(self.robot_spec) and not self.real_vehicle:
            return (f"proposals are off for a real vehicle link ({self.robot_spec}): start the console with "
                    "--agent-real-vehicle to allow them (Hold, Land here and Return stay on)")
        return None

    # --- recording and events ------------------------------------------------------------------------------
    def _announce(self, event: dict[str, Any], line: str, level: str = "info") -> None:
        event = {**event, "time": time.time(), "text": line, "level": level}
        announce = getattr(self.session, "announce_agent", None)
        if announce is not None:
            announce(event)

    def _on_session(self, topic: str, payload: Any) -> None:
        stamp = time.strftime("%H:%M:%S")
        line = None
        if topic == "notice":
            line = f"{payload.level}: {payload.title}: {payload.body}"
        elif topic == "run" and payload is not None:
            line = f"mission {payload.state}" + (f": {payload.message}" if payload.message else "")
        elif topic == "job" and payload is not None and not payload.running:
            line = f"{payload.name}: {payload.error or payload.message}"
        elif topic == "capture" and payload is not None:
            line = f"capture {payload.id}: {len(payload.detections)} detections"
        elif topic == "mission":
            m = self.session.mission
            line = f"mission {m.id} built: {m.summary()}" if m is not None else None
        elif topic == "agent" and isinstance(payload, dict):
            line = str(payload.get("text", ""))
        if line:
            with self._lock:
                if not self._events or self._events[-1][9:] != line:  # runs report progress often: once per text
                    self._events.append(f"{stamp} {line}")

    def _on_proposal(self, event: str, p: Proposal) -> None:
        if event == "proposed":
            self._announce({"event": "proposal", "proposal": p.to_dict()}, f"agent proposes {p.id}: {p.title} (why: {p.why})")
            self.session.notify("Agent proposal", f"{p.title}. Why: {p.why} (Approve or Reject in the Agent panel)",
                                "warning")
        else:
            self._announce({"event": "decision", "proposal": p.to_dict()}, f"proposal {p.id} {p.state}: {p.outcome}",
                           "warning" if p.state in ("failed",) else "info")

    # --- read ---------------------------------------------------------------------------------------------
    def _op_status(self, args: Mapping[str, Any]) -> dict[str, Any]:
        return {"robot": self.robot_spec, "real_vehicle_link": link_is_real(self.robot_spec),
                "proposals_allowed_on_this_link": not link_is_real(self.robot_spec) or self.real_vehicle}

    def _op_summary(self, args: Mapping[str, Any]) -> str:
        return read.summary(self.session)

    def _op_scene_graph(self, args: Mapping[str, Any]) -> dict[str, Any]:
        return read.scene_graph(self.session)

    def _op_scene_graph_schema(self, args: Mapping[str, Any]) -> dict[str, Any]:
        from planner.scene_graph_schema import SCENE_GRAPH_SCHEMA

        return SCENE_GRAPH_SCHEMA

    def _op_unseen_space(self, args: Mapping[str, Any]) -> dict[str, Any]:
        from console.mcp.unseen import unseen_space

        x, y, _z, _yaw = read.robot_pose(self.session)
        return unseen_space(self.session, (x, y))

    def _op_objects(self, args: Mapping[str, Any]) -> list[dict[str, Any]]:
        return read.objects(self.session)

    def _op_robot_state(self, args: Mapping[str, Any]) -> dict[str, Any]:
        return read.robot_state(self.session, self.runner is not None)

    def _op_mission_state(self, args: Mapping[str, Any]) -> dict[str, Any]:
        out = read.mission_state(self.session, self.runner is not None)
        goal = self.session.route_snapshot().candidate_goal
        out["route"]["candidate_by_agent"] = goal is not None and self.agent_goal is not None and \
            math.dist(goal, self.agent_goal) < 1e-6
        out["proposals"] = [p.to_dict() for p in self.queue.pending()]
        return out

    def _op_mission_json(self, args: Mapping[str, Any]) -> dict[str, Any]:
        return read.mission_json(self.session)

    def _op_scene_json(self, args: Mapping[str, Any]) -> dict[str, Any]:
        from pipeline.scene import scene_to_dict

        return scene_to_dict(self.session.scene)

    def _op_last_photo(self, args: Mapping[str, Any]) -> dict[str, Any]:
        got = read.last_photo(self.session)
        if got is None:
            raise AgentError("no photo yet: nothing was captured in this session")
        jpeg, meta = got
        return {"jpeg_base64": base64.b64encode(jpeg).decode("ascii"), **meta}

    def _op_recent_events(self, args: Mapping[str, Any]) -> list[str]:
        limit = _number(args, "limit", 30)
        if not (limit == int(limit) and 1 <= limit <= EVENTS_KEPT):
            raise AgentError(f"limit: must be a whole number from 1 to {EVENTS_KEPT}, got {args.get('limit')!r}")
        with self._lock:
            return list(self._events)[-int(limit):]

    def _op_proposals(self, args: Mapping[str, Any]) -> dict[str, Any]:
        return {"pending": [p.to_dict() for p in self.queue.pending()], "decided": [p.to_dict() for p in self.queue.decided()]}

    def _op_wait_proposal(self, args: Mapping[str, Any]) -> dict[str, Any]:
        pid = _text(args, "proposal_id", 64, required=True)
        timeout = min(WAIT_MAX, max(0.0, _number(args, "timeout", WAIT_MAX)))
        p = self.queue.wait(pid, timeout)
        final = p.decided
        job = {"capture": self.mapping, "look": self.look}.get(p.kind)
        if final and p.state == "approved" and job is not None:
            end = time.monotonic() + timeout  # the outcome of a capture or a look is the map it made
            while getattr(job, "running", False) and time.monotonic() < end:
                time.sleep(0.1)
            final = not getattr(job, "running", False)
            if final:
                job = self.session.job
                p_out = p.outcome + (f"; mapping: {job.error or job.message}" if job.name else "")
                return {**p.to_dict(), "outcome": p_out, "final": True}
        return {**p.to_dict(), "final": final}

    # --- always allowed: they make things safer -----------------------------------------------------------------
    def _op_hold(self, args: Mapping[str, Any]) -> str:
        why = _text(args, "why", WHY_MAX)
        run = self.session.run
        if run.state == "running" and self.runner is not None:
            self.runner.pause()  # the mission manager holds the robot
            msg = "the mission is paused: the robot holds where it is (the operator may Resume or Abort)"
        elif self.search is not None and self.search.running and not self.search.paused:
            self.search.pause()  # the move under way ends: the robot holds where it is
            msg = "the search is paused: the robot holds where it is (the operator may Resume or Stop)"
        elif self.look is not None and self.look.running and not self.look.paused:
            self.look.pause()  # a turn under way stops; the look waits
            msg = "the look around is paused: the robot holds where it is (the operator may Resume or Stop)"
        else:
            msg = self._command("hold")
        self.session.notify("Agent: Hold", msg + (f". Why: {why}" if why else ""), "warning")
        return msg

    def _op_land_here(self, args: Mapping[str, Any]) -> str:
        return self._end_run_then("land", "Land here", _text(args, "why", WHY_MAX))

    def _op_return_to_launch(self, args: Mapping[str, Any]) -> str:
        return self._end_run_then("return", "Return", _text(args, "why", WHY_MAX))

    def _end_run_then(self, name: str, label: str, why: str, timeout: float = 30.0) -> str:
        if self.session.run.active and self.runner is not None:
            if self.session.run.state == "failsafe":
                raise AgentError(f"{label}: the failsafe is acting (holding, then landing): nothing may interfere")
            try:
                self.runner.abort()  # the robot holds; then the command, like the panel's button
            except Exception as exc:  # ended meanwhile
                log.info("agent %s: abort: %s", label, exc)
            end = time.monotonic() + timeout
            while self.session.run.active and time.monotonic() < end:
                time.sleep(0.05)
        msg = self._command(name)
        self.session.notify(f"Agent: {label}", msg + (f". Why: {why}" if why else ""), "warning")
        return msg

    def _command(self, name: str) -> str:
        if self.commands is None:
            raise AgentError("this console has no vehicle commands (no robot link)")
        return str(self.commands.run(name))


def _brief(args: Mapping[str, Any]) -> dict[str, Any]:
    """The arguments as recorded: long texts cut."""
    return {k: (v[:300] + "…" if isinstance(v, str) and len(v) > 300 else v) for k, v in args.items()}


def _brief_text(args: Mapping[str, Any]) -> str:
    return ", ".join(f"{k}={v!r}" for k, v in _brief(args).items())[:400]


__all__ = ["AgentDoor", "AgentError", "PROPOSAL_OPS", "READ_OPS", "SAFE_OPS", "link_is_real"]
