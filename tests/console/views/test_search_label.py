"""The search's next-viewpoint label in the label declutter (console/views/search_view.py,
console/views/object_labels.py): drawn per tab (layer ``search``), not server-wide; left out of a tab's view
where it would sit on the robot's label (the robot's wins), shown where it is clear; gone when the search ends."""

from __future__ import annotations

from pathlib import Path
from types import SimpleNamespace
from typing import Any

import numpy as np
import pytest
import viser

from console.session.search_types import target_height
from console.session.session import Session
from console.views.object_labels import ClientLabels, fixed_labels, label_rect, overlaps, project
from console.views.search_view import SearchView
from tests.console.views.test_object_labels import look

ROBOT = (2.0, 3.0, 0.0)  # the robot arrives at the viewpoint: its label over the viewpoint's eye


class _Handle:
    def __init__(self, text: str) -> None:
        self.text, self.visible = text, False

    def remove(self) -> None:
        self.visible = False


class _Tab:
    """A browser tab as the declutter sees it: its camera and its own label nodes."""

    def __init__(self, camera: Any) -> None:
        self.client_id, self.camera, self.labels = 7401, camera, []
        camera.on_update = lambda _cb: None
        self.scene = SimpleNamespace(add_label=self._add)

    def _add(self, name: str, text: str, **_kw: Any) -> _Handle:
        self.labels.append(_Handle(text))
        return self.labels[-1]

    def shown(self) -> list[str]:
        return [h.text for h in self.labels if h.visible]


class _Job:
    running, paused, waiting_approval, pause_reason, steps, result = True, False, False, "", [], None
    chosen: Any = None


@pytest.fixture()
def console(tmp_path: Path) -> Any:
    server = viser.ViserServer(host="127.0.0.1", port=0, verbose=False)
    robot = server.scene.add_frame("/robot", position=ROBOT, show_axes=False)
    server.scene.add_label("/robot/label", "robot · walking", position=(0.0, 0.0, 0.55), anchor="bottom-center",
                           font_screen_scale=0.8)
    board = ClientLabels(server, lambda: None)
    job = _Job()
    view = SearchView(server, Session(tmp_path / "s", autosave=False), job, target_height)  # type: ignore[arg-type]
    try:
        yield server, board, job, view, robot
    finally:
        view._refresher.close()
        board.close()
        server.stop()


def _viewpoint(eye: tuple[float, float, float]) -> Any:
    return SimpleNamespace(eye=eye, yaw=0.0, gain=3.1, cost=4.2, goal=eye)


def test_the_viewpoint_label_is_per_tab_and_never_over_the_robots(console) -> None:
    server, board, job, view, _robot = console
    text = "next viewpoint: gain 3.1 m³, cost 4.2"
    cam = look((2.0, -1.5, 1.6), (2.0, 3.0, 0.5))  # the robot and the viewpoint ahead, seen from behind
    tab = _Tab(cam)
    board._connect(tab)

    # the robot arrives at a hover viewpoint: the viewpoint's eye (its camera) beside its label
    job.chosen = _viewpoint((ROBOT[0] - 0.2, ROBOT[1], 0.6))
    view.refresh()
    assert [s.text for s in board.spots("search")] == [text]
    assert text not in [f.text for f in fixed_labels(server)]  # not a server-wide node any more
    u, v, _ = project(cam.wxyz, cam.position, cam.fov, cam.image_width, cam.image_height, (*ROBOT[:2], 0.55))
    robot_box = label_rect("robot · walking", u, v)
    spot = board.spots("search")[0]
    su, sv, _ = project(cam.wxyz, cam.position, cam.fov, cam.image_width, cam.image_height, spot.position)
    assert overlaps(label_rect(text, su, sv, anchor="top-left"), robot_box, gap=0.0)  # it would sit on the robot's
    board.refresh(tab.client_id)
    assert text not in tab.shown() and board.shown(tab.client_id, layer="search") == []  # the robot's wins

    # a viewpoint across the room: its label shows, clear of the robot's
    job.chosen = _viewpoint((4.0, 5.0, 1.2))
    view.refresh()
    board.refresh(tab.client_id)
    assert tab.shown().count(text) == 1, tab.shown()
    (_, box), = board.shown(tab.client_id, layer="search")
    assert not overlaps(box, robot_box, gap=0.0)

    # the search ends: the label goes
    job.running = False
    view.refresh()
    board.refresh(tab.client_id)
    assert board.spots("search") == [] and text not in tab.shown()
    assert np.isfinite(cam.fov)


def test_without_a_declutter_the_label_is_one_server_wide_node_replaced_and_removed(tmp_path: Path) -> None:
    """A server with no objects view (no declutter): the label is a server-wide node, one at a time."""
    server = viser.ViserServer(host="127.0.0.1", port=0, verbose=False)
    job = _Job()
    view = SearchView(server, Session(tmp_path / "s", autosave=False), job, target_height)  # type: ignore[arg-type]

    def shown() -> list[tuple[str, tuple[float, ...]]]:
        return [(f.text, tuple(round(float(v), 3) for v in f.position)) for f in fixed_labels(server)
                if f.text.startswith("next viewpoint")]

    try:
        job.chosen = _viewpoint((1.0, 2.0, 0.6))
        view.refresh()
        assert shown() == [("next viewpoint: gain 3.1 m³, cost 4.2", (1.0, 2.0, 0.6))]
        job.chosen = _viewpoint((4.0, 5.0, 1.2))  # the next viewpoint replaces it
        view.refresh()
        assert shown() == [("next viewpoint: gain 3.1 m³, cost 4.2", (4.0, 5.0, 1.2))]
        job.running = False  # the search ends: the label goes
        view.refresh()
        assert shown() == []
    finally:
        view._refresher.close()
        server.stop()
