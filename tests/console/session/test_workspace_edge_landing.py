"""Landing spots keep the robot's radius from the workspace's edge (Land here during a search picks the
nearest seen-free floor: never in the band along a wall); landing straight down from a hover beside
the wall is not refused as if an obstacle were below (going down brings it no nearer the wall)."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np

from pipeline.mapping.known_space import KnownSpace
from planner.grid import Workspace, build_grid
from planner.robot_model import MORPHOGEAR

from console.session.operator_state import landing_blocker
from console.session.search_landing import nearest_landing_spots, seen_free_floor

WS = Workspace()


def _hover(x: float, y: float, z: float) -> SimpleNamespace:
    return SimpleNamespace(pose=SimpleNamespace(translation=(x, y, z)))


def test_the_nearest_landing_spot_beside_a_wall_keeps_the_radius_from_it() -> None:
    ks = KnownSpace.empty(WS.min, WS.max, WS.resolution)
    free = np.ones(ks.shape, dtype=bool)  # everything seen free
    grid = build_grid([], WS, known=ks.updated(free, np.zeros_like(free)))
    ok = seen_free_floor(grid)
    assert ok is not None and ok[1:19, 1:31].all() and not ok[0].any() and not ok[19].any() and not ok[:, 0].any()
    for point in ((4.95, 4.0, 1.0), (0.05, 7.95, 1.0), (2.5, 0.05, 0.6)):
        spots = nearest_landing_spots(grid, point)
        assert spots, point
        for x, y, _ in spots:
            gap = min(x - WS.min[0], WS.max[0] - x, y - WS.min[1], WS.max[1] - y)
            assert gap >= MORPHOGEAR.radius - 1e-9, (point, (x, y))
        assert np.hypot(spots[0][0] - point[0], spots[0][1] - point[1]) < 0.6  # the nearest: just inside the band


def test_land_here_straight_down_beside_the_wall_is_not_refused_as_an_obstacle() -> None:
    grid = build_grid([], WS)
    assert landing_blocker(_hover(4.9, 4.0, 1.2), grid) is None
    assert landing_blocker(_hover(2.5, 7.95, 2.9), grid) is None  # under the top too
