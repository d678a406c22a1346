"""The grid layers without a browser: after a capture with known space the red "occupied" layer
draws the obstacle cells only, not the cells closed because they are unknown or within the robot's
clearance; those go to the (off by default) "unknown" layer and the yellow "dangerous" layer (the
band around obstacles; the band around unseen space goes with the unknown layer). Free cells are off
by default and one toggle shows them."""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np
import pytest
import viser

from console.link.sim import SimConfig, SimRobot
from console.session.mapping_job import GROUND_TRUTH_LABEL, MapperPerceiver, MappingJob, ground_truth_bundle_for
from console.session.session import Session
from console.views.grid_view import GridView, near_obstacles
from planner.grid import CellState, Closed


@pytest.fixture()
def server() -> viser.ViserServer:
    srv = viser.ViserServer(host="127.0.0.1", port=0, verbose=False)
    yield srv
    srv.stop()


@pytest.fixture()
def captured(tmp_path: Path) -> Session:
    robot = SimRobot(config=SimConfig(time_scale=4.0))
    robot.connect()
    session = Session(tmp_path / "s")
    job = MappingJob(session, robot.capture, MapperPerceiver(GROUND_TRUTH_LABEL, ground_truth_bundle_for))
    try:
        assert job.run()
        yield session
    finally:
        robot.close()


def _wait_for(view: GridView, expected: dict[str, int], deadline_s: float = 30.0) -> dict[str, int]:
    end = time.monotonic() + deadline_s
    drawn = view.drawn_counts()
    while time.monotonic() < end:
        drawn = view.drawn_counts()
        if all(drawn.get(k, 0) == v for k, v in expected.items()):
            break
        time.sleep(0.05)
    return drawn


def test_red_means_obstacles_not_unknown_space(server: viser.ViserServer, captured: Session) -> None:
    grid = captured.grid
    assert captured.known_space is not None and grid.reason is not None
    reason = grid.reason
    unknown = int(np.count_nonzero(reason == Closed.UNKNOWN))
    obstacles = int(np.count_nonzero(np.isin(reason, [Closed.OBJECT, Closed.SURFACE, Closed.BENEATH])))
    clearance = int(np.count_nonzero(reason == Closed.CLEARANCE))
    dangerous = int(np.count_nonzero(grid.state == CellState.DANGEROUS))
    occupied = int(np.count_nonzero(grid.state == CellState.OCCUPIED))
    edge = int(np.count_nonzero(reason == Closed.EDGE))  # the robot's size along the workspace's edge: yellow too
    assert edge > 0
    assert unknown > obstacles > 0 and clearance > 0  # the capture left most of the room unseen
    assert occupied > obstacles + clearance

    # yellow is the band around obstacles; the band that only unseen space makes goes with the grey layer
    near = near_obstacles(grid)
    banded = (grid.state == CellState.DANGEROUS) | (reason == Closed.CLEARANCE)
    around_unseen = int(np.count_nonzero(banded & ~near))
    assert around_unseen > 0 and int(np.count_nonzero(banded & near)) > 0
    assert around_unseen + int(np.count_nonzero(banded & near)) == dangerous + clearance

    view = GridView(server, captured)  # the height slider starts at the top: every cell is drawn
    assert view.visible_layers() == {"occupied": True, "dangerous": True, "free": False, "unknown": False}
    drawn = _wait_for(view, {"occupied": obstacles, "dangerous": dangerous + clearance - around_unseen + edge})
    assert drawn["occupied"] == obstacles, drawn
    assert drawn["dangerous"] == dangerous + clearance - around_unseen + edge, drawn
    assert "unknown" not in drawn and "free" not in drawn  # off by default
    assert "free and unknown not drawn: tick <i>Free cells</i> / <i>Unknown cells</i> under Layers" \
        in view._counts.content  # the counts line says how to show them

    view._checks["unknown"].value = True  # the toggle under Layers, as the browser sets it
    drawn = _wait_for(view, {"unknown": unknown + around_unseen})
    assert drawn["unknown"] == unknown + around_unseen and drawn["occupied"] == obstacles, drawn
    handle = view._handles["unknown"]
    assert handle.opacity is not None and handle.opacity < 0.5  # translucent grey

    view._checks["occupied"].value = False
    drawn = _wait_for(view, {"occupied": 0})
    assert "occupied" not in drawn and drawn["unknown"] == unknown + around_unseen, drawn

    view._checks["free"].value = True  # one click shows the free cells of the goal layer
    free_floor = int(np.count_nonzero(grid.state[:, :, 0] == CellState.FREE))
    drawn = _wait_for(view, {"free": free_floor})
    assert free_floor > 0 and drawn["free"] == free_floor, drawn
    assert "free and" not in view._counts.content


def _drawn_yellow(view: GridView, grid: object) -> int:
    """The yellow cells the view draws once it has redrawn ``grid`` (waits on the drawn count, not on time)."""
    from console.views.grid_view import layer_mask

    want = int(layer_mask(grid, "dangerous").sum())  # type: ignore[arg-type]
    drawn = _wait_for(view, {"dangerous": want})
    assert drawn.get("dangerous", 0) == want, (drawn, want)
    return want


def test_planning_into_unknown_space_does_not_paint_it_yellow(server: viser.ViserServer, captured: Session) -> None:
    view = GridView(server, captured)
    closed = _drawn_yellow(view, captured.grid)
    captured.set_plan_unknown(True)
    grid = captured.grid
    assert grid.rule == "allow" and grid.unseen is not None and grid.unseen.any()
    allowed = _drawn_yellow(view, grid)
    # the first capture leaves most of the room unseen: thousands of cells the planner may now cross (dearer);
    # they stay grey (the Unknown layer), so yellow stays the band around obstacles and the edge, as with it off
    unseen_dear = int(((grid.state == CellState.DANGEROUS) & grid.unseen).sum())
    assert unseen_dear > 300, unseen_dear
    assert abs(allowed - closed) <= 0.25 * closed, (allowed, closed)  # (the edge band next to unseen space)
    from console.views.grid_view import layer_mask, unseen_cells

    assert not (layer_mask(grid, "dangerous") & unseen_cells(grid)).any()
    assert (layer_mask(grid, "unknown") & grid.unseen).sum() == grid.unseen.sum()  # every one of them grey
    captured.set_plan_unknown(False)
    assert _drawn_yellow(view, captured.grid) == closed
