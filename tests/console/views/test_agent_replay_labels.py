"""The agent's label ("proposed by the agent", console/views/approval_view.py) and the replay's viewpoint label
(console/recording/replay_search.py) in the per-tab label declutter (console/views/object_labels.py): drawn per
tab (layers ``agent`` and ``search``), not server-wide; left out of a tab's view where it would sit on the robot's
label (the robot's wins) and shown in another tab where it is clear; gone when there is nothing to label; on a
server without a declutter they stay server-wide labels, as before."""

from __future__ import annotations

from types import SimpleNamespace
from typing import Any

import pytest
import viser

from console.recording.replay_search import LABEL_NODE as REPLAY_NODE
from console.recording.replay_search import SearchReplayView
from console.views.approval_view import AGENT_LABEL, ApprovalView
from console.views.object_labels import ClientLabels, fixed_labels, label_rect, overlaps, project
from tests.console.views.test_object_labels import look

ROBOT = (2.0, 3.0, 0.0)  # the robot's frame; its label's anchor (bottom centre) 0.55 m above it
ROBOT_TEXT = "robot · walking"
BEHIND = look((2.0, -1.5, 1.6), (2.0, 3.0, 0.5))  # the robot and what is just past it on one line of sight
LEVEL = look((2.0, 0.5, 0.5), (2.0, 3.3, 0.6))  # at the labels' height, behind the robot
SIDE = look((3.2, 3.15, 0.9), (2.0, 3.15, 0.6))  # from the side, near: the robot and what is 0.3 m past it apart


class _Handle:
    def __init__(self, text: str) -> None:
        self.text, self.visible = text, False

    def remove(self) -> None:
        self.visible = False


class _Tab:
    """A browser tab as the declutter sees it: its camera and its own label nodes."""

    def __init__(self, client_id: int, camera: Any) -> None:
        self.client_id, self.camera, self.labels = client_id, camera, []
        camera.on_update = lambda _cb: None
        self.scene = SimpleNamespace(add_label=self._add)

    def _add(self, name: str, text: str, **_kw: Any) -> _Handle:
        self.labels.append(_Handle(text))
        return self.labels[-1]

    def shown(self) -> list[str]:
        return [h.text for h in self.labels if h.visible]


def _box(cam: Any, text: str, where: tuple[float, float, float], anchor: str) -> Any:
    u, v, _ = project(cam.wxyz, cam.position, cam.fov, cam.image_width, cam.image_height, where)
    return label_rect(text, u, v, anchor=anchor)


def _robot_box(cam: Any) -> Any:
    return _box(cam, ROBOT_TEXT, (*ROBOT[:2], 0.55), "bottom-center")


@pytest.fixture()
def server() -> Any:
    server = viser.ViserServer(host="127.0.0.1", port=0, verbose=False)
    server.scene.add_frame("/robot", position=ROBOT, show_axes=False)
    server.scene.add_label("/robot/label", ROBOT_TEXT, position=(0.0, 0.0, 0.55), anchor="bottom-center",
                           font_screen_scale=0.8)
    try:
        yield server
    finally:
        server.stop()


class _Queue:
    def pending(self) -> list[Any]:
        return []

    def decided(self) -> list[Any]:
        return []

    def subscribe(self, _cb: Any) -> Any:
        return lambda: None


def _agent(server: Any, goal: list[Any]) -> tuple[ApprovalView, Any]:
    """The Agent panel on ``server`` with the agent's goal and the candidate's goal both ``goal[0]``."""
    door = SimpleNamespace(queue=_Queue(), agent_goal=None)
    session = SimpleNamespace(workspace=SimpleNamespace(resolution=0.25), subscribe=lambda _cb: (lambda: None),
                              route_snapshot=lambda: SimpleNamespace(candidate_goal=goal[0], goals=[]))

    def plan(g: Any) -> None:
        goal[0] = door.agent_goal = g

    return ApprovalView(server, session, door), plan  # type: ignore[arg-type]


