"""The planner keeps the robot's radius from where a mapped object may really be: its box grown by
k sigma of its fused sightings (capped); pinned and history-less objects keep no extra margin."""

from __future__ import annotations

import math
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from console.link.world_file import load_world
from pipeline.scene import SceneObject, Sighting, Source
from planner.grid import CellState, Closed, Workspace, build_grid
from planner.map_uncertainty import K_SIGMA, MARGIN_CAP, object_margin, position_sigma, yaw_sigma
from planner.robot_model import MORPHOGEAR, RobotModel
from planner.route import Route

SURE = RobotModel(mapping_margin=True)  # the robot model with the mapping margin on (off by default)

GAP_LINE = Path(__file__).resolve().parents[2] / "examples" / "worlds" / "gap_line.world.json"


def _seen(o: SceneObject, sigma: float, yaw: float, n: int = 1, **kw) -> SceneObject:
    """``o`` as the map fusion leaves it after ``n`` sightings of 1-sigma ``sigma`` [m] / ``yaw`` [rad]."""
    h = (Sighting("c", o.position, o.yaw, o.size, (sigma, sigma / 4, yaw)),) * n
    return replace(o, history=h, source=Source("c", "fused"), **kw)


def _sofa(x: float = 2.5, y: float = 4.0) -> SceneObject:
    return SceneObject("sofa-1", "sofa", (x, y, 0.4), (0.9, 0.8, 2.0), yaw=0.0)  # 2 m long along x


def test_margin_is_k_sigma_of_the_farthest_corner_capped() -> None:
    sofa = _sofa()
    assert object_margin(sofa) == 0.0  # a scene-file object: no history, no margin
    one = _seen(sofa, 0.08, math.radians(3))
    r = math.hypot(0.9, 2.0) / 2
    assert position_sigma(one) == pytest.approx(0.08) and yaw_sigma(one) == pytest.approx(math.radians(3))
    assert object_margin(one) == pytest.approx(K_SIGMA * math.hypot(0.08, r * math.radians(3)))
    four = _seen(sofa, 0.08, math.radians(3), n=4)  # fused: sigma / sqrt(n)
    assert object_margin(four) == pytest.approx(object_margin(one) / 2)
    assert object_margin(_seen(sofa, 0.5, 0.35)) == MARGIN_CAP
    assert object_margin(_seen(sofa, 0.08, 0.05, pinned=True)) == 0.0  # the operator confirmed it: exact
    assert object_margin(one.moved((3.0, 4.0, 0.4))) == 0.0  # the operator moved it: exact
    rejected = replace(one, history=tuple(replace(h, used=False) for h in one.history))
    assert object_margin(rejected) == 0.0


def test_a_noisy_mapped_box_closes_cells_the_exact_one_leaves_open() -> None:
    ws = Workspace(resolution=0.1)
    sofa = _sofa()
    x = 2.5 + 1.0 + 0.35 + 0.08  # 8 cm beyond the robot's radius from the sofa's end, on its axis
    cell = ws.cell_of((x, 4.0, 0.0))
    exact = build_grid([sofa], ws, robot=SURE)
    assert exact.state_at(cell) is not CellState.OCCUPIED
    noisy = build_grid([_seen(sofa, 0.08, math.radians(3))], ws, robot=SURE)  # margin 2 * hypot(0.08, 1.10 * 0.052) = 0.20 m
    assert noisy.state_at(cell) is CellState.OCCUPIED and noisy.reason_at(cell) == Closed.CLEARANCE
    assert noisy.owner_of(cell) == "sofa-1"
    for beyond in (0.2, 0.3):  # the danger band still ends 0.25 m beyond the radius from the mapped box
        far = ws.cell_of((2.5 + 1.0 + 0.35 + beyond, 4.0, 0.0))
        assert noisy.state_at(far) is exact.state_at(far) is (CellState.DANGEROUS if beyond < 0.25 else CellState.FREE)
    # flying past it the same margin holds in plan (not above it: the box's height is its own)
    air = ws.cell_of((x, 4.0, 0.45))
    assert exact.state_at(air) is not CellState.OCCUPIED and noisy.state_at(air) is CellState.OCCUPIED
    over = ws.cell_of((2.5, 4.0, 0.8 + 0.35 + 0.08))
    assert noisy.state_at(over) is not CellState.OCCUPIED


def test_the_goal_refusal_names_the_margin() -> None:
    ws = Workspace(resolution=0.1)
    grid = build_grid([_seen(_sofa(), 0.08, math.radians(3))], ws, robot=SURE)
    res = Route(grid, (0.5, 0.5, 0.0)).plan((0.5, 0.5, 0.0), (2.5 + 1.0 + 0.35 + 0.08, 4.0, 0.0))
    assert not res.ok
    assert "sofa 'sofa-1'" in res.message and "0.20 m for where it may really be" in res.message


def _gap_line(sigma: float | None, yaw: float = 0.0, n: int = 1) -> tuple[list[SceneObject], Workspace]:
    w = load_world(GAP_LINE)
    objs = list(w.scene.objects)
    if sigma is not None:
        objs = [_seen(o, sigma, yaw, n) for o in objs]
    return objs, w.workspace(0.25)


@pytest.mark.parametrize("sigma, yaw, n", [(None, 0.0, 1), (0.02, 0.02, 3), (0.08, math.radians(3), 1),
                                           (1.0, 0.5, 1)])
def test_the_13_m_gap_still_plans_on_foot_and_the_05_m_one_never(sigma, yaw, n) -> None:
    """The gap_line world's 1.3 m gap (x 3.2..4.53) leaves its middle cell 0.65 m from both sides: open
    for the robot's 0.35 m radius with any margin up to the cap; the 0.5 m gap is closed either way."""
    objs, ws = _gap_line(sigma, yaw, n)
    grid = build_grid(objs, ws, robot=SURE)
    row = ws.cell_of((0.0, 3.5, 0.0))[1]
    xs = ws.axes()[0]
    open_x = [float(xs[i]) for i in range(len(xs)) if grid.state[i, row, 0] != CellState.OCCUPIED]
    assert open_x and all(3.2 < x < 4.53 for x in open_x)
    res = Route(grid, (3.0, 0.7, 0.0)).plan((3.0, 0.7, 0.0), (3.9, 5.0, 0.0))
    assert res.ok and bool(np.all(res.cells[:, 2] == 0)), res.message  # walks through the gap


def test_the_default_robot_keeps_no_mapping_margin() -> None:
    ws = Workspace(resolution=0.1)
    cell = ws.cell_of((2.5 + 1.0 + 0.35 + 0.08, 4.0, 0.0))
    assert not MORPHOGEAR.mapping_margin
    assert build_grid([_seen(_sofa(), 0.08, math.radians(3))], ws).state_at(cell) is not CellState.OCCUPIED
