"""The MorphoNavi MCP server: tools, resources and prompts over a console's agent door.

Built with the official ``mcp`` SDK (:class:`mcp.server.mcpserver.MCPServer`). Every tool is one
request to the console through a *bridge* (``call(op, args)``): in-process for ``console --mcp``,
over the console's loopback control API for ``morphonavi mcp`` (:mod:`console.mcp.control_api`).

Tools (world frame, z up, metres):
- read, always on: ``get_scene_summary``, ``get_scene_graph``, ``list_objects``, ``get_robot_state``,
  ``get_mission_state``, ``get_last_photo``, ``get_recent_events``;
- safety, always on (they make things safer): ``hold``, ``land_here``, ``return_to_launch``;
- proposals, only with ``--allow-actions``: ``plan_to_point``, ``plan_to_object`` (a candidate path
  labelled as the agent's in the console; nothing moves), ``propose_capture_and_map``, ``propose_look_around``,
  ``propose_mission`` (they return once the operator approves or rejects in the console, with the
  outcome) and ``wait_for_decision``.

Resources: ``morphonavi://scene.json``, ``morphonavi://mission.json``,
``morphonavi://scene-graph-schema.json``. Prompts: ``describe_the_room``, ``find_an_object``.
"""

import base64
import json
from typing import Any, Optional, Protocol

import anyio
import anyio.to_thread
from mcp.server.mcpserver import Context, Image, MCPServer
from mcp.server.mcpserver.exceptions import ToolError
from mcp_types import ToolAnnotations

from console.mcp.door import AgentError

DECISION_TIMEOUT = 600.0
"""How long a proposal tool waits for the operator before answering "still pending" [s]."""
INSTRUCTIONS = """MorphoNavi: a mapped room and an aerial-ground robot (it walks, takes off, flies, lands) watched by a \
human operator in a browser console. World frame: x, y on the floor, z up, metres. Read the map with \
get_scene_summary / get_scene_graph / list_objects, the robot with get_robot_state, the route and mission with \
get_mission_state. Nothing you do moves the robot by itself: plan_to_object / plan_to_point make a candidate path, \
propose_mission asks the operator to execute it, and you get the operator's decision. hold, land_here and \
return_to_launch always work and act at once: use them when something looks unsafe."""


class Bridge(Protocol):
    def call(self, op: str, args: Optional[dict] = None) -> Any: ...


async def _call(bridge: Bridge, op: str, args: Optional[dict] = None) -> Any:
    """One request on a worker thread (the bridge blocks); a refusal becomes the tool's error text."""
    try:
        return await anyio.to_thread.run_sync(bridge.call, op, args or {})
    except AgentError as exc:
        raise ToolError(str(exc)) from None


def _json(value: Any) -> str:
    return json.dumps(value, indent=1)


