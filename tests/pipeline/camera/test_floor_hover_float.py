"""A capture from the air is not told "objects float over the floor" when its pose is right.

The search's hover 2 m up (camera 2.33 m) facing the line of boxes: the boxes it sees whole are the upper
rows, their lower boxes hidden behind nearer ones and the floor under them below the image's bottom border,
so their bottoms 0.37-0.39 m up proved nothing about the camera pose; the floor check warned anyway. A
floating box counts only when the floor under it is in the image at the capture's own camera height.
Ground-truth perception of the simulator's render (fixtures of tests/pipeline/conftest.py). World frame [m].
"""

from __future__ import annotations

import pytest

from pipeline.camera.pose_check import floor_check
from pipeline.scene import Capture, Scene, SceneObject, Source

# robot (x, y, z) [m] and yaw [deg] of hovers the search chose (3.88, 0.38, 1.98, facing 150 deg) and beside it
HOVERS = [(3.88, 0.38, 1.98, 155.0), (3.88, 0.3, 1.9, 155.0), (3.95, 0.38, 1.9, 145.0), (3.8, 0.38, 1.98, 155.0)]


@pytest.mark.parametrize("x, y, z, yaw_deg", HOVERS)
def test_a_hover_over_the_box_line_gives_no_floating_warning(sim_shot, gt_map, x, y, z, yaw_deg) -> None:
    scene = gt_map(sim_shot(x, y, z, yaw_deg)).scene
    assert scene.captures[0].camera_position[2] > 2.0  # a camera in the air
    assert floor_check(scene) == []


def _floating(camera_z: float) -> Scene:
    """Two boxes 0.45 m over the floor, 3 m ahead of a level camera at ``camera_z`` (facing +y)."""
    cap = Capture("c", intrinsics={"fx": 400.0, "fy": 400.0, "cx": 320.0, "cy": 240.0, "width": 640, "height": 480},
                  camera_position=(0.0, 0.0, camera_z),
                  camera_quaternion=(-0.7071067811865476, 0.0, 0.0, 0.7071067811865476))  # optical z -> world +y
    boxes = [SceneObject(f"box-{i}", "cardboard_box", (x, 3.0, 0.65), (0.4, 0.4, 0.4), source=Source(capture="c"))
             for i, x in enumerate((-0.5, 0.5))]
    return Scene(objects=tuple(boxes), captures=(cap,))


def test_floating_boxes_are_still_named_when_the_floor_under_them_is_in_view() -> None:
    (warning,) = floor_check(_floating(0.35))  # floor 3 m ahead of a camera 0.35 m up: in the image
    assert "objects float over the floor (the lowest box bottom is 0.45 m over it" in warning
    assert floor_check(_floating(2.3)) == []  # 2.3 m up: the floor there is under the image's bottom border
