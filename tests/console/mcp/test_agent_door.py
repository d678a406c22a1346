"""The agent door and its approval queue without an MCP client or a browser: what an agent may read,
what it is refused (naming the field), flooding, the real-vehicle rule, approve / reject outcomes,
and the control API's token (the MCP tools over stdio: tests/console/e2e/test_mcp_agent_e2e.py)."""

from __future__ import annotations

import json
import sys
import threading
import urllib.request
from pathlib import Path

import pytest

from console.link.world import paper_room
from console.mcp.control_api import AGENT_FILE, ConsoleBridge, ConsoleUnavailable, ControlAPI
from console.mcp.door import AgentDoor, AgentError, link_is_real
from console.mcp.proposals import ProposalError, ProposalQueue
from console.session.session import RobotSnapshot, Session, SessionError
from pipeline.camera.geometry import Pose


class FakeRunner:
    def __init__(self) -> None:
        self.executed: list[str] = []

    def execute(self, mission, command: str = "") -> None:
        self.executed.append(mission.id)

    def pause(self) -> None: ...

    def abort(self) -> None: ...


@pytest.fixture()
def door(tmp_path: Path) -> AgentDoor:
    s = Session(tmp_path / "s")
    s.spawn(paper_room(), origin="test")
    d = AgentDoor(s, runner=FakeRunner(), robot_spec="sim")
    yield d
    d.close()


def test_the_queue_refuses_floods_naming_the_limit() -> None:
    now = [0.0]
    q = ProposalQueue(max_pending=2, rate_limit=3, rate_window=60.0, clock=lambda: now[0])
    a = q.propose("mission", "A", "why a", lambda: "done a")
    q.propose("mission", "B", "why b", lambda: "done b")
    with pytest.raises(ProposalError, match=r"rate limited: 2 proposals already wait for the operator \(at most 2\)"):
        q.propose("mission", "C", "why c", lambda: "c")
    q.reject(a.id, "not now")
    q.propose("mission", "C", "why c", lambda: "c")
    q.reject(q.pending()[0].id)
    with pytest.raises(ProposalError, match=r"at most 3 proposals per 60 s; try again in 60 s"):
        q.propose("mission", "D", "why d", lambda: "d")
    now[0] = 61.0  # the window slides: allowed again
    assert q.propose("mission", "D", "why d", lambda: "d").state == "pending"


def test_approve_runs_the_action_once_and_reject_tells_why() -> None:
    q = ProposalQueue()
    ran: list[int] = []
    p = q.propose("mission", "Go", "because", lambda: ran.append(1) or "started")
    waiter: dict[str, object] = {}
    t = threading.Thread(target=lambda: waiter.update(p=q.wait(p.id, 60.0)))
    t.start()
    assert q.approve(p.id).outcome == "started"
    t.join(60.0)
    assert waiter["p"].state == "approved" and ran == [1]
    with pytest.raises(ProposalError, match="already decided: approved"):
        q.approve(p.id)
    assert ran == [1]
    r = q.propose("capture", "Capture", "look", lambda: "x")
    assert q.reject(r.id, "the robot is charging").outcome == "rejected by the operator: the robot is charging"

    def refuse() -> str:
        raise SessionError("Execute is off: battery 18 %")

    f = q.propose("mission", "Go", "because", refuse)
    out = q.approve(f.id)
    assert out.state == "failed" and out.outcome == "approved, but not carried out: Execute is off: battery 18 %"


@pytest.mark.parametrize("spec, real", [
    ("sim", False), ("mavlink:udpin:127.0.0.1:14550", False), ("mavlink:tcp:localhost:5760", False),
    ("mavlink:udpin:0.0.0.0:14550", True), ("mavlink:udpout:192.168.1.20:14550", True),
    ("mavlink:/dev/ttyACM0", True), ("mavlink:COM3", True)])
def test_a_real_vehicle_link_is_told_from_a_loopback_one(spec: str, real: bool) -> None:
    assert link_is_real(spec) is real


def test_proposals_need_allow_actions_and_the_real_vehicle_flag(door: AgentDoor) -> None:
    with pytest.raises(AgentError, match="proposals are off: start the MCP server with --allow-actions"):
        door.call("plan_to_object", {"object": "robot dog"})
    door.robot_spec = "mavlink:udpin:0.0.0.0:14550"
    with pytest.raises(AgentError, match=r"proposals are off for a real vehicle link .*--agent-real-vehicle"):
        door.call("plan_to_object", {"object": "robot dog"}, allow_actions=True)
    assert "robot dog" in door.call("summary")  # reading stays on
    door.real_vehicle = True
    assert door.call("plan_to_object", {"object": "robot dog"}, allow_actions=True)["object"]["id"] == "robot_dog-1"


@pytest.mark.parametrize("op, args, message", [
    ("plan_to_point", {"x": "abc", "y": 1.0}, "goal.x: must be a number [m], got 'abc'"),
    ("plan_to_point", {"x": 1.0, "y": 9.0}, "goal.y: 9.00 m is outside the workspace (0.00 to 8.00 m)"),
    ("plan_to_point", {"x": 1.0, "y": float("nan")}, "goal.y: must be a finite number [m], got nan"),
    ("plan_to_object", {"object": "unicorn"}, "object: no object with id or label 'unicorn' in the scene (labels: "),
    ("plan_to_object", {"object": ""}, "object: must not be empty"),
    ("plan_to_object", {"object": ["robot dog"]}, "object: must be text, got list"),
    ("propose_mission", {"why": ""}, "why: must not be empty: say why, for the operator"),
    ("propose_mission", {"why": "x" * 3000}, "why: at most 2000 characters, got 3000"),
    ("propose_mission", {"why": "go"}, "mission: register at least one path segment before building the mission"),
    ("recent_events", {"limit": 0}, "limit: must be a whole number from 1 to 300, got 0"),
    ("wait_proposal", {"proposal_id": "p-nope", "timeout": 0}, "proposal_id: no proposal 'p-nope'"),
    ("fly_anywhere", {}, "op: unknown request 'fly_anywhere'"),
])
def test_bad_agent_input_is_refused_naming_the_field(door: AgentDoor, op: str, args: dict, message: str) -> None:
    with pytest.raises(AgentError) as err:
        door.call(op, args, allow_actions=True)
    assert message in str(err.value)
    assert door.session.mission is None and door.runner.executed == []