def build_server(bridge: Bridge, allow_actions: bool = False, decision_timeout: float = DECISION_TIMEOUT) -> MCPServer:
    """The MCP server for ``bridge``; proposal tools only when ``allow_actions``."""
    mcp = MCPServer("morphonavi", instructions=INSTRUCTIONS, log_level="WARNING")  # stderr: stdout is the protocol
    read_only = ToolAnnotations(read_only_hint=True, destructive_hint=False, open_world_hint=False)
    acts = ToolAnnotations(read_only_hint=False, destructive_hint=False, open_world_hint=True)

    async def call(op: str, args: Optional[dict] = None) -> Any:
        return await _call(bridge, op, args)

    # --- read ----------------------------------------------------------------------------------------
    @mcp.tool(annotations=read_only, structured_output=False)
    async def get_scene_summary() -> str:
        """A short text summary of the mapped room, as seen from the robot: objects, where they stand,
        what is behind what, which can be reached by walking or flying."""
        return str(await call("summary"))

    @mcp.tool(annotations=read_only, structured_output=False)
    async def get_scene_graph(include_schema: bool = False) -> str:
        """The scene graph as JSON: objects (centre, size [w, h, l], support, direction from the robot,
        visibility, reachability), relations, groups, uncertainties. include_schema adds its JSON schema."""
        graph = await call("scene_graph")
        if include_schema:
            return _json({"graph": graph, "schema": await call("scene_graph_schema")})
        return _json(graph)

    @mcp.tool(annotations=read_only, structured_output=False)
    async def list_objects() -> str:
        """Every mapped object as JSON: id, label, score, centre and size [m], yaw [rad], position
        uncertainty (sigma_xy, sigma_ray [m]) and the captures that saw it."""
        return _json(await call("objects"))

    @mcp.tool(annotations=read_only, structured_output=False)
    async def get_robot_state() -> str:
        """The robot as JSON: position (or why it is unknown), mode, armed, landed, battery (0-1), link
        health, readiness, warnings, latest messages, and which of hold / land / return apply now."""
        return _json(await call("robot_state"))

    @mcp.tool(annotations=read_only, structured_output=False)
    async def get_mission_state() -> str:
        """The route (start, registered goals, candidate: whether the agent planned it), the built
        mission (segments), its run (state, segment, progress) and the proposals awaiting the operator."""
        return _json(await call("mission_state"))

    @mcp.tool(annotations=read_only, structured_output=False)
    async def get_unseen_space() -> str:
        """What no capture has seen yet: the known space's share seen, cells free / occupied / unknown,
        unlabelled obstacle cells (seen but no mapped object explains them), whether routes may enter
        unknown space, and the frontier: seen-free floor points next to unseen floor, world frame [m],
        nearest the robot first (where to look next). ``known: false`` before the first capture."""
        return _json(await call("unseen_space"))

    @mcp.tool(annotations=read_only, structured_output=False)
    async def get_last_photo() -> list[Any]:
        """The last photo the robot took (JPEG) and its detections (label, score, box in pixels of
        the full photo, the mapped object it became) with the camera and robot positions."""
        got = await call("last_photo")
        jpeg = base64.b64decode(got.pop("jpeg_base64"))
        return [Image(data=jpeg, format="jpeg"), _json(got)]

    @mcp.tool(annotations=read_only, structured_output=False)
    async def get_recent_events(limit: int = 30) -> str:
        """The console's latest events, oldest first: notices, mapping results, mission progress,
        agent requests and the operator's decisions (limit: 1 to 300 lines)."""
        return "\n".join(await call("recent_events", {"limit": limit})) or "(no events yet)"

    # --- safety: always on ------------------------------------------------------------------------------
    @mcp.tool(annotations=acts, structured_output=False)
    async def hold(why: str = "") -> str:
        """Stop the robot where it is, now. During a mission this pauses it (the operator may resume or
        abort). Always allowed."""
        return str(await call("hold", {"why": why}))

    @mcp.tool(annotations=acts, structured_output=False)
    async def land_here(why: str = "") -> str:
        """Land straight down where the robot hovers (refused above a mapped obstacle, with the reason).
        A mission under way is ended first. Always allowed."""
        return str(await call("land_here", {"why": why}))

    @mcp.tool(annotations=acts, structured_output=False)
    async def return_to_launch(why: str = "") -> str:
        """Go back to the launch spot (where the robot last stood disarmed), walking or flying, then land.
        A mission under way is ended first. Always allowed."""
        return str(await call("return_to_launch", {"why": why}))

    if not allow_actions:
        return mcp

    # --- proposals ------------------------------------------------------------------------------------
    async def decided(first: dict, ctx: Optional[Context]) -> str:
        pid = first["id"]
        end = anyio.current_time() + decision_timeout
        waited = 0
        p = first
        try:
            while not p.get("final"):
                left = end - anyio.current_time()
                if left <= 0:
                    return _json({**p, "note": "still waiting for the operator: call wait_for_decision with this id"})
                p = await call("wait_proposal", {"proposal_id": pid, "timeout": min(20.0, left)})
                waited += 1
                if ctx is not None and not p.get("final"):
                    try:
                        await ctx.report_progress(waited, None, f"waiting for the operator to approve or reject {pid}")
                    except Exception:  # a client that takes no progress
                        pass
        except anyio.get_cancelled_exc_class():
            with anyio.CancelScope(shield=True):  # the agent gave up: take the proposal off the panel
                try:
                    await call("withdraw_proposal", {"proposal_id": pid, "why": "the agent cancelled its request"})
                except ToolError:
                    pass
            raise
        return _json({k: p[k] for k in ("id", "kind", "title", "state", "outcome", "note") if k in p})

    @mcp.tool(annotations=acts, structured_output=False)
    async def plan_to_point(x: float, y: float, z: float = 0.0, why: str = "") -> str:
        """Plan a candidate path from the end of the route to the point (x, y, z) [m, world frame, z
        above the floor]. It appears in the console labelled as proposed by the agent; nothing moves."""
        return _json(await call("plan_to_point", {"x": x, "y": y, "z": z, "why": why}))

    @mcp.tool(annotations=acts, structured_output=False)
    async def plan_to_object(object: str, why: str = "") -> str:  # noqa: A002 (the agent's word)
        """Plan a candidate path to the free floor beside an object, named by id or label ("robot dog",
        "robot_dog-1"). It appears in the console labelled as proposed by the agent; nothing moves."""
        return _json(await call("plan_to_object", {"object": object, "why": why}))

    @mcp.tool(annotations=acts, structured_output=False)
    async def propose_mission(why: str, ctx: Context) -> str:
        """Ask the operator to execute the route (the candidate is registered, the mission built and
        shown in the console). Returns when the operator approves (the mission starts) or rejects it,
        with the outcome. why: your reason, shown to the operator."""
        return await decided(await call("propose_mission", {"why": why}), ctx)

    @mcp.tool(annotations=acts, structured_output=False)
    async def propose_capture_and_map(why: str, ctx: Context) -> str:
        """Ask the operator to take a photo from where the robot is and map it. Returns once decided
        (and, if approved, once the map is updated), with the outcome."""
        return await decided(await call("propose_capture_and_map", {"why": why}), ctx)

    @mcp.tool(annotations=acts, structured_output=False)
    async def propose_look_around(why: str, ctx: Context) -> str:
        """Ask the operator to let the robot turn in place through 6 headings, capturing and mapping at
        each. Returns once decided (and, if approved, once the look has ended), with the outcome."""
        return await decided(await call("propose_look_around", {"why": why}), ctx)

    @mcp.tool(annotations=acts, structured_output=False)
    async def propose_search(target: str, why: str, ctx: Context, mode: str = "auto", max_captures: int = 20) -> str:
        """Propose a search (Find) for ``target`` (a catalog class such as "robot dog"): the console picks
        viewpoints, moves there, captures and maps until the target is found or the budget ends. Nothing
        moves until the operator approves in the console. ``mode``: ``auto`` or ``step`` (the operator
        approves each move); ``max_captures``: 1..200. Returns when the operator decides."""
        return await decided(await call("propose_search", {"target": target, "why": why, "mode": mode,
                                                           "max_captures": max_captures}), ctx)

    @mcp.tool(annotations=read_only, structured_output=False)
    async def wait_for_decision(proposal_id: str, ctx: Context) -> str:
        """Keep waiting for the operator's decision on a proposal that was still pending."""
        return await decided({"id": proposal_id, "final": False}, ctx)

    return mcp


