"""A capture from the air is not told "objects float over the floor" when its pose is right.

The search's hover with the camera 1.98 m up facing the line of boxes (``morphonavi search --target 'robot
dog'``, cap-0005): the boxes it sees whole are the upper rows, their lower boxes and the floor under them
hidden behind the desk in front (or, 2.3 m up, below the image's bottom border), so their bottoms 0.37-0.44 m
up proved nothing about the camera pose; the floor check warned anyway. A floating box counts only when the
floor under it is seen at the capture's own camera pose: inside the image, behind no other object of the photo.
Ground-truth perception of the simulator's render (fixtures of tests/pipeline/conftest.py). World frame [m].
"""

from __future__ import annotations

import pytest

from pipeline.camera.pose_check import floor_check
from pipeline.scene import Capture, Scene, SceneObject, Source

# robot body (x, y, z) [m] and yaw [deg]: the search's hover (camera at (3.75, 0.45, 1.98)), beside it, and higher
HOVERS = [(3.875, 0.375, 1.625, 150.0), (3.875, 0.375, 1.55, 150.0), (3.8, 0.45, 1.65, 145.0),
          (3.88, 0.38, 1.98, 155.0), (3.88, 0.3, 1.9, 155.0), (3.95, 0.38, 1.9, 145.0)]


@pytest.mark.parametrize("x, y, z, yaw_deg", HOVERS)
def test_a_hover_over_the_box_line_gives_no_floating_warning(sim_shot, gt_map, x, y, z, yaw_deg) -> None:
    scene = gt_map(sim_shot(x, y, z, yaw_deg)).scene
    assert scene.captures[0].camera_position[2] > 1.8  # a camera in the air
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


def test_floating_boxes_behind_a_desk_are_no_evidence() -> None:
    """The camera 1.5 m up: the floor 3 m ahead is in the image, but the floor under the boxes is behind a desk."""
    scene = _floating(1.5)
    assert floor_check(scene)  # nothing in front: the floor under the boxes is seen, they float
    desk = SceneObject("desk-1", "desk", (0.0, 2.2, 0.375), (0.7, 0.75, 1.6), source=Source(capture="c"),
                       cut=("bottom",))
    assert floor_check(Scene(objects=scene.objects + (desk,), captures=scene.captures)) == []
