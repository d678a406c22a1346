"""Path -> mission segments, JSON round trip and validation."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from pipeline.scene import SceneObject
from planner.grid import Workspace, build_grid
from planner.mission import Mission, MissionError, mission_from_cells, simplify
from planner.robot_model import RobotModel


def _grid(objs=()):
    return build_grid(list(objs), Workspace(resolution=0.25), margin=0.3)


def test_ground_only_path_is_one_walk() -> None:
    cells = np.array([[2, 2, 0], [3, 3, 0], [4, 4, 0], [5, 4, 0], [6, 4, 0]])
    m = mission_from_cells(cells, _grid())
    assert m.kinds() == ["walk"]
    wps = np.array(m.segments[0].waypoints)
    assert np.allclose(wps[:, 2], 0.0)  # on the floor
    assert len(wps) == 3  # collinear runs collapsed: start, turn, end


def test_walk_takeoff_fly_land_walk() -> None:
    cells = np.array([[2, 2, 0], [2, 3, 0], [2, 4, 1], [2, 5, 2], [2, 6, 2], [2, 7, 1], [2, 8, 0], [2, 9, 0]])
    m = mission_from_cells(cells, _grid())
    assert m.kinds() == ["walk", "takeoff", "fly", "land", "walk"]
    to, fly, land = m.segments[1], m.segments[2], m.segments[3]
    ws = Workspace(resolution=0.25)
    assert to.spot == pytest.approx((0.625, 0.875, 0.0))
    assert to.height == pytest.approx(ws.layer_height(1))
    assert fly.start == to.end and fly.end == land.start
    assert land.spot == pytest.approx((0.625, 2.125, 0.0))
    assert max(w[2] for w in fly.waypoints) == pytest.approx(ws.layer_height(2))
    assert m.segments[4].start == land.spot


def test_path_ending_in_the_air_has_no_landing() -> None:
    cells = np.array([[2, 2, 0], [2, 3, 1], [2, 4, 2]])
    m = mission_from_cells(cells, _grid())
    assert m.kinds() == ["takeoff", "fly"]


def test_takeoff_spot_must_be_free_ground() -> None:
    box = SceneObject("b", "cardboard_box", (0.625, 1.375, 0.25), (0.25, 0.5, 0.25))
    g = _grid([box])
    # cell (2, 3, 0) is 0.375 m from the box at (2, 5): beyond the 0.3 m radius (cell (2, 4) is
    # closed), within the danger band: dangerous
    cells = np.array([[2, 2, 0], [2, 3, 0], [2, 4, 2], [2, 8, 0]])
    with pytest.raises(MissionError, match="take-off spot .* dangerous"):
        mission_from_cells(cells, g)


def test_json_round_trip_and_validation(tmp_path: Path) -> None:
    cells = np.array([[2, 2, 0], [2, 3, 0], [2, 4, 1], [2, 5, 1], [2, 6, 0]])
    m = mission_from_cells(cells, _grid())
    p = m.save(tmp_path / "m.json")
    back = Mission.load(p)
    assert back.kinds() == m.kinds()
    assert np.allclose(back.segments[1].waypoints, m.segments[1].waypoints)
    d = json.loads(p.read_text())
    d["segments"][2]["kind"] = "swim"
    with pytest.raises(MissionError, match=r"segments\[2\].kind"):
        Mission.from_dict(d)
    d = json.loads(p.read_text())
    d["segments"][1]["waypoints"] = [[0, 0, 0]]
    with pytest.raises(MissionError, match=r"segments\[1\]"):
        Mission.from_dict(d)
    d = json.loads(p.read_text())
    d["segments"][3]["waypoints"][0] = [9, 9, 9]
    with pytest.raises(MissionError, match="starts at"):
        Mission.from_dict(d)


def test_simplify_keeps_turns_and_reversals() -> None:
    p = np.array([[0, 0, 0], [1, 0, 0], [2, 0, 0], [2, 1, 0], [2, 2, 0], [2, 1, 0]], float)
    assert simplify(p).tolist() == [[0, 0, 0], [2, 0, 0], [2, 2, 0], [2, 1, 0]]


def test_takeoff_spot_needs_room_above() -> None:
    """A shelf board 0.3-0.45 m above the floor (no danger margin): the floor under it is free,
    but the robot cannot take off there."""
    board = SceneObject("shelf", "shelf", (0.625, 0.875, 0.375), (0.25, 0.15, 0.25))
    # a point robot low enough (one layer) to walk under the board
    g = build_grid([board], Workspace(resolution=0.25), robot=RobotModel(0.0, 0.25, 0.0))
    assert g.state_at((2, 3, 0)).name == "FREE" and g.state_at((2, 3, 1)).name == "OCCUPIED"
    with pytest.raises(MissionError, match=r"take-off spot \(0.62, 0.88\) has an obstacle right above it"):
        mission_from_cells(np.array([[2, 3, 0], [2, 4, 1], [2, 5, 0]]), g)
    with pytest.raises(MissionError, match=r"landing spot \(0.62, 0.88\) has an obstacle right above it"):
        mission_from_cells(np.array([[2, 1, 0], [2, 2, 1], [2, 3, 0]]), g)
    beside = mission_from_cells(np.array([[1, 3, 0], [1, 4, 1], [1, 5, 0]]), g)  # one cell to the side
    assert beside.kinds() == ["takeoff", "fly", "land"]