def add_resources_and_prompts(mcp: Any, bridge: Bridge) -> None:
    """The scene and mission JSON and the scene graph schema as resources; two prompts."""

    @mcp.resource("morphonavi://scene.json", name="scene", mime_type="application/json",
                  description="The mapped scene (world frame, metres): objects and the captures they came from")
    async def scene() -> str:
        return _json(await _call(bridge, "scene_json"))

    @mcp.resource("morphonavi://mission.json", name="mission", mime_type="application/json",
                  description="The built mission: walk / take-off / fly / land segments, or null")
    async def mission() -> str:
        return _json(await _call(bridge, "mission_json"))

    @mcp.resource("morphonavi://scene-graph-schema.json", name="scene graph schema", mime_type="application/json",
                  description="The JSON schema of get_scene_graph's output")
    async def schema() -> str:
        return _json(await _call(bridge, "scene_graph_schema"))

    @mcp.prompt(name="describe_the_room", description="Describe the mapped room for the operator")
    def describe_the_room() -> str:
        return ("Call get_scene_summary (and get_scene_graph for details), then describe the room to the operator in a "
                "few sentences: what stands where, what is hidden behind what, which objects the robot can reach by "
                "walking and which only by flying, and what is uncertain in the map.")

    @mcp.prompt(name="find_an_object", description="Find an object in the room and propose a mission to it")
    def find_an_object(object: str) -> str:  # noqa: A002
        return (f"Find the {object} in the room. Read get_scene_summary and list_objects. If it is mapped, call "
                f"plan_to_object with it and then propose_mission, saying why. If it is not mapped yet, propose "
                "propose_capture_and_map and read the map again. Never assume the robot moved until "
                "get_robot_state says so; use hold if anything looks unsafe.")


def make_server(bridge: Bridge, allow_actions: bool = False, decision_timeout: float = DECISION_TIMEOUT) -> Any:
    """:func:`build_server` with the resources and prompts."""
    mcp = build_server(bridge, allow_actions, decision_timeout)
    add_resources_and_prompts(mcp, bridge)
    return mcp


__all__ = ["DECISION_TIMEOUT", "INSTRUCTIONS", "build_server", "make_server"]
