"""The camera-pose sanity check: objects under the floor or all floating are reported with the likely cause."""

from __future__ import annotations

from pipeline.camera.pose_check import floor_check
from pipeline.scene import Scene, SceneObject


def _obj(i: int, label: str, bottom: float, h: float = 0.8, known: bool = True, frame: str = "world") -> SceneObject:
    return SceneObject(f"o{i}", label, (1.0 + i, 2.0, bottom + h / 2), (0.5, h, 0.5), 0.0, frame,  # type: ignore[arg-type]
                       size_known=known)


def test_objects_on_the_floor_are_fine() -> None:
    scene = Scene([_obj(0, "chair", 0.03), _obj(1, "desk", -0.06), _obj(2, "cup", 0.75, 0.1)])
    assert floor_check(scene) == []
    assert floor_check(Scene([])) == []


def test_objects_under_the_floor_name_the_mount() -> None:
    scene = Scene([_obj(0, "chair", -0.32), _obj(1, "desk", -0.25), _obj(2, "box", -0.2), _obj(3, "box", 0.5)])
    (warning,) = floor_check(scene)
    assert warning.startswith("objects land under the floor (the lower quartile of the box bottoms is 0.27 m under "
                              "it; chair -0.32 m, desk -0.25 m, box -0.20 m)")
    assert "mount height and pitch" in warning and "pitch_deg" in warning and "camera_height" in warning


def test_one_stray_object_under_the_floor_is_mapping_noise() -> None:
    scene = Scene([_obj(0, "box", -0.6), _obj(1, "desk", 0.0), _obj(2, "chair", 0.02), _obj(3, "box", 0.5),
                   _obj(4, "box", 0.9)])
    assert floor_check(scene) == []


def test_one_object_alone_under_the_floor_proves_nothing_two_do() -> None:
    """The console case: YOLOX-Nano read a small toy in the simulator's render as a 0.33 "refrigerator"; its
    1.8 m size put it 0.69 m under the floor and the console blamed the camera pose."""
    assert floor_check(Scene([_obj(0, "refrigerator", -0.69, 1.8)])) == []
    (warning,) = floor_check(Scene([_obj(0, "refrigerator", -0.69, 1.8), _obj(1, "chair", -0.3)]))
    assert "the second lowest box bottom is 0.30 m under it" in warning and "refrigerator -0.69 m" in warning


def test_every_object_floating_is_reported_but_one_on_a_table_is_not() -> None:
    floating = Scene([_obj(0, "chair", 0.45), _obj(1, "suitcase", 0.6)])
    (warning,) = floor_check(floating)
    assert "objects float over the floor (the lowest box bottom is 0.45 m over it" in warning
    assert "mount height and pitch" in warning
    assert floor_check(Scene([_obj(0, "cup", 0.75, 0.1)])) == []  # one object on a table: no evidence


def test_floor_height_unknown_sizes_and_other_frames() -> None:
    scene = Scene([_obj(0, "chair", 0.9)])
    assert floor_check(scene, floor_z=1.0) == []  # a floor at z = 1 m: the chair stands on it
    assert floor_check(Scene([_obj(0, "thing", -0.5, known=False), _obj(1, "x", -0.5, frame="camera")])) == []


def test_a_photo_from_a_high_tilted_camera_mapped_with_the_level_mount_is_flagged(sim_shot, gt_map) -> None:
    """The issue's case: taken from 1.2 m looking 30 deg down, mapped as if from the 0.35 m level mount."""
    import math

    from console.link.sim import DEFAULT_MOUNT
    from pipeline.camera.geometry import CameraMount

    high = CameraMount((0.15, 0.0, 1.2), math.radians(30.0))
    shot = sim_shot(mount=high)
    scenes = {name: gt_map(shot, mount).scene for name, mount in (("true", high), ("assumed", DEFAULT_MOUNT))}
    assert len(scenes["true"].objects) >= 2
    assert floor_check(scenes["true"]) == []  # the right pose: everything on (or over) the floor
    warnings = floor_check(scenes["assumed"])
    # the mapper's own floor fit names the photo's pose (true: 30 deg down, 1.2 m up), then the landing check
    assert len(warnings) == 2 and "mount height and pitch" in warnings[1], warnings
    import re

    got = re.search(r"pitch (-?[\d.]+) deg \(given 0\.0\), camera ([\d.]+) m above the floor \(given 0\.35 m\)", warnings[0])
    assert got and abs(float(got[1]) - 30.0) < 3.0 and abs(float(got[2]) - 1.2) < 0.2, warnings[0]
