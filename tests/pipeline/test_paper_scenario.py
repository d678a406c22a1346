"""The paper's experiment: a line of obstacles splits the room, a robot dog hides behind boxes.

The robot must walk, take off, fly over the line, land and walk to the dog; with a gap in the
line that makes walking around cheaper, it must walk around instead.
"""

from __future__ import annotations

import numpy as np
import pytest

from pipeline.scene import Scene, SceneObject
from planner.grid import CellState, Workspace, build_grid
from planner.mission import SegmentKind
from planner.route import Route

START = (2.5, 0.7, 0.0)
GOAL = (2.5, 5.7, 0.0)  # in front of the dog


def _room(gap: bool) -> Scene:
    objs = [
        SceneObject("desk-1", "desk", (0.8, 1.8, 0.375), (0.7, 0.75, 1.4)),
        SceneObject("chair-1", "office_chair", (1.6, 2.2, 0.5), (0.6, 1.0, 0.6)),
        SceneObject("dog", "robot_dog", (2.5, 6.3, 0.2), (0.28, 0.4, 0.645), yaw=np.pi / 2),
    ]
    # stacked boxes in a line across the room at y = 4 m, 1.2 m high
    x, n = 0.0, 0
    end = 4.0 if gap else 5.0
    while x < end - 1e-9:
        w = min(0.5, end - x)
        objs.append(SceneObject(f"box-{n}", "cardboard_box", (x + w / 2, 4.0, 0.6), (0.5, 1.2, w)))
        x += w
        n += 1
    return Scene(objects=tuple(objs))


def _plan(gap: bool):
    grid = build_grid(_room(gap), Workspace(), margin=0.35)
    route = Route(grid, START)
    res = route.propose(GOAL)
    assert res.ok, res.message
    route.register()
    return grid, route.mission(), res


def test_line_without_gap_forces_walk_takeoff_fly_land_walk() -> None:
    grid, mission, res = _plan(gap=False)
    assert mission.kinds() == ["walk", "takeoff", "fly", "land", "walk"]
    fly = mission.segments[2]
    # it crosses the line in the air, above the boxes and their dangerous shell
    assert min(w[1] for w in fly.waypoints) < 4.0 < max(w[1] for w in fly.waypoints)
    top = max(w[2] for w in fly.waypoints)
    assert top > 1.2
    # every path cell is passable; take-off and landing spots are free ground
    assert not np.any(grid.state[tuple(res.cells.T)] == CellState.OCCUPIED)
    for seg in (mission.segments[1], mission.segments[3]):
        assert grid.state_at(grid.workspace.cell_of(seg.spot)) is CellState.FREE
    assert mission.segments[-1].end == pytest.approx((2.625, 5.625, 0.0))


def test_gap_makes_walking_around_cheaper() -> None:
    _, mission, res = _plan(gap=True)
    assert mission.kinds() == ["walk"]
    assert np.all(res.cells[:, 2] == 0)
    # it goes through the gap at x > 4 m
    xs = Workspace().centers(res.cells)[:, 0]
    assert xs.max() > 4.0


def test_expensive_flight_weights_still_fly_when_no_gap() -> None:
    grid = build_grid(_room(False), Workspace(), margin=0.35)
    from planner.grid import CostWeights

    route = Route(grid, START, CostWeights(takeoff=50.0, flight=10.0))
    assert route.propose(GOAL).ok
    route.register()
    assert SegmentKind.FLY.value in route.mission().kinds()
