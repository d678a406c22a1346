"""An object's existence weighed as log-odds: detections for it, captures that saw its place and missed it against.

Synthetic captures in the paper's room (world frame, z up [m]); a level camera 0.35 m up, 640 x 480 px, its
pose ``world <- camera`` in the OpenCV optical frame (the helpers of test_map_misses.py).
"""

from __future__ import annotations

import math
from dataclasses import replace

import pytest

from pipeline.mapping.map_existence import HIT, MISS, miss_log_odds, visible_share
from pipeline.mapping.map_fusion import fuse
from pipeline.mapping.map_misses import MIN_MISS_SHARE, MISS_NOTE, is_partial
from pipeline.scene import Scene, SceneObject, Source
from tests.pipeline.mapping.test_map_misses import CHAIR, DESK, _capture, _obj

SUITCASE = (0.45, 0.68, 0.27)
BOX = (0.45, 0.4, 0.45)


def _two_agreeing_false_suitcases() -> Scene:
    """The noisy tour's seed 9: two captures' false boxes that agree on one suitcase. The first is short and low
    (read as an occluded suitcase), the second lies inside the box of a real chair nearer to the camera (read
    as mostly hidden): each shows only part of what it claims, but only the first counts as cut by the
    yaw-sigma rule."""
    a = _capture("a", (1.0, 1.0, 0.35), math.pi / 2 - 0.4,
                 _obj("suitcase-1", "suitcase", (2.5, 3.4, 0.34), SUITCASE, "a", (413, 299, 524, 357)))
    b = _capture("b", (4.2, 0.9, 0.35), math.pi / 2 + 0.5,
                 _obj("office_chair-1", "office_chair", (3.5, 2.5, 0.525), CHAIR, "b", (238, 0, 514, 410)),
                 _obj("suitcase-1", "suitcase", (2.48, 3.5, 0.34), SUITCASE, "b", (259, 213, 352, 305)))
    scene, _ = fuse(Scene(), a)
    scene, _ = fuse(scene, b)
    return scene


def test_two_agreeing_false_detections_go_after_two_captures_see_their_place_empty() -> None:
    scene = _two_agreeing_false_suitcases()
    suitcase = scene.object("suitcase-1")
    used = [s for s in suitcase.history if s.used]
    assert [s.capture for s in used] == ["a", "b"] and all(is_partial(s) for s in used)
    assert not all(s.sigma[2] >= math.pi / 2 for s in used)  # the hidden view is not cut: the old rule kept it
    looks = [_capture(f"look-{k}", (2.5 + 0.05 * k, 1.2, 0.35), math.pi / 2) for k in range(2)]
    once, report = fuse(scene, looks[0], check_consistency=False)
    assert "suitcase-1" in {o.id for o in once.objects} and not report.removed  # 4.5 for, 2.3 against
    twice, report = fuse(once, looks[1], check_consistency=False)
    assert {o.id for o in twice.objects} == {"office_chair-1"}
    assert ("suitcase-1: seen by 2 captures (in part), missed by 2 captures that saw its place: removed"
            in report.notes())


def test_a_real_object_seen_once_and_then_hidden_stays() -> None:
    """A desk seen whole once; later captures look at it from behind a cabinet: they saw nothing of its place."""
    scene, _ = fuse(Scene(), _capture("one", (1.2, 0.8, 0.35), math.pi / 2,
                                      _obj("desk-1", "desk", (1.2, 2.95, 0.375), DESK, "one", (200, 150, 420, 330))))
    cabinet = _obj("office_cabinet-1", "office_cabinet", (1.2, 1.9, 0.6), (1.0, 1.2, 0.5), "one", (150, 0, 480, 480))
    scene = scene.with_objects(list(scene.objects) + [cabinet])
    for k in range(4):
        scene, report = fuse(scene, _capture(f"look-{k}", (1.1 + 0.05 * k, 0.9, 0.35), math.pi / 2),
                             check_consistency=False)
        assert not report.removed
    assert {o.id for o in scene.objects} == {"desk-1", "office_cabinet-1"}
    assert all(s.note != MISS_NOTE for s in scene.object("desk-1").history)


