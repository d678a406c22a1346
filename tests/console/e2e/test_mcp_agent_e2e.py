"""An agent with the MCP SDK's own client over stdio, a console on the simulator, an operator in Chromium.

The console runs in this process (simulated robot, the paper's room spawned into the map); the agent
is ``morphonavi mcp --allow-actions`` started by the SDK's ``stdio_client``. The agent lists the
tools, reads the room's summary, plans to "robot dog" and proposes the mission: the robot has not
moved while the proposal waits. The operator approves it in the page's Agent panel (headless
Chromium, Playwright) and the robot executes it; Hold from the agent pauses the mission and the
robot holds; a second proposal rejected in the page reaches the agent with the operator's note.
Every tool call, proposal and decision is in the session's MCAP. Skipped, with the reason, without
``/usr/bin/chromium``, ``playwright`` or ``mcp``. ``MORPHONAVI_UPDATE_SCREENSHOT=1`` refreshes
``docs/agent_panel.png`` (the page with the mission proposal waiting).
"""

from __future__ import annotations

import json
import math
import os
import queue
import sys
import tempfile
import threading
from pathlib import Path
from typing import Any, Callable

import pytest

from console.app import ConsoleApp, ConsoleConfig, wait_until
from console.link.world import paper_room

CHROMIUM = Path("/usr/bin/chromium")
BROWSER_ARGS = ["--headless", "--no-sandbox", "--disable-gpu", "--no-first-run", "--disable-background-networking",
                "--disable-component-update", "--disable-sync", "--use-angle=swiftshader", "--enable-unsafe-swiftshader"]
REPO = Path(__file__).resolve().parents[3]
TOOLS = {"get_scene_summary", "get_scene_graph", "list_objects", "get_robot_state", "get_mission_state",
         "get_last_photo", "get_unseen_space", "get_recent_events", "hold", "land_here", "return_to_launch", "plan_to_point",
         "plan_to_object", "propose_mission", "propose_capture_and_map", "propose_look_around", "propose_search",
         "wait_for_decision"}
DEADLINE = 120.0  # [s] generous: the machine may be loaded
SHOT = REPO / "docs" / "agent_panel.png"
UPDATE_SHOT = os.environ.get("MORPHONAVI_UPDATE_SCREENSHOT") == "1"  # refresh docs/agent_panel.png


def _missing() -> str | None:
    if not CHROMIUM.exists():
        return "Debian's chromium is not installed (/usr/bin/chromium); run `make browser`"
    for module, hint in (("playwright.sync_api", "pip install playwright"), ("mcp.client.stdio", "pip install 'mcp>=2.3,<3'")):
        try:
            __import__(module)
        except ImportError:
            return f"the {module.split('.')[0]} package is not installed ({hint})"
    return None


class Operator:
    """One Chromium page on the console, driven from its own thread (Playwright's sync API is bound to one)."""

    def __init__(self, url: str, tmp: Path) -> None:
        self._url, self._tmp = url, tmp
        self._todo: queue.Queue[Callable[[Any], Any] | None] = queue.Queue()
        self._done: queue.Queue[tuple[bool, Any]] = queue.Queue()
        self._thread = threading.Thread(target=self._run, daemon=True)
        self._thread.start()

    def _run(self) -> None:
        from playwright.sync_api import sync_playwright

        with sync_playwright() as pw:
            ctx = pw.chromium.launch_persistent_context(
                tempfile.mkdtemp(prefix="chromium-", dir=self._tmp), executable_path=str(CHROMIUM), headless=True,
                args=BROWSER_ARGS, viewport={"width": 1440, "height": 900})
            try:
                page = ctx.new_page()
                page.goto(self._url)
                while (job := self._todo.get()) is not None:
                    try:
                        self._done.put((True, job(page)))
                    except Exception as exc:  # noqa: BLE001 (handed to the test thread)
                        self._done.put((False, exc))
            finally:
                ctx.close()

    def do(self, job: Callable[[Any], Any]) -> Any:
        self._todo.put(job)
        ok, value = self._done.get(timeout=4 * DEADLINE)
        if not ok:
            raise value
        return value

    def close(self) -> None:
        self._todo.put(None)
        self._thread.join(DEADLINE)


