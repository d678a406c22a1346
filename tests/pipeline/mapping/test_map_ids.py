"""Ids stay stable and are never reused: an id freed by a removal, a merge or the operator's delete is
not given to another object, also after the map is saved and read back (a console restart).

Synthetic captures in the paper's room (world frame, z up [m]); a level camera 0.35 m up, 640 x 480 px,
its pose ``world <- camera`` in the OpenCV optical frame.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from pipeline.mapping.map_extent import id_numbers, next_id
from pipeline.mapping.map_fusion import fuse
from pipeline.scene import Capture, Scene, SceneError, SceneObject, Source, load_scene, save_scene, scene_from_dict

CAM = {"fx": 525.0, "fy": 525.0, "cx": 319.5, "cy": 239.5, "width": 640.0, "height": 480.0}
CHAIR = (0.62, 1.05, 0.62)


def _quaternion(yaw: float) -> tuple[float, ...]:
    c, s = math.cos(yaw), math.sin(yaw)
    r = np.array([[s, 0.0, c], [-c, 0.0, s], [0.0, -1.0, 0.0]])  # columns: camera x, y, z in the world
    return tuple(float(v) for v in Rotation.from_matrix(r).as_quat())


def _chair(oid: str, pos, cid: str, bbox) -> SceneObject:
    return SceneObject(oid, "office_chair", pos, CHAIR, 0.0, source=Source(cid, "depth", bbox=bbox))


def _capture(cid: str, camera, yaw: float, *objects: SceneObject) -> Scene:
    return Scene(objects=objects, captures=(Capture(cid, intrinsics=CAM, camera_position=camera,
                                                    camera_quaternion=_quaternion(yaw)),))


def _false_chair_removed() -> Scene:
    """office_chair-2, a false chair seen once in part, removed when a capture looked and saw nothing."""
    bad = _capture("bad", (2.42, 0.83, 0.35), math.pi / 2 + 0.55,
                   _chair("office_chair-1", (1.26, 2.63, 0.525), "bad", (198, 54, 395, 363)),
                   _chair("office_chair-2", (1.75, 2.33, 0.525), "bad", (375, 331, 489, 429)))
    scene, report = fuse(Scene(), bad)
    assert report.added == ["office_chair-1", "office_chair-2"]
    look = _capture("look", (2.0, 1.0, 0.35), math.pi / 2,
                    _chair("office_chair-1", (1.35, 2.45, 0.525), "look", (40, 60, 260, 380)))
    scene, report = fuse(scene, look)
    assert [o.id for o in scene.objects] == ["office_chair-1"] and report.removed[0][0] == "office_chair-2"
    return scene


def _another_chair(cid: str) -> Scene:
    """A real second chair far from the first, which the mapper of its photo calls ``office_chair-2``."""
    return _capture(cid, (3.8, 5.0, 0.35), math.pi / 2, _chair("office_chair-2", (3.9, 6.6, 0.525), cid,
                                                                (250, 100, 400, 330)))


def test_an_id_freed_by_a_removal_is_not_given_to_a_new_object() -> None:
    scene = _false_chair_removed()
    assert scene.last_ids == {"office_chair": 2}
    after, report = fuse(scene, _another_chair("later"))
    assert report.added == ["office_chair-3"]  # was office_chair-2: the removed false chair's id
    assert after.last_ids == {"office_chair": 3}


def test_an_id_freed_by_a_merge_or_a_delete_is_not_given_again() -> None:
    a = _capture("a", (1.2, -1.5, 0.35), math.pi / 2, _chair("office_chair-1", (1.2, 2.55, 0.525), "a",
                                                              (250, 60, 420, 360)))
    b = _capture("b", (1.8, -1.7, 0.35), math.pi / 2, _chair("office_chair-1", (1.8, 2.3, 0.525), "b",
                                                              (200, 60, 370, 360)))
    scene, _ = fuse(Scene(), a)
    scene, report = fuse(scene, b)
    assert report.added == ["office_chair-2"]
    between = _capture("c", (1.5, 1.2, 0.35), math.pi / 2, _chair("office_chair-1", (1.45, 2.35, 0.525), "c",
                                                                   (250, 60, 420, 360)))
    scene, report = fuse(scene, between)
    assert report.merged == (("office_chair-1", "office_chair-2"),)
    after, report = fuse(scene, _another_chair("later"))
    assert report.added == ["office_chair-3"]
    deleted = after.with_objects([o for o in after.objects if o.id != "office_chair-3"])  # the operator's delete
    again, report = fuse(deleted, _another_chair("again"))
    assert report.added == ["office_chair-4"]


def test_the_numbering_survives_saving_and_reading_the_map(tmp_path: Path) -> None:
    scene = _false_chair_removed()
    path = save_scene(scene, tmp_path / "map.json")
    assert json.loads(path.read_text())["last_ids"] == {"office_chair": 2}
    back = load_scene(path)
    assert back.last_ids == {"office_chair": 2}
    _, report = fuse(back, _another_chair("after restart"))
    assert report.added == ["office_chair-3"]
    old_file = json.loads(path.read_text())
    del old_file["last_ids"]  # a file written before the numbering was kept: its objects' numbers count
    assert scene_from_dict(old_file).last_ids == {}
    assert fuse(scene_from_dict(old_file), _another_chair("x"))[1].added == ["office_chair-2"]


@pytest.mark.parametrize("value, field", [([1], "last_ids"), ({"desk": -1}, "last_ids.desk"),
                                          ({"desk": 1.5}, "last_ids.desk"), ({"desk": "3"}, "last_ids.desk"),
                                          ({"desk": True}, "last_ids.desk")])
def test_a_malformed_numbering_is_refused_naming_the_field(value, field: str) -> None:
    with pytest.raises(SceneError) as err:
        scene_from_dict({"version": 1, "last_ids": value})
    assert err.value.field == field


def test_next_id_never_gives_a_number_the_class_had() -> None:
    assert next_id("desk-2", "desk", ["desk-1"]) == "desk-2"  # never had: the mapper's own id stays
    assert next_id("desk-2", "desk", ["desk-1"], {"desk": 5}) == "desk-6"
    assert next_id("desk-7", "desk", ["desk-1"], {"desk": 5}) == "desk-7"
    assert next_id("my desk", "desk", ["desk-1"], {"desk": 5}) == "my desk"  # a scene file's own id, free
    assert id_numbers([SceneObject("desk-4", "desk", (0, 0, 0), (1, 1, 1)),
                       SceneObject("box-9", "cardboard_box", (0, 0, 0), (1, 1, 1))], {"desk": 2}) == {"desk": 4}