def test_reading_tools_give_objects_robot_and_mission(door: AgentDoor) -> None:
    objs = {o["id"]: o for o in door.call("objects")}
    dog = objs["robot_dog-1"]
    assert dog["label"] == "robot_dog" and len(dog["centre"]) == 3 and len(dog["size"]) == 3
    assert {"sigma_xy", "sigma_ray", "captures"} <= set(dog)
    graph = door.call("scene_graph")
    assert graph["schema"] and any(o["id"] == "robot_dog-1" for o in graph["objects"])
    import jsonschema

    jsonschema.validate(graph, door.call("scene_graph_schema"))
    assert door.call("robot_state") == {"known": False,
                                        "why": "no state from the robot yet (the link may still be connecting)"}
    assert door.call("mission_state")["mission"] is None
    with pytest.raises(AgentError, match="no photo yet"):
        door.call("last_photo")


def test_a_proposed_mission_runs_only_when_approved_and_only_as_proposed(door: AgentDoor) -> None:
    door.session.set_robot(RobotSnapshot(Pose.from_xyz_yaw(2.5, 0.7, 0.0), mode="idle", armed=False, landed=True))
    door.call("plan_to_object", {"object": "robot dog", "why": "find the dog"}, allow_actions=True)
    p = door.call("propose_mission", {"why": "the operator asked for the dog"}, allow_actions=True)
    assert p["state"] == "pending" and door.runner.executed == []  # built, shown, not executed
    assert door.call("mission_state")["proposals"][0]["id"] == p["id"]
    out = door.queue.approve(p["id"])
    assert out.state == "approved" and door.runner.executed == [p["mission"]["id"]]
    # a second proposal whose mission the operator rebuilds meanwhile is not run on approval
    door.call("plan_to_point", {"x": 1.0, "y": 1.0}, allow_actions=True)
    q = door.call("propose_mission", {"why": "back"}, allow_actions=True)
    door.session.build_mission()  # the operator rebuilds: another mission id
    out = door.queue.approve(q["id"])
    assert out.state == "failed" and "the mission changed since the agent proposed" in out.outcome
    assert door.runner.executed == [p["mission"]["id"]]


def test_the_control_api_needs_the_token_from_the_session_folder(door: AgentDoor, tmp_path: Path) -> None:
    folder = door.session.folder
    api = ControlAPI(door, folder).start()
    try:
        info = json.loads((folder / AGENT_FILE).read_text())
        assert info["url"].startswith("http://127.0.0.1:") and (folder / AGENT_FILE).stat().st_mode & 0o077 == 0
        assert not [n for n in door.session.list_saves() if "agent" in n]  # not a snapshot the operator could Load
        bridge = ConsoleBridge(folder, allow_actions=False)
        assert "robot dog" in bridge.call("summary")
        with pytest.raises(AgentError, match="proposals are off"):
            bridge.call("plan_to_object", {"object": "robot dog"})
        req = urllib.request.Request(info["url"] + "/call", data=b'{"op": "summary"}', method="POST",
                                     headers={"Authorization": "Bearer wrong", "Content-Type": "application/json"})
        with pytest.raises(urllib.error.HTTPError) as err:
            urllib.request.urlopen(req, timeout=30)
        assert err.value.code == 401
    finally:
        api.close()
    assert not (folder / AGENT_FILE).exists()
    with pytest.raises(ConsoleUnavailable, match="no console is running on the session folder"):
        ConsoleBridge(folder, allow_actions=False).call("summary")


class FakeLook:
    def __init__(self) -> None:
        self.running = self.paused = False

    def look_around(self) -> None:
        self.running = True

    def pause(self) -> None:
        self.paused = True


def test_look_around_runs_when_approved_and_hold_pauses_it(door: AgentDoor) -> None:
    door.look = look = FakeLook()
    p = door.call("propose_look_around", {"why": "see what is behind the boxes"}, allow_actions=True)
    assert not look.running and p["title"].startswith("Look around: turn in place through 6 headings")
    assert door.queue.approve(p["id"]).outcome == "look around started: 6 headings, a capture and map at each"
    assert look.running
    assert door.call("wait_proposal", {"proposal_id": p["id"], "timeout": 0})["final"] is False  # still looking
    assert door.call("hold", {"why": "stop"}).startswith("the look around is paused: the robot holds")
    assert look.paused


def test_without_the_mcp_sdk_the_commands_say_how_to_install_it(monkeypatch: pytest.MonkeyPatch) -> None:
    from console.cli.errors import CliError
    from console.cli.mcp_cmd import need_mcp
    from console.cli.morphonavi import main

    monkeypatch.setitem(sys.modules, "mcp.server.mcpserver", None)  # import fails as if not installed
    with pytest.raises(CliError, match=r"morphonavi mcp needs the MCP Python SDK \(mcp 2.x\), which is not installed: "
                                       r"pip install 'mcp>=2.3,<3'"):
        need_mcp("morphonavi mcp")
    assert main(["console", "--mcp-allow-actions"]) == 2  # only with --mcp PORT