def test_the_agents_label_is_placed_per_tab_and_never_over_the_robots(server: Any) -> None:
    board = ClientLabels(server, lambda: None)
    goal: list[Any] = [None]
    view, plan = _agent(server, goal)
    behind, side = _Tab(9101, LEVEL), _Tab(9102, SIDE)
    board._connect(behind)
    board._connect(side)
    try:
        plan((2.0, 3.3, 0.0))  # a goal 0.3 m past the robot: its label's anchor 0.6 m above it
        view.refresh()
        assert view.labelled and [s.text for s in board.spots("agent")] == [AGENT_LABEL]
        assert AGENT_LABEL not in [f.text for f in fixed_labels(server)]  # not a server-wide node any more
        spot = board.spots("agent")[0]
        assert spot.position == pytest.approx((2.0, 3.3, 0.6))
        for tab in (behind, side):
            board.refresh(tab.client_id)

        # from behind the robot, the agent's label would sit on the robot's: that tab leaves it out
        assert overlaps(_box(LEVEL, AGENT_LABEL, spot.position, "bottom-center"), _robot_box(LEVEL), gap=0.0)
        assert AGENT_LABEL not in behind.shown() and board.shown(behind.client_id, layer="agent") == []
        # from the side it is clear of it: that tab shows it, in its own place
        (text, box), = board.shown(side.client_id, layer="agent")
        assert text == AGENT_LABEL and side.shown().count(AGENT_LABEL) == 1
        assert not overlaps(box, _robot_box(SIDE), gap=0.0)

        # the candidate goes (discarded, or another goal): the label goes in every tab
        plan(None)
        view.refresh()
        for tab in (behind, side):
            board.refresh(tab.client_id)
        assert not view.labelled and board.spots("agent") == []
        assert AGENT_LABEL not in behind.shown() + side.shown()
    finally:
        view.close()
        board.close()


def _state(*eyes: tuple[float, float, float]) -> Any:
    steps = [{"kind": "viewpoint", "search_id": "s1", "index": n, "text": f"viewpoint {n + 1}",
              "viewpoint": {"eye": list(e), "yaw": 0.0, "gain": 3.1, "cost": 4.2}} for n, e in enumerate(eyes)]
    return SimpleNamespace(search=steps, search_result=None)


def test_the_replays_viewpoint_label_is_placed_per_tab_and_never_over_the_robots(server: Any) -> None:
    board = ClientLabels(server, lambda: None)
    view = SearchReplayView(server, SimpleNamespace(content=""))
    tab = _Tab(9201, BEHIND)
    board._connect(tab)
    try:
        # the replay shows the robot arriving at a hover viewpoint: the viewpoint's eye beside its label
        view.show(_state((ROBOT[0] - 0.2, ROBOT[1], 0.6)))
        text = "viewpoint 1: gain 3.1 m³, cost 4.2"
        assert [s.text for s in board.spots("search")] == [text] == [s.text for s in view.label_spots()]
        assert text not in [f.text for f in fixed_labels(server)]
        spot = board.spots("search")[0]
        assert overlaps(_box(BEHIND, text, spot.position, "top-left"), _robot_box(BEHIND), gap=0.0)
        board.refresh(tab.client_id)
        assert text not in tab.shown() and board.shown(tab.client_id, layer="search") == []  # the robot's wins

        # later in the replay: the next viewpoint across the room, shown, clear of the robot's label
        view.show(_state((ROBOT[0] - 0.2, ROBOT[1], 0.6), (4.0, 5.0, 1.2)))
        board.refresh(tab.client_id)
        text2 = "viewpoint 2: gain 3.1 m³, cost 4.2"
        assert tab.shown().count(text2) == 1 and text not in tab.shown(), tab.shown()
        (_, box), = board.shown(tab.client_id, layer="search")
        assert not overlaps(box, _robot_box(BEHIND), gap=0.0)

        # seeking back before the first viewpoint: no label
        view.show(_state())
        board.refresh(tab.client_id)
        assert board.spots("search") == [] and not any(t.startswith("viewpoint") for t in tab.shown())
    finally:
        board.close()


def test_without_a_declutter_both_labels_stay_server_wide(server: Any) -> None:
    goal: list[Any] = [None]
    agent, plan = _agent(server, goal)
    replay = SearchReplayView(server, SimpleNamespace(content=""))
    try:
        plan((2.0, 4.0, 0.0))
        agent.refresh()
        replay.show(_state((4.0, 5.0, 1.2)))
        texts = {f.text: f for f in fixed_labels(server)}
        assert texts[AGENT_LABEL].position == pytest.approx((2.0, 4.0, 0.6))
        assert texts["viewpoint 1: gain 3.1 m³, cost 4.2"].anchor == "top-left"
        assert REPLAY_NODE in server.scene._handle_from_node_name
        plan(None)
        agent.refresh()
        replay.show(_state())
        assert {f.text for f in fixed_labels(server)} == {ROBOT_TEXT}
    finally:
        agent.close()
