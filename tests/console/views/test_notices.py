"""Notices that expire or are replaced by newer news about the same thing (console/views/client_notice.py),
and a robot panel that shows current news, not old errors (console/views/robot_messages.py, robot_view.py)."""

from __future__ import annotations

from typing import Any

import pytest

from console.views import client_notice
from console.views.client_notice import MAX_SHOWN, reconnect_script, subject, tell
from console.views.robot_messages import MessageShelf


class _Handle:
    def __init__(self, client: "_Client", title: str, body: str, color: str, seconds: Any) -> None:
        self.client, self.title, self.body, self.color, self.seconds = client, title, body, color, seconds

    def remove(self) -> None:
        self.client.open.remove(self)


class _Client:
    """A tab: what notifications it has open."""

    def __init__(self, client_id: int) -> None:
        self.client_id = client_id
        self.open: list[_Handle] = []

    def add_notification(self, title: str, body: str, *, color: str, auto_close_seconds: Any) -> _Handle:
        h = _Handle(self, title, body, color, auto_close_seconds)
        self.open.append(h)
        return h


def test_newer_news_about_the_same_thing_replaces_the_notice() -> None:
    tab = _Client(9001)
    try:
        tell(tab, "Mission", "walk refused: the goal is off the floor", "red")
        assert [(h.title, h.seconds) for h in tab.open] == [("Mission", client_notice.ERROR_SECONDS)]  # expires too
        tell(tab, "Capture & map failed", "the camera gave no usable photo", "red")
        tell(tab, "Mission done", "the route now starts where the robot stands", "green")
        assert [h.title for h in tab.open] == ["Capture & map failed", "Mission done"]  # the error is replaced
        tell(tab, "Mapped", "3 objects seen", "green")
        assert [h.title for h in tab.open] == ["Mission done", "Mapped"]  # the failed capture is old news
        for k in range(2 * MAX_SHOWN):  # unrelated notices never stack beyond MAX_SHOWN
            tell(tab, f"Note {k}", "x", "blue")
        assert len(tab.open) == MAX_SHOWN and tab.open[-1].title == f"Note {2 * MAX_SHOWN - 1}"
        other = _Client(9002)
        tell(other, "Mission", "paused", "yellow")
        assert len(tab.open) == MAX_SHOWN and len(other.open) == 1  # per tab
        client_notice.forget(9002)
    finally:
        client_notice.forget(9001)


def test_subjects() -> None:
    assert subject("Cannot resume") == subject("Mission done") == subject("Battery critical") == "mission"
    assert subject("Capture held back") == subject("Mapped") == "capture"
    assert subject("Robot link") == subject("Robot says") == "robot"
    assert subject("Saved") == "Saved"


def test_a_background_tab_retries_as_a_focused_one() -> None:
    js = reconnect_script()
    assert "document.hasFocus = function () { return true; }" in js and "dispatchEvent(new Event('focus'))" in js


def test_the_robot_panel_drops_old_errors_after_a_success_and_with_time() -> None:
    now = [100.0]
    shelf = MessageShelf(keep=60.0, clock=lambda: now[0])
    msgs = ((1, "ERROR: walk refused: blocked"), (2, "WARNING: battery 30 %"))
    assert shelf.current(msgs) == msgs
    shelf.clear()  # a later mission is done
    assert shelf.current(msgs) == ()
    msgs = (*msgs, (3, "ERROR: fly refused: geofence"))
    now[0] = 130.0
    assert shelf.current(msgs) == ((3, "ERROR: fly refused: geofence"),)  # newer news still shows
    now[0] = 191.0
    assert shelf.current(msgs) == ()  # a minute later it is old news too
    assert shelf.current(((1, "INFO: link back"),)) == ((1, "INFO: link back"),)  # the link counts again
    with pytest.raises(ValueError, match="keep"):
        MessageShelf(keep=0.0)


def test_the_status_line_shows_only_the_current_messages() -> None:
    import time

    from console.session.session import RobotSnapshot
    from console.views.robot_view import status_text
    from pipeline.camera.geometry import Pose

    r = RobotSnapshot(pose=Pose.from_xyz_yaw(1.0, 1.0, 0.0, yaw=0.0), mode="idle", armed=False, battery=0.9,
                      healthy=True, detail="", stamp=time.time(), messages=((1, "ERROR: walk refused: blocked"),))
    assert "walk refused" in status_text(r, "sim")
    assert "walk refused" not in status_text(r, "sim", ())
