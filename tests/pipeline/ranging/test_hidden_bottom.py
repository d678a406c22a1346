"""An object whose lower part a nearer one hides is placed from its top edge, not floating.

The paper room's cabinet (1.85 m) behind the line of boxes shows a sliver of its top: its centre was
placed on that sliver's ray, 1.87 m up, and the map then reported it "floating 0.94 m above the floor".
"""

from __future__ import annotations


import numpy as np
import pytest

from pipeline.camera.geometry import Intrinsics
from pipeline.ranging.hidden_bottom import centre_below_top

INTR = Intrinsics(525.0, 525.0, 319.5, 239.5, 640, 480)
G = (0.0, 1.0, 0.0)  # a level camera: gravity along +y (down)


def _px(p: np.ndarray) -> float:
    return INTR.cy + INTR.fy * p[1] / p[2]


def test_a_top_sliver_is_placed_half_its_height_below_the_top() -> None:
    H, h, z = 1.0, 1.85, 5.0  # camera 1 m up, a 1.85 m cabinet 5 m ahead, its top 0.85 m over the camera
    top, bottom = _px(np.array([0.0, -(h - H), z])), _px(np.array([0.0, -0.7, z]))  # boxes hide below 0.3 m under its top
    placed = np.array([0.0, 0.5 * (top + bottom - 2 * INTR.cy) / INTR.fy * z, z])  # on the sliver's ray
    c = centre_below_top(placed, (300.0, top, 340.0, bottom), h, G, H, INTR)
    assert c is not None
    assert H - c[1] == pytest.approx(0.5 * h, abs=1e-6)  # centre 0.925 m over the floor
    assert c[2] == pytest.approx(z)


def test_a_whole_object_or_one_on_the_floor_keeps_its_centre() -> None:
    H, h, z = 1.0, 0.5, 3.0
    top, bottom = _px(np.array([0.0, H - h, z])), _px(np.array([0.0, H, z]))
    centre = np.array([0.0, H - 0.5 * h, z])
    assert centre_below_top(centre, (300.0, top, 340.0, bottom), h, G, H, INTR) is None  # bottom on the floor
    # a whole 0.5 m object on a 0.75 m desk: all of it shows, it stands on something
    top, bottom = _px(np.array([0.0, H - 1.25, z])), _px(np.array([0.0, H - 0.75, z]))
    assert centre_below_top(np.array([0.0, H - 1.0, z]), (300.0, top, 340.0, bottom), h, G, H, INTR) is None


@pytest.mark.parametrize("x, y, z, yaw_deg", [(2.5, 0.7, 0.0, 90.0), (2.5, 1.2, 1.0, 90.0)])
def test_the_cabinet_behind_the_box_line_stands_on_the_floor(sim_shot, gt_map, x: float, y: float, z: float,
                                                             yaw_deg: float) -> None:
    scene = gt_map(sim_shot(x, y, z, yaw_deg)).scene
    (cab,) = [o for o in scene.objects if o.label == "office_cabinet"]
    assert abs(cab.position[2] - 0.925) < 0.05, cab.position  # was 1.87 from the start pose
