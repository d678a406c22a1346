"""Map-folder buttons: each says what it does on hover, and is off with the reason when it would be refused.

Rules (:mod:`console.session.look_rules`): Look at goal / Go look are off while the Goal x / y fields are at
the robot (no goal typed or clicked yet) or not numbers; Capture & map while a look runs or a capture is
being mapped; Look around while a mission, a look or a capture is under way or the robot is not known;
Undo / Redo when there is nothing to undo / redo. The views (a real viser server, no browser) draw them:
the buttons' ``disabled`` and hover text follow the rules and the typed goal. The mission panel after a
finished mission says so instead of "No mission yet".
"""

from __future__ import annotations

import time
from pathlib import Path
from typing import Any, Callable

import pytest
import viser

from console.session import look_rules
from console.session.look_rules import NO_GOAL, Busy
from console.session.session import Session, SessionError
from console.session.session_types import RobotSnapshot
from pipeline.camera.geometry import Pose

AT = (2.5, 0.7)
ROBOT = RobotSnapshot(pose=Pose.from_xyz_yaw(AT[0], AT[1], 0.0, 0.0), mode="idle")
CELL = 0.1


def _wait(cond: Callable[[], bool], what: str, deadline: float = 30.0) -> None:
    end = time.monotonic() + deadline
    while not cond():
        if time.monotonic() > end:
            raise AssertionError(f"timed out waiting for {what}")
        time.sleep(0.02)


# --- the rules ---------------------------------------------------------------------------------------
def test_look_at_goal_is_off_while_the_goal_is_at_the_robot() -> None:
    state = look_rules.look_at_goal(Busy(), ROBOT, ("2.50", "0.70", "0.00"), CELL)
    assert not state.enabled and state.reason.startswith(NO_GOAL), state
    near = look_rules.look_at_goal(Busy(), ROBOT, ("2.55", "0.72"), CELL)  # within one cell: still no heading worth it
    assert not near.enabled and near.reason.startswith(NO_GOAL)
    assert look_rules.look_at_goal(Busy(), ROBOT, ("2.50", "5.00"), CELL).enabled


def test_look_at_goal_is_off_while_the_goal_is_not_numbers_and_names_the_fields() -> None:
    state = look_rules.look_at_goal(Busy(), ROBOT, ("abc", "0.7"), CELL)
    assert not state.enabled and "Goal x / y must be numbers" in state.reason and "'abc'" in state.reason
    assert look_rules.goal_blocker((), ROBOT, CELL) == NO_GOAL  # the fields not made yet


def test_look_around_is_off_while_anything_moves_the_robot_or_it_is_not_known() -> None:
    assert look_rules.look_around(Busy(), ROBOT).enabled
    assert "mission is under way" in look_rules.look_around(Busy(mission=True), ROBOT).reason
    assert "look is already running" in look_rules.look_around(Busy(go_look=True), ROBOT).reason
    assert "capture is being mapped" in look_rules.look_around(Busy(mapping=True), ROBOT).reason
    assert "no state from the robot" in look_rules.look_around(Busy(), None).reason
    lost = RobotSnapshot(pose=ROBOT.pose, mode="idle", healthy=False)
    assert not look_rules.look_around(Busy(), lost).enabled
    # the busy reason comes before the goal's
    assert "mission" in look_rules.look_at_goal(Busy(mission=True), ROBOT, ("2.5", "0.7"), CELL).reason


def test_capture_is_off_while_a_look_runs_or_a_capture_is_mapped() -> None:
    assert look_rules.capture(Busy()).enabled
    assert look_rules.capture(Busy(mission=True)).enabled  # a capture while walking is fine
    assert look_rules.capture(Busy(look=True)).reason == "a look is running: pause or stop it first"
    assert look_rules.capture(Busy(mapping=True)).reason == "a capture is already being mapped"


def test_hover_says_what_it_does_and_why_it_is_off() -> None:
    on = look_rules.hover("around", look_rules.look_around(Busy(), ROBOT), 6)
    assert on.startswith("Turn in place through 6 headings") and "is off" not in on
    off = look_rules.hover("look_at", look_rules.look_at_goal(Busy(), ROBOT, ("2.50", "0.70"), CELL))
    assert off.startswith("Turn to face the point") and f"· Look at goal is off: {NO_GOAL}" in off
    assert look_rules.hover("undo", look_rules.history(None, "undo")).endswith("Undo is off: nothing to undo")
    assert look_rules.hover("redo", look_rules.history(None, "redo")).endswith("Redo is off: nothing to redo")
    for name in look_rules.DOES:
        assert look_rules.hover(name, look_rules.CommandState(True, True, "")), name