def decide(button: str, reason: str, note: str = "", view: Any = None, shot: Path | None = None) -> Callable[[Any], str]:
    """In the page: wait for the proposal with ``reason`` in the Agent panel, optionally type a note
    (and wait until ``view``, the server's Agent panel, has it), click ``button``. ``shot``: save a
    screenshot of the page with the proposal waiting there first."""

    def job(page: Any) -> str:
        page.get_by_text(reason).first.wait_for(timeout=DEADLINE * 1000)  # the agent's own words are shown
        if shot is not None:
            page.get_by_role("button", name=button).wait_for(timeout=DEADLINE * 1000)
            page.screenshot(path=str(shot))
        if note:
            label = page.get_by_text("Note to the agent", exact=True)  # viser's text input has no label id
            label.locator("xpath=ancestor::*[.//input][1]//input").first.fill(note)
            assert wait_until(lambda: view.note_text == note, DEADLINE), "the note did not reach the console"
        page.get_by_role("button", name=button).click(timeout=DEADLINE * 1000)  # waits until it stands still
        return button

    return job


async def _poll(predicate: Callable[[], bool], what: str, timeout: float = DEADLINE) -> None:
    import anyio

    with anyio.move_on_after(timeout):
        while not predicate():
            await anyio.sleep(0.05)
        return
    raise AssertionError(f"timed out waiting for {what}")


def _text(result: Any) -> str:
    assert not result.is_error, result.content[0].text
    return result.content[0].text


