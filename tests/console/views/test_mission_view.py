"""The mission panel's controls follow the reported run state (no browser: the server-side GUI handles)."""

from __future__ import annotations

from pathlib import Path

import pytest
import viser

from console.views.mission_view import MissionView, segment_table
from console.session.session import RobotSnapshot, RunStatus, Session
from pipeline.camera.geometry import Pose


class _Runner:
    def execute(self, mission: object) -> None: ...

    def pause(self) -> None: ...

    def resume(self) -> None: ...

    def abort(self) -> None: ...


@pytest.fixture()
def server() -> viser.ViserServer:
    srv = viser.ViserServer(host="127.0.0.1", port=0, verbose=False)
    yield srv
    srv.stop()


def _shown(view: MissionView) -> dict[str, bool]:
    """Which buttons an operator can press now (visible and enabled)."""
    handles = {"execute": view._execute, "pause": view._pause, "resume": view._resume, "abort": view._abort}
    return {name: h.visible and not h.disabled for name, h in handles.items()}


def test_buttons_follow_the_run_state(server: viser.ViserServer, tmp_path: Path) -> None:
    session = Session(tmp_path / "session", start=(2.5, 0.7, 0.0), autosave=False)
    view = MissionView(server, session, _Runner())
    assert _shown(view) == {"execute": False, "pause": False, "resume": False, "abort": False}  # no mission yet
    session.set_robot(RobotSnapshot(Pose.from_xyz_yaw(2.5, 0.7, 0.0), mode="idle"))  # Execute needs the robot

    session.add_goal((2.5, 2.0, 0.0))
    session.register()
    mission = session.build_mission()
    assert _shown(view) == {"execute": True, "pause": False, "resume": False, "abort": False}

    session.set_run(RunStatus("running", 0, 0.3, "walking"))
    assert _shown(view) == {"execute": False, "pause": True, "resume": False, "abort": True}
    assert view._progress.visible and view._progress.value == pytest.approx(30.0)
    assert "▶ **1**" in view._table.content  # the running segment is marked

    session.set_run(RunStatus("paused", 0, 0.3, "paused"))
    assert _shown(view) == {"execute": False, "pause": False, "resume": True, "abort": True}
    session.set_run(RunStatus("failsafe", 0, 0.3, "link lost: holding"))
    assert _shown(view) == {"execute": False, "pause": False, "resume": True, "abort": True}
    assert view._progress.color == "red"

    session.set_run(RunStatus("aborted", 0, 0.3, "aborted by the operator"))
    assert _shown(view)["execute"] and not _shown(view)["abort"]
    assert "aborted by the operator" in view._status.content
    assert segment_table(mission) == view._table.content  # nothing marked once it stopped


def test_without_a_mission_manager_nothing_can_run(server: viser.ViserServer, tmp_path: Path) -> None:
    session = Session(tmp_path / "session", start=(2.5, 0.7, 0.0), autosave=False)
    view = MissionView(server, session, None)
    session.add_goal((2.5, 2.0, 0.0))
    session.register()
    session.build_mission()
    assert not any(_shown(view).values())
