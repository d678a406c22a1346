"""Found by trying the console as a newcomer: a capture from the air above the line of stacked boxes
warned "Check the camera pose" although the pose was right (only the upper boxes of the stacks were in
view, so every box bottom was over the floor)."""

from __future__ import annotations


import pytest

from pipeline.camera.pose_check import floor_check
from pipeline.scene import Scene, SceneObject


def _box(i: int, label: str, bottom: float, h: float = 0.4, cut: tuple[str, ...] = ()) -> SceneObject:
    return SceneObject(f"o{i}", label, (1.0 + 0.5 * i, 4.0, bottom + h / 2), (0.45, h, 0.45), 0.0, "world", cut=cut)


def test_stacked_boxes_over_the_floor_are_no_evidence_of_a_wrong_pose() -> None:
    # the middle layer of a line of boxes, its lower part under the image border, and the top layer on it
    middle = [_box(i, "cardboard_box", 0.4, cut=("bottom",)) for i in range(5)]
    top = [SceneObject(f"t{i}", "cardboard_box", (1.0 + 0.5 * i, 4.0, 1.0), (0.45, 0.4, 0.45), 0.0, "world")
           for i in range(5)]
    assert floor_check(Scene([*middle, *top])) == []
    assert floor_check(Scene(top)) != []  # the same boxes with nothing under them do float


def test_floor_standing_objects_floating_are_still_reported_among_stacked_boxes() -> None:
    scene = Scene([_box(0, "office_chair", 0.5, 1.0), _box(1, "desk", 0.55, 0.75),
                   *(_box(i, "cardboard_box", 0.8) for i in range(2, 8))])
    (warning,) = floor_check(scene)
    assert "objects float over the floor" in warning


def test_stacked_boxes_under_the_floor_are_still_reported() -> None:
    scene = Scene([_box(i, "cardboard_box", -0.4) for i in range(6)])
    (warning,) = floor_check(scene)
    assert "objects land under the floor" in warning


@pytest.mark.parametrize("x, y, z, yaw_deg", [(2.62, 0.62, 1.62, 90.0), (2.625, 0.625, 1.625, 89.5), (1.5, 0.6, 1.6, 80.0)])
def test_a_capture_hovering_in_front_of_the_line_of_boxes_mapped_with_the_right_pose_is_not_flagged(
        sim_shot, gt_map, x: float, y: float, z: float, yaw_deg: float) -> None:
    """The console case: the simulated robot hovering at 1.6 m, 3.4 m before the line, camera level.

    (Not yet right: from lower, e.g. 1.1 m, the middle boxes' bottoms hidden behind the desks are
    still taken for floating; the check knows nothing of occlusion.)"""
    from console.link.sim import DEFAULT_MOUNT

    scene = gt_map(sim_shot(x, y, z, yaw_deg), DEFAULT_MOUNT).scene
    assert sum(o.label == "cardboard_box" for o in scene.objects) >= 10
    assert floor_check(scene) == []
