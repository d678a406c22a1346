"""The landing rule (planner/landing_spot.py): the robot's whole footprint against mapped objects of any
height (a 5 cm sports mat), unlabelled obstacle cells (an unmapped mat the simulator's exact depth saw) and
unseen floor; the whole-floor mask agrees with the one-spot rule; every mission's landing checks it."""

from __future__ import annotations

import math

import numpy as np
import pytest

from pipeline.camera.geometry import CameraMount, Intrinsics, Pose, camera_pose_in_world
from pipeline.mapping.known_space import KnownSpace
from pipeline.mapping.known_space_update import box_depth, capture_update
from pipeline.scene import SceneObject
from planner.grid import Workspace, build_grid
from planner.landing_spot import landing_mask, landing_problem, unseen_footprint
from planner.mission import MissionError, mission_from_cells

WS = Workspace((0.0, 0.0, 0.0), (5.0, 8.0, 3.0), 0.25)
MAT = SceneObject("sports_mat-1", "sports_mat", (2.5, 5.0, 0.025), (1.0, 0.05, 1.0), 0.0)  # x 2.0-3.0, y 4.5-5.5
INTR = Intrinsics(525.0, 525.0, 319.5, 239.5, 640, 480)
CAM = camera_pose_in_world(Pose.from_xyz_yaw(2.5, 2.0, 0.0, math.pi / 2), CameraMount(position=(0.15, 0.0, 0.35)))


def _seen_mat_known() -> KnownSpace:
    """One capture of exact depth from (2.5, 2.0) facing +y: the floor and the mat ahead."""
    space = KnownSpace.empty(WS.min, WS.max, WS.resolution)
    return capture_update(space, box_depth([MAT], INTR, CAM), INTR, CAM).space


def test_a_mapped_mat_beside_the_spot_stops_the_landing_whatever_its_height() -> None:
    grid = build_grid([MAT], WS, robot=None, margin=0.35)
    p = landing_problem(grid, (3.25, 5.0))  # 0.25 m beside the mat's edge: the footprint reaches onto it
    assert p is not None and p.kind == "object" and p.owner == "sports_mat-1"
    assert str(p).startswith("sports mat 'sports_mat-1' is 0.25 m from the landing spot (3.25, 5.00)")
    assert landing_problem(grid, (2.5, 5.0)).text.startswith("sports mat 'sports_mat-1' is under")  # type: ignore[union-attr]
    assert landing_problem(grid, (3.375, 5.125)) is None  # 0.375 m away (a cell centre): clear of the radius
    assert landing_problem(grid, (3.375, 5.125), clear=True).kind == "danger"  # type: ignore[union-attr]
    assert landing_problem(grid, (3.625, 5.125), clear=True) is None  # 0.625 m: clear of the danger band too
    assert landing_problem(grid, (3.25, 5.0), forced=True).kind == "object"  # type: ignore[union-attr]
    assert landing_problem(grid, (6.0, 5.0)).kind == "outside"  # type: ignore[union-attr]
    assert landing_problem(grid, (float("nan"), 5.0)).kind == "outside"  # type: ignore[union-attr]


def test_an_unmapped_mat_the_depth_saw_stops_the_landing_as_an_unlabelled_obstacle() -> None:
    grid = build_grid([], WS, margin=0.35, known=_seen_mat_known(), unknown="closed")
    assert grid.unlabelled > 0
    p = landing_problem(grid, (2.5, 4.75))  # on the mat's near edge
    assert p is not None and p.kind == "obstacle" and "unlabelled obstacle" in p.text, p
    forced = landing_problem(grid, (2.5, 4.75), forced=True)  # a forced landing still avoids it
    assert forced is not None and forced.kind == "obstacle"
    assert landing_problem(grid, (2.5, 3.5)) is None  # seen floor, 1 m short of the mat
    assert landing_problem(grid, (2.5, 1.0)).kind == "unseen"  # type: ignore[union-attr]  # behind the camera
    assert unseen_footprint(grid, (2.5, 1.0)) and not unseen_footprint(grid, (2.5, 3.5))


@pytest.mark.parametrize("unknown", ["closed", "allow"])
def test_the_floor_mask_is_the_one_spot_rule_at_every_cell(unknown: str) -> None:
    desk = SceneObject("desk-1", "desk", (1.0, 3.0, 0.375), (1.4, 0.75, 0.7), math.pi / 2)
    grid = build_grid([MAT, desk], WS, margin=0.35, known=_seen_mat_known(), unknown=unknown)
    xs, ys, _ = WS.axes()
    for forced, clear in ((False, False), (True, False), (False, True)):
        mask = landing_mask(grid, forced=forced, clear=clear)
        want = np.array([[landing_problem(grid, (x, y), forced=forced, clear=clear) is None for y in ys] for x in xs])
        assert np.array_equal(mask, want), (forced, clear, np.argwhere(mask != want)[:5])
        assert 0 < int(mask.sum()) < mask.size
    assert not landing_mask(grid)[WS.cell_of((2.5, 4.75, 0.0))[:2]]  # type: ignore[index]


def test_a_mission_never_lands_with_a_mat_under_the_footprint() -> None:
    grid = build_grid([MAT], WS, margin=0.35)
    # walk, take off, fly, land beside the mat: the spot (3.12, 5.12) is 0.12 m from its edge
    i0, j0 = WS.cell_of((3.375, 2.0, 0.0))[:2]  # type: ignore[index]
    i1, j1 = WS.cell_of((3.125, 5.0, 0.0))[:2]  # type: ignore[index]
    cells = np.array([[i0, j0, 0], [i0, j0 + 1, 2], [i1, j1, 2], [i1, j1, 0]])
    with pytest.raises(MissionError, match=r"cannot land at \(3.12, 5.12\): sports mat 'sports_mat-1' is 0.12 m from"):
        mission_from_cells(cells, grid)
    far = WS.cell_of((3.875, 5.0, 0.0))[:2]  # type: ignore[index]
    ok = mission_from_cells(np.array([[i0, j0, 0], [i0, j0 + 1, 2], [far[0], far[1], 2], [far[0], far[1], 0]]), grid)
    assert ok.kinds()[-1] == "land" and landing_problem(grid, ok.segments[-1].end) is None