def test_a_look_between_two_boxes_counts_for_the_part_it_shows() -> None:
    """A suitcase seen once in part, then a look through the gap between two nearer boxes: its centre is on a
    clear line of sight (a whole miss by the centre ray alone, which removed it), but the boxes hide its sides:
    a third of it in view is too little to count against it."""
    first = _capture("one", (1.0, 1.0, 0.35), math.pi / 2 - 0.4,
                     _obj("suitcase-1", "suitcase", (2.5, 3.4, 0.34), SUITCASE, "one", (413, 299, 524, 357)))
    scene, _ = fuse(Scene(), first)
    boxes = [_obj(f"cardboard_box-{k + 1}", "cardboard_box", (2.5 + dx, 2.6, 0.34), BOX, "one", None)
             for k, dx in enumerate((-0.25, 0.25))]
    scene = scene.with_objects(list(scene.objects) + boxes)
    look = _capture("look", (2.5, 1.2, 0.35), math.pi / 2)
    share = visible_share(scene.object("suitcase-1"), look.captures[0], boxes)
    assert 0.2 < share < 0.5
    after, report = fuse(scene, look, check_consistency=False)
    assert "suitcase-1" in {o.id for o in after.objects} and not report.removed
    assert share < MIN_MISS_SHARE and all(s.note != MISS_NOTE for s in after.object("suitcase-1").history)


def test_visible_share_in_view_hidden_out_of_range_and_at_the_border() -> None:
    desk = SceneObject("desk-1", "desk", (1.2, 2.95, 0.375), DESK, 0.0)
    cam = _capture("c", (1.2, 0.8, 0.35), math.pi / 2).captures[0]
    assert visible_share(desk, cam, []) == 1.0
    cabinet = SceneObject("office_cabinet-1", "office_cabinet", (1.2, 1.9, 0.6), (1.6, 1.2, 0.5), 0.0)
    assert visible_share(desk, cam, [cabinet]) == 0.0
    assert visible_share(desk, cam, [], far=1.5) == 0.0
    behind = SceneObject("desk-2", "desk", (1.2, -0.5, 0.375), DESK, 0.0)  # behind the camera
    assert visible_share(behind, cam, []) == 0.0
    aside = _capture("c", (1.2, 0.8, 0.35), math.pi / 2 - 0.55).captures[0]  # the desk at the image's left border
    assert 0.2 < visible_share(desk, aside, []) < 0.8


def test_evidence_is_weighed_a_desk_seen_whole_twice_goes_after_four_clean_misses() -> None:
    assert HIT == pytest.approx(4.50, abs=0.01) and MISS == pytest.approx(-2.30, abs=0.01)
    assert miss_log_odds(1.0) == miss_log_odds(0.5) == pytest.approx(MISS) and miss_log_odds(0.0) == 0.0
    assert miss_log_odds(1 / 3) == pytest.approx(math.log(0.4))  # a third in view: found 6 times in 10
    assert 2 * MISS < -HIT < MISS  # one whole view outweighs one clean miss, not two
    desk = Scene()
    for k in range(2):
        desk, _ = fuse(desk, _capture(f"seen-{k}", (1.2 + 0.1 * k, 0.8, 0.35), math.pi / 2,
                                      _obj("desk-1", "desk", (1.2, 2.95, 0.375), DESK, f"seen-{k}", (200, 150, 420, 330))))
    for k in range(4):
        desk, report = fuse(desk, _capture(f"look-{k}", (1.1 + 0.1 * k, 1.0, 0.35), math.pi / 2),
                            check_consistency=False)
        assert bool(report.removed) == (k == 3)
    assert desk.objects == ()


@pytest.mark.parametrize("how", ["pinned", "manual"])
def test_a_pinned_or_operator_placed_object_is_never_removed(how: str) -> None:
    scene, _ = fuse(Scene(), _capture("one", (1.2, 0.8, 0.35), math.pi / 2,
                                      _obj("desk-1", "desk", (1.2, 2.95, 0.375), DESK, "one", (200, 150, 420, 330))))
    desk = scene.object("desk-1")
    desk = replace(desk, pinned=True) if how == "pinned" else replace(desk, source=Source(None, "manual"))
    scene = scene.with_objects([desk])
    for k in range(5):
        scene, report = fuse(scene, _capture(f"look-{k}", (1.1 + 0.05 * k, 1.0, 0.35), math.pi / 2),
                             check_consistency=False)
        assert not report.removed
    assert [o.id for o in scene.objects] == ["desk-1"]