def test_the_mission_panel_after_a_finished_mission_does_not_say_yet() -> None:
    from console.views.mission_view import no_mission_text

    assert "No mission yet" in no_mission_text(0)
    done = no_mission_text(0, run_state="done")
    assert "Mission done" in done and "yet" not in done and "register a path" in done
    assert "Mission aborted" in no_mission_text(0, run_state="aborted")


# --- the views draw them -----------------------------------------------------------------------------
class _Job:
    """A look / Go look / mapping job stand-in: only whether it runs."""

    def __init__(self) -> None:
        self.running = False
        self.paused = False
        self.started: list[Any] = []
        self.outcome = type("O", (), {"message": ""})()

    def look_at(self, point: Any) -> None:
        self.started.append(point)

    def start(self, point: Any) -> None:
        self.started.append(point)


@pytest.fixture()
def panel(tmp_path: Path):
    from console.views.look_view import LookView

    s = Session(tmp_path / "s", start=(AT[0], AT[1], 0.0), autosave=False)
    s.set_robot(ROBOT)
    server = viser.ViserServer(host="127.0.0.1", port=0, verbose=False)
    try:
        fields = [server.gui.add_text(f"Goal {n} [m]", v) for n, v in zip("xyz", ("2.50", "0.70", "0.00"))]
        cap = server.gui.add_button("Capture & map")
        look, go, mapping = _Job(), _Job(), _Job()
        view = LookView(server, s, look, lambda: (fields[0].value, fields[1].value), go_look=go,  # type: ignore[arg-type]
                        capture=cap, mapping=mapping)
        view.follow_goal(fields)
        yield type("P", (), dict(view=view, fields=fields, cap=cap, look=look, go=go, mapping=mapping, session=s))
    finally:
        server.stop()


def test_look_buttons_are_off_at_the_robot_and_on_once_a_goal_is_typed(panel: Any) -> None:
    v = panel.view
    assert v.look_at.disabled and v.go_look.disabled
    assert f"Look at goal is off: {NO_GOAL}" in v.look_at.hint and f"Go look is off: {NO_GOAL}" in v.go_look.hint
    assert not v.around.disabled and v.around.hint.startswith("Turn in place")
    assert not panel.cap.disabled and panel.cap.hint.startswith("Ask the robot for a photo")
    assert 'data-mn-hint="Turn to face the point' in v._hints.content  # the page script's copy for the title
    panel.fields[1].value = "5.00"  # a goal clicked or typed behind the boxes
    _wait(lambda: not v.look_at.disabled and not v.go_look.disabled, "Look at goal / Go look on")
    assert v.look_at.hint == look_rules.DOES["look_at"]
    panel.fields[1].value = "0.70"
    _wait(lambda: v.look_at.disabled, "Look at goal off again at the robot")


def test_a_click_on_look_at_goal_at_the_robot_is_refused_with_the_hover_words(panel: Any) -> None:
    with pytest.raises(SessionError, match="no goal yet: type or click a goal"):
        panel.view._look_at_goal()
    with pytest.raises(SessionError, match="no goal yet: type or click a goal"):
        panel.view._go_look()
    assert panel.look.started == [] and panel.go.started == []


def test_capture_is_off_with_the_reason_while_a_capture_is_mapped(panel: Any) -> None:
    from console.session.session import JobStatus

    panel.mapping.running = True
    panel.session.set_job(JobStatus("Capture & map", True, 0.1, "detecting"))
    _wait(lambda: panel.cap.disabled, "Capture & map off")
    assert "Capture & map is off: a capture is already being mapped" in panel.cap.hint
    assert "Look around is off: a capture is being mapped" in panel.view.around.hint
    panel.mapping.running = False
    panel.session.set_job(JobStatus("Capture & map", False, 1.0, "done"))
    _wait(lambda: not panel.cap.disabled, "Capture & map on again")


def test_undo_and_redo_say_what_they_do_and_nothing_to_undo(tmp_path: Path) -> None:
    from console.views.redo_view import RedoView
    from pipeline.scene import Scene, SceneObject

    s = Session(tmp_path / "s", autosave=False)
    server = viser.ViserServer(host="127.0.0.1", port=0, verbose=False)
    try:
        undo = server.gui.add_button("Undo", disabled=True)
        view = RedoView(server, s, undo)
        assert undo.disabled and undo.hint.endswith("Undo is off: nothing to undo")
        assert view.button.disabled and view.button.hint.endswith("Redo is off: nothing to redo")
        s.spawn(Scene(objects=(SceneObject("crate", "cardboard_box", (3.3, 1.8, 0.3), (0.5, 0.6, 0.5)),)),
                origin="the operator's map")
        _wait(lambda: not undo.disabled, "Undo on")
        assert undo.hint.startswith("Undo the last map edit") and "is off" not in undo.hint
        assert 'data-mn-hint="Undo the last map edit' in view._hints.content
    finally:
        server.stop()
