"""The console's controls say what they do: typed goals are refused by field, edit buttons are off
with nothing to act on, the run line belongs to its mission, plain words for segment kinds, and a
replay is read-only (server-side GUI handles of a real viser server; no browser)."""

from __future__ import annotations

from pathlib import Path

import pytest
import viser

from console.views.capture_view import CaptureView
from console.link.manager import MissionManager, MissionStatus
from console.link.sim import SimConfig, SimRobot
from console.views.mission_view import MissionView
from console.views.paths_view import PathsView
from console.session.session import RobotSnapshot, RunStatus, Session
from pipeline.camera.geometry import Pose
from planner.mission import Mission, MissionSegment, SegmentKind


class _Client:
    """Stands in for a browser tab: records the notices it is shown."""

    def __init__(self) -> None:
        self.notices: list[tuple[str, str]] = []

    def add_notification(self, title: str, body: str, **_kw: object) -> None:
        self.notices.append((title, body))


@pytest.fixture()
def server() -> viser.ViserServer:
    srv = viser.ViserServer(host="127.0.0.1", port=0, verbose=False)
    yield srv
    srv.stop()


@pytest.fixture()
def session(tmp_path: Path) -> Session:
    return Session(tmp_path / "session", start=(2.5, 0.7, 0.0), autosave=False)


def _edits(paths: PathsView, mission: MissionView) -> dict[str, bool]:
    """Which route edit buttons an operator can press now."""
    out = {name.lower(): not h.disabled for name, h in paths._edit.items()}
    out["build"] = not mission._build.disabled
    return out


@pytest.mark.parametrize("typed, field", [(("nan", "2.0", "0"), "goal.x"), (("2.5", "abc", "0"), "goal.y"),
                                          (("2.5", "2.0", ""), "goal.z")])
def test_a_bad_typed_field_is_refused_by_name_and_adds_nothing(server: viser.ViserServer, session: Session,
                                                                typed: tuple[str, str, str], field: str) -> None:
    paths = PathsView(server, session)
    for handle, text in zip(paths._typed, typed):
        handle.value = text  # what the operator typed, as the browser sends it
    assert paths.typed_values() == typed
    client = _Client()
    assert paths.goal_from_values(client, paths.typed_values()) is False
    assert session.route_snapshot().candidate is None  # the previous value was not used
    assert len(client.notices) == 1 and client.notices[0][1].startswith(f"{field}: must be a")
    for handle, text in zip(paths._typed, ("2.5", "2.0", "0")):
        handle.value = text
    assert paths.goal_from_values(client, paths.typed_values()) is True
    assert session.route_snapshot().candidate_goal == pytest.approx((2.5, 2.0, 0.0))


def test_edit_buttons_are_off_with_nothing_to_act_on(server: viser.ViserServer, session: Session) -> None:
    paths, mission = PathsView(server, session), MissionView(server, session, None)
    nothing = {"register": False, "discard": False, "undo": False, "clear": False, "build": False}
    assert _edits(paths, mission) == nothing
    assert session.add_goal((2.5, 2.0, 0.0)).ok
    assert _edits(paths, mission) == {**nothing, "register": True, "discard": True, "clear": True}
    session.register()
    assert _edits(paths, mission) == {**nothing, "undo": True, "clear": True, "build": True}
    session.add_goal((1.5, 3.0, 0.0))
    assert all(_edits(paths, mission).values())
    session.discard()
    session.undo()
    assert _edits(paths, mission) == nothing


def test_a_new_build_hides_the_previous_runs_line(server: viser.ViserServer, session: Session) -> None:
    view = MissionView(server, session, None)
    session.add_goal((2.5, 2.0, 0.0))
    session.register()
    session.build_mission()
    session.set_run(RunStatus("running", 0, 0.4, "walking"))
    session.set_run(RunStatus("done", None, 1.0, "mission m1 done"))
    assert "mission m1 done" in view._status.content and view._progress.visible  # its own mission: shown
    session.build_mission()  # a new mission: the old run is not its run
    assert view._status.content == "" and not view._progress.visible
    session.set_run(RunStatus("running", 0, 0.1, "walking"))  # its own run shows again
    assert "walking" in view._status.content and view._progress.visible


def test_progress_says_take_off_in_plain_words() -> None:
    robot = SimRobot(config=SimConfig(time_scale=10.0, walk_speed=1.0, fly_speed=1.5, climb_rate=1.0,
                                      descent_rate=1.0, spool_time=0.3, settle_time=0.2))
    robot.connect()
    try:
        mission = Mission((MissionSegment(SegmentKind.WALK, ((2.5, 0.7, 0.0), (2.5, 1.5, 0.0))),
                           MissionSegment(SegmentKind.TAKEOFF, ((2.5, 1.5, 0.0), (2.5, 1.5, 1.0))),
                           MissionSegment(SegmentKind.LAND, ((2.5, 1.5, 1.0), (2.5, 1.5, 0.0)))))
        manager = MissionManager(robot)
        events: list = []
        manager.subscribe(events.append)
        manager.start(mission)
        assert manager.wait(60.0) is MissionStatus.DONE, [e.message for e in events]
        messages = [e.message for e in events]
        assert "segment 2/3: take-off" in messages, messages
        assert not any("takeoff" in m for m in messages), messages
    finally:
        robot.close()


def test_replay_views_are_read_only(server: viser.ViserServer, session: Session) -> None:
    paths = PathsView(server, session, read_only=True)
    mission = MissionView(server, session, None, read_only=True)
    capture = CaptureView(server, session, read_only=True)
    session.add_goal((2.5, 2.0, 0.0))  # the replayed route
    session.register()
    session.add_goal((1.5, 3.0, 0.0))
    assert not any(_edits(paths, mission).values())
    assert "press" not in capture._caption.content and "at this time" in capture._caption.content
    session.set_robot(RobotSnapshot(Pose.from_xyz_yaw(2.5, 0.7, 0.0), mode="idle"))
    assert not mission._replan.visible and not mission._landing.visible


def test_the_replay_console_is_read_only(tmp_path: Path) -> None:
    from console.cli.replay_cmd import open_replay
    from tests.console.recording.test_recording import run_short_mission

    path, _snaps, _live = run_short_mission(tmp_path)
    app = open_replay(path, port=0)
    try:
        paths, mission, capture = app.views["paths"], app.views["mission"], app.views["capture"]
        for t in (0.0, app.recording.duration / 2, app.recording.duration):
            app.seek(t)
            assert not any(_edits(paths, mission).values()), t
        app.seek(0.0)
        if app.session.capture is None:  # no capture at the start of the recording
            assert "press" not in capture._caption.content and "at this time" in capture._caption.content
    finally:
        app.stop()