@pytest.mark.skipif(_missing() is not None, reason=_missing() or "")
def test_an_agent_over_stdio_plans_proposes_and_the_operator_decides_in_the_browser(tmp_path: Path) -> None:
    import anyio
    from mcp.client.session import ClientSession
    from mcp.client.stdio import StdioServerParameters, stdio_client

    app = ConsoleApp(ConsoleConfig(robot="sim", session_dir=tmp_path / "s", scene_dir=tmp_path / "scenes", port=0,
                                   fresh=True)).start()
    session, door = app.session, app.agent
    operator: Operator | None = None
    try:
        session.spawn(paper_room(), origin="test")
        assert wait_until(lambda: session.robot is not None, DEADLINE), "no state from the simulated robot"
        operator = Operator(app.url, tmp_path)

        def position() -> tuple[float, float, float]:
            return tuple(float(v) for v in session.robot.pose.translation)  # type: ignore[union-attr]

        async def agent() -> None:
            params = StdioServerParameters(command=sys.executable, cwd=str(REPO), args=[
                "-m", "console.cli.morphonavi", "mcp", "--session", str(session.folder), "--allow-actions"])
            async with stdio_client(params) as (read, write), ClientSession(read, write) as mcp:
                await mcp.initialize()
                names = {t.name for t in (await mcp.list_tools()).tools}
                assert names == TOOLS

                summary = _text(await mcp.call_tool("get_scene_summary", {}))
                assert "robot dog (robot_dog-1)" in summary and "cardboard box" in summary
                start = json.loads(_text(await mcp.call_tool("get_robot_state", {})))["position"]
                assert math.dist(start, position()) < 0.05

                plan = json.loads(_text(await mcp.call_tool(
                    "plan_to_object", {"object": "robot dog", "why": "the operator asked where the dog is"})))
                assert plan["object"]["id"] == "robot_dog-1" and plan["max_height_m"] > 1.2  # over the boxes
                goal = session.route_snapshot().candidate_goal
                assert goal is not None and math.dist(goal[:2], paper_room().object("robot_dog-1").position[:2]) < 1.0
                assert app.views["approval"].labelled  # "proposed by the agent" at the candidate's goal

                # the mission proposal waits for the operator: nothing moves meanwhile
                answers: dict[str, str] = {}

                async def propose(tool: str, why: str) -> None:
                    answers[tool] = _text(await mcp.call_tool(tool, {"why": why}))

                async with anyio.create_task_group() as tg:
                    tg.start_soon(propose, "propose_mission", "go and look at the robot dog behind the boxes")
                    await _poll(lambda: bool(door.queue.pending()), "the mission proposal")
                    assert session.mission is not None and session.run.state == "idle"
                    assert app.views["approval"].labelled  # still at the registered route's last goal
                    assert math.dist(start, position()) < 0.05, "the robot moved before the operator approved"
                    await anyio.to_thread.run_sync(operator.do, decide("Approve", "go and look at the robot dog",
                                                                        shot=SHOT if UPDATE_SHOT else None))
                outcome = json.loads(answers["propose_mission"])
                assert outcome["state"] == "approved" and outcome["outcome"].startswith(f"mission {session.mission.id} started")

                await _poll(lambda: session.run.state == "running" and math.dist(start, position()) > 0.3,
                            "the robot executing the approved mission")

                held = _text(await mcp.call_tool("hold", {"why": "a person walked in"}))
                assert held.startswith("the mission is paused: the robot holds where it is")
                await _poll(lambda: session.run.state == "paused", "the mission paused by the agent's Hold")
                here, stamp = position(), session.robot.stamp
                await _poll(lambda: session.robot.stamp > stamp + 1.0, "a second of robot states after Hold")
                assert math.dist(here, position()) < 0.02, "the robot kept moving after Hold"

                async with anyio.create_task_group() as tg:
                    tg.start_soon(propose, "propose_capture_and_map", "take a photo of the corner behind the boxes")
                    await _poll(lambda: bool(door.queue.pending()), "the capture proposal")
                    await anyio.to_thread.run_sync(operator.do, decide("Reject", "photo of the corner behind the boxes",
                                                                        note="not while the robot holds",
                                                                        view=app.views["approval"]))
                told = json.loads(answers["propose_capture_and_map"])
                assert told["state"] == "rejected"
                assert told["outcome"] == "rejected by the operator: not while the robot holds"
                assert session.capture is None and session.run.state == "paused"  # nothing was captured

                events = _text(await mcp.call_tool("get_recent_events", {"limit": 300}))
                assert "approved: mission" in events and "rejected by the operator" in events

        anyio.run(agent)
    finally:
        if operator is not None:
            operator.close()
        app.stop()

    from mcap.reader import make_reader

    recorded: list[dict[str, Any]] = []
    for path in sorted((tmp_path / "s" / "recordings").glob("*.mcap")):
        with open(path, "rb") as f:
            for _, channel, message in make_reader(f).iter_messages(topics=["/agent/events"]):
                recorded.append(json.loads(message.data))
    kinds = [(e["event"], e.get("tool") or e["proposal"]["state"]) for e in recorded]
    for expected in [("tool_call", "summary"), ("tool_call", "plan_to_object"),
                     ("proposal", "pending"), ("decision", "approved"), ("tool_call", "hold"), ("decision", "rejected")]:
        assert expected in kinds, f"{expected} not recorded: {kinds}"
    from mcap_protobuf.decoder import DecoderFactory

    lines = []  # what replay lists in its log
    for path in sorted((tmp_path / "s" / "recordings").glob("*.mcap")):
        with open(path, "rb") as f:
            for _, _, _, log in make_reader(f, decoder_factories=[DecoderFactory()]).iter_decoded_messages(topics=["/log"]):
                if log.name == "agent":
                    lines.append(log.message)
    assert any(line.startswith("agent proposes p-") for line in lines)
    assert any("rejected: rejected by the operator: not while the robot holds" in line for line in lines), lines
