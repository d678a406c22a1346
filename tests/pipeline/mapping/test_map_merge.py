"""One chair mapped once: the noisy tour's duplicate chair as a small fixture.

In the noisy tour (seed 2) a capture saw office chair 1 whole and, beside it, a false detection of the
same class: a short box low in the image, read as an occluded chair 0.4 m away. It became a second
chair, and the later captures split their views of the real chair between the two. Synthetic
observations in the paper's room (world frame, z up [m]); the camera 640 x 480 px.
"""

from __future__ import annotations

import math

from pipeline.mapping.map_fusion import fuse
from pipeline.mapping.map_merge import overlapping, seen_apart
from pipeline.mapping.observation_sigma import observation_sigma
from pipeline.scene import Capture, Scene, SceneObject, Source

CAM = {"fx": 525.0, "fy": 525.0, "cx": 319.5, "cy": 239.5, "width": 640.0, "height": 480.0}
CHAIR = (0.62, 1.05, 0.62)
"""An office chair's ``(w, h, l)`` [m]."""
TRUE_CHAIR = (1.45, 2.3, 0.525)


def _chair(oid: str, pos, cid: str, bbox) -> SceneObject:
    return SceneObject(oid, "office_chair", pos, CHAIR, 0.0, source=Source(cid, "depth", bbox=bbox))


def _capture(cid: str, camera, *objects: SceneObject) -> Scene:
    return Scene(objects=objects, captures=(Capture(cid, intrinsics=CAM, camera_position=camera),))


def _the_bad_capture() -> Scene:
    """From (2.42, 0.83) facing the desk: the chair whole (mapped 0.33 m off), and a false chair: a
    98-px box low in the image whose depth (the floor's) puts it 0.45 m beside the real one."""
    whole = _chair("office_chair-1", (1.26, 2.63, 0.525), "bad", (198, 54, 395, 363))
    false = _chair("office_chair-2", (1.75, 2.33, 0.525), "bad", (375, 331, 489, 429))
    return _capture("bad", (2.42, 0.83, 0.35), whole, false)


def test_the_false_box_reads_as_a_partial_view() -> None:
    view = _the_bad_capture()
    whole, false = view.objects
    assert not observation_sigma(whole, view.captures[0], view.objects).partial
    assert observation_sigma(false, view.captures[0], view.objects).partial  # occluded: far too short for a chair


def test_a_chair_mapped_twice_is_merged_once_a_capture_shows_the_two_overlap() -> None:
    """Two far captures that each saw one copy (the other out of their view); a near view between them
    pulls one onto the other: one chair, the older id, both histories."""
    scene, _ = fuse(Scene(), _capture("a", (1.2, -1.5, 0.35), _chair("office_chair-1", (1.2, 2.55, 0.525), "a",
                                                                      (250, 60, 420, 360))))
    scene, report = fuse(scene, _capture("b", (1.8, -1.7, 0.35), _chair("office_chair-1", (1.8, 2.3, 0.525), "b",
                                                                         (200, 60, 370, 360))))
    assert report.added == ["office_chair-2"]  # 0.65 m apart: beyond the gate, no overlap
    between = _chair("office_chair-1", (1.45, 2.35, 0.525), "c", (250, 60, 420, 360))
    after, report = fuse(scene, _capture("c", (1.5, 1.2, 0.35), between))
    assert [o.id for o in after.objects] == ["office_chair-1"]
    assert report.merged == (("office_chair-1", "office_chair-2"),)
    assert "office_chair-2 merged into office_chair-1: they overlapped (one object mapped twice)" in report.notes()
    chair = after.object("office_chair-1")
    assert {s.capture for s in chair.history} == {"a", "b", "c"}
    assert math.dist(chair.position[:2], TRUE_CHAIR[:2]) < 0.15


def test_two_chairs_one_capture_saw_apart_are_not_merged() -> None:
    """Two whole detections in one photo are two chairs, even where their estimates overlap."""
    a = _chair("office_chair-1", (1.3, 2.3, 0.525), "one", (100, 60, 300, 360))
    b = _chair("office_chair-2", (1.85, 2.3, 0.525), "one", (320, 60, 520, 360))
    scene, _ = fuse(Scene(), _capture("one", (1.6, 0.5, 0.35), a, b))
    assert seen_apart(scene.objects[0], scene.objects[1])
    pulled = _chair("office_chair-1", (1.6, 2.3, 0.525), "two", (250, 60, 450, 360))
    after, report = fuse(scene, _capture("two", (1.6, 0.6, 0.35), pulled))
    assert overlapping(after.objects[0], after.objects[1], 0.3, 0.5)  # the estimates now overlap
    assert len(after.objects) == 2 and report.merged == ()
