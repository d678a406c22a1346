"""``console --mcp PORT``: the MCP server inside the console over streamable HTTP (the SDK's own client),
read tools only unless ``--mcp-allow-actions``; the last photo as image content; floods refused (``morphonavi mcp``
with no console running: tests/console/cli/test_mcp_no_console.py). Skipped without the ``mcp`` package."""

from __future__ import annotations

import base64
import json
from pathlib import Path

import pytest

from console.app import ConsoleApp, ConsoleConfig, wait_until
from console.link.world import paper_room

mcp = pytest.importorskip("mcp.client.session", reason="the mcp package is not installed (pip install 'mcp>=2.3,<3')")
DEADLINE = 120.0  # [s] generous: the machine may be loaded
READ_AND_SAFETY = {"get_scene_summary", "get_scene_graph", "list_objects", "get_robot_state", "get_mission_state",
                   "get_last_photo", "get_unseen_space", "get_recent_events", "hold", "land_here", "return_to_launch"}


def test_the_console_serves_mcp_over_http_read_tools_and_the_last_photo(tmp_path: Path) -> None:
    import anyio
    from mcp.client.session import ClientSession
    from mcp.client.streamable_http import streamable_http_client

    app = ConsoleApp(ConsoleConfig(robot="sim", session_dir=tmp_path / "s", scene_dir=tmp_path / "scenes", port=0,
                                   fresh=True, mcp_port=0)).start()
    try:
        session = app.session
        session.spawn(paper_room(), origin="test")
        assert wait_until(lambda: session.robot is not None, DEADLINE)
        assert app.mapping.start()  # one capture (ground-truth perception on the simulator)
        assert wait_until(lambda: session.capture is not None and not app.mapping.running, DEADLINE)

        async def agent() -> None:
            async with streamable_http_client(app.mcp_host.url) as streams, ClientSession(*streams[:2]) as client:
                await client.initialize()
                names = {t.name for t in (await client.list_tools()).tools}
                assert names == READ_AND_SAFETY  # no proposal tools without --mcp-allow-actions
                photo = await client.call_tool("get_last_photo", {})
                assert not photo.is_error
                image, meta = photo.content
                assert image.type == "image" and image.mime_type == "image/jpeg"
                assert base64.b64decode(image.data)[:2] == b"\xff\xd8"  # a JPEG
                info = json.loads(meta.text)
                assert info["capture"] == session.capture.id and len(info["detections"]) == len(session.capture.detections)
                graph = json.loads((await client.call_tool("get_scene_graph", {"include_schema": True})).content[0].text)
                assert graph["schema"]["title"] and any(o["id"] == "robot_dog-1" for o in graph["graph"]["objects"])
                hold = await client.call_tool("hold", {"why": "test"})  # standing disarmed: Hold does not apply
                assert hold.is_error and "Hold applies only while the robot is armed or off the ground" in hold.content[0].text
                scene = await client.read_resource("morphonavi://scene.json")
                assert any(o["id"] == "robot_dog-1" for o in json.loads(scene.contents[0].text)["objects"])
                prompts = {p.name for p in (await client.list_prompts()).prompts}
                assert prompts == {"describe_the_room", "find_an_object"}

        anyio.run(agent)
    finally:
        app.stop()


def test_an_agent_flooding_proposals_is_rate_limited(tmp_path: Path) -> None:
    from console.mcp.door import AgentDoor, AgentError
    from console.session.session import Session

    door = AgentDoor(Session(tmp_path / "s"), mapping=object(), robot_spec="sim")
    try:
        for i in range(3):
            door.call("propose_capture_and_map", {"why": f"look {i}"}, allow_actions=True)
        with pytest.raises(AgentError, match=r"rate limited: 3 proposals already wait for the operator"):
            door.call("propose_capture_and_map", {"why": "look again"}, allow_actions=True)
        for p in door.queue.pending():
            door.queue.reject(p.id)
        for i in range(3):
            door.call("propose_capture_and_map", {"why": f"more {i}"}, allow_actions=True)
            door.queue.reject(door.queue.pending()[0].id)
        with pytest.raises(AgentError, match=r"rate limited: at most 6 proposals per 60 s; try again in \d+ s"):
            door.call("propose_capture_and_map", {"why": "and again"}, allow_actions=True)
    finally:
        door.close()
