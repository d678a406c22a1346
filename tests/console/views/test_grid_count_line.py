"""The grid's count line after a first capture: the grid's few free cells (where the robot fits) are
said as such, beside the cells the capture saw free, so a capture that saw a quarter of the room never
reads as "0 free"."""

from __future__ import annotations

import re
from pathlib import Path

import pytest
import viser

from console.link.sim import SimConfig, SimRobot
from console.session.mapping_job import GROUND_TRUTH_LABEL, MapperPerceiver, MappingJob, ground_truth_bundle_for
from console.session.session import Session
from console.views.grid_view import GridView, seen_free_cells
from pipeline.mapping.known_space import KnownState
from planner.grid import CellState


@pytest.fixture()
def server() -> viser.ViserServer:
    srv = viser.ViserServer(host="127.0.0.1", port=0, verbose=False)
    yield srv
    srv.stop()


def test_the_count_line_says_free_for_the_robot_and_seen_free(server: viser.ViserServer, tmp_path: Path) -> None:
    session = Session(tmp_path / "s", autosave=False)
    view = GridView(server, session)
    view.redraw()
    assert "seen free" not in view._counts.content  # no capture yet: no known space to count
    robot = SimRobot(config=SimConfig(time_scale=4.0))
    robot.connect()
    try:
        assert MappingJob(session, robot.capture, MapperPerceiver(GROUND_TRUTH_LABEL, ground_truth_bundle_for)).run()
    finally:
        robot.close()
    view.redraw()
    words = re.sub(r"<[^>]+>", "", view._counts.content)
    seen = int((session.known_space.state() == KnownState.FREE).sum())
    grid_free = int((session.grid.state == CellState.FREE).sum())
    assert seen > 10 * max(grid_free, 1) and seen_free_cells(session) == seen  # the first capture's case
    assert f"{grid_free} free for the robot ({seen} seen free) · " in words, words
    assert "free not drawn" in words or "free and unknown not drawn" in words  # Free cells is off by default
