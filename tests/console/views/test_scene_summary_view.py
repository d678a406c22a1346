"""The console's scene summary panel and "Go to" list (server-side GUI handles, no browser)."""

from __future__ import annotations

import html
import time
from pathlib import Path
from typing import Callable

import pytest
import viser

from console.link.world import DEFAULT_START, paper_room
from console.views.scene_summary_view import EMPTY, PLACEHOLDER, SceneSummaryView, option_label, summary_html
from console.session.session import RobotSnapshot, Session
from pipeline.camera.geometry import Pose
from pipeline.scene import Scene


def _wait(pred: Callable[[], bool], timeout: float = 60.0) -> bool:
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        if pred():
            return True
        time.sleep(0.02)
    return pred()


@pytest.fixture()
def server() -> viser.ViserServer:
    srv = viser.ViserServer(host="127.0.0.1", port=0, verbose=False)
    yield srv
    srv.stop()


@pytest.fixture()
def view(server: viser.ViserServer, tmp_path: Path):
    session = Session(tmp_path / "session", start=(2.5, 0.7, 0.0), autosave=False)
    v = SceneSummaryView(server, session)
    assert _wait(lambda: v.refreshes >= 1)
    yield v, session
    v.close()


def test_empty_map_has_no_objects_to_go_to(view) -> None:
    v, _ = view
    assert "nothing has been mapped yet" in v.text
    assert v._goto.disabled and v._goto.options == (EMPTY,)


def test_summary_follows_map_changes_and_lists_objects(view) -> None:
    v, session = view
    session.set_robot(RobotSnapshot(DEFAULT_START, mode="idle"))
    session.spawn(paper_room(), origin="test")
    assert _wait(lambda: "robot_dog-1" in v.text)
    dog = next(line for line in v.text.splitlines() if line.startswith("- robot dog (robot_dog-1)"))
    assert "behind the line of 33 cardboard boxes" in dog and "reachable only by flying" in dog
    assert option_label("robot_dog", "robot_dog-1") in v._goto.options and v._goto.options[0] == PLACEHOLDER
    assert len(v._goto.options) == 1 + 43
    assert html.escape("robot dog (robot_dog-1)") in v._html.content  # shown in the panel
    session.delete_object("robot_dog-1")
    assert _wait(lambda: "robot_dog-1" not in v.text)
    assert option_label("robot_dog", "robot_dog-1") not in v._goto.options


def test_summary_is_redone_when_the_robot_moves_far_enough(view) -> None:
    v, session = view
    session.spawn(Scene(objects=paper_room().objects[:1]), origin="test")  # desk-1 at (1.2, 2.95)
    session.set_robot(RobotSnapshot(Pose.from_xyz_yaw(1.2, 0.95, 0.0, 1.5708), mode="idle"))
    assert _wait(lambda: "2.0 m ahead" in v.text)
    assert not v.moved_enough(Pose.from_xyz_yaw(1.21, 0.95, 0.0, 1.5708))  # 1 cm: no redo
    assert not v.moved_enough(Pose.from_xyz_yaw(1.2, 0.95, 0.0, 1.5708 + 0.2))  # 11 degrees
    assert v.moved_enough(Pose.from_xyz_yaw(1.2, 0.95, 0.0, 1.5708 + 0.5))  # 29 degrees
    session.set_robot(RobotSnapshot(Pose.from_xyz_yaw(1.2, 4.5, 0.0, 1.5708), mode="idle"))  # now it is behind
    assert _wait(lambda: "behind" in v.text.splitlines()[2])


def test_go_to_robot_dog_plans_take_off_fly_over_and_land(view) -> None:
    v, session = view
    session.spawn(paper_room(), origin="test")
    assert v.go_to("robot_dog-1")
    cand = session.route_snapshot().candidate
    assert cand is not None and cand[:, 2].max() > 1.2  # over the 1.2 m boxes
    session.register()
    mission = session.build_mission()
    assert mission.kinds() == ["walk", "takeoff", "fly", "land", "walk"]
    assert mission.segments[3].spot[1] > 4.2
    assert not v.go_to("no-such-object")


def test_copy_button_copies_the_textarea() -> None:
    out = summary_html("a <b> & c")
    assert "&lt;b&gt; &amp; c</textarea>" in out
    assert "navigator.clipboard.writeText(t.value)" in html.unescape(out)


def test_the_console_shows_the_panel_and_refreshes_it_after_a_map_change(tmp_path: Path) -> None:
    from console.app import ConsoleApp, ConsoleConfig

    app = ConsoleApp(ConsoleConfig(robot="sim", session_dir=tmp_path / "s", scene_dir=tmp_path / "scenes", port=0,
                                   fresh=True)).start()
    try:
        view = app.views["summary"]
        assert isinstance(view, SceneSummaryView)
        assert _wait(lambda: "nothing has been mapped yet" in view.text)
        app.session.spawn(paper_room(), origin="test")
        assert _wait(lambda: "hidden behind the line of 33 cardboard boxes" in view.text)
        assert view.go_to("robot dog")  # by label, as an operator would say it
        assert app.session.route_snapshot().candidate is not None
    finally:
        app.stop()
    assert _wait(lambda: not view._worker.is_alive(), 10.0)
