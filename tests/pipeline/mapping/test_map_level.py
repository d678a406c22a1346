"""A view that shows a box's top and bottom stays on its own level of a stack; a stack settles together.

The paper's room has a line of cardboard boxes three rows high (0.4 m each: centres at z = 0.2, 0.6, 1.0).
On the noisy extended tour (seed 9) the far-end capture saw a middle-row box cut by the right image border;
the cut widens a view's gate across the ray (x3), vertically too, and the view joined the top-row box above
it (its bottom 0.43 m below that box's), so the middle-row box was later mapped twice. Synthetic objects with
the tour's figures (world frame, z up [m]); images 640 x 480 px.
"""

from __future__ import annotations

import pytest

from pipeline.mapping.map_association import other_level
from pipeline.mapping.map_fusion import fuse
from pipeline.mapping.map_support import settle, supported_z
from pipeline.mapping.observation_sigma import observation_sigma
from pipeline.scene import Capture, Scene, SceneObject, Sighting, Source

CAM = {"fx": 525.0, "fy": 525.0, "cx": 319.5, "cy": 239.5, "width": 640.0, "height": 480.0}
BOX = (0.45, 0.4, 0.45)
FAR_END = (2.5, 7.45, 0.35)
"""The far-end camera, facing -y: the line (y = 4.0) 3.5 m in front of it, its left end on the right."""

TOP_ROW = (0.48, 3.37, 1.02)
"""The top-row box at the line's left end as the map had it before the far-end capture (seed 9)."""


def _top_row_box() -> Scene:
    """The map: one top-row box, from three views (two mostly hidden, one cut), as seed 9 had it."""
    seen = (Sighting("tour-3", (0.14, 3.85, 1.15), -1.65, BOX, (0.45, 0.11, 0.35), (4.13, 1.03, 0.35), 4.95),
            Sighting("tour-5", (1.03, 2.56, 0.78), -0.89, BOX, (0.56, 0.14, 1.57), (2.42, 0.83, 0.35), 2.27),
            Sighting("tour-13", (0.25, 3.81, 1.21), -1.62, BOX, (1.34, 0.34, 1.57), (4.56, 1.64, 0.35), 4.89))
    box = SceneObject("cardboard_box-22", "cardboard_box", TOP_ROW, BOX, -1.63, source=Source("tour-13", "depth"),
                      history=seen)
    return Scene(objects=(box,), captures=())


def _far_end_view(z: float, bbox) -> Scene:
    """The far-end capture's view of the line's left end: a box cut by the right image border."""
    obs = SceneObject("cardboard_box-2", "cardboard_box", (0.48, 4.03, z), BOX, 0.0,
                      source=Source("tour-15", "depth", bbox=bbox))
    return Scene(objects=(obs,), captures=(Capture("tour-15", intrinsics=CAM, camera_position=FAR_END),))


MIDDLE = _far_end_view(0.59, (580.3, 165.4, 639.5, 234.6))
"""Seed 9's view of the middle-row box (true centre z = 0.6) cut by the right border: top and bottom seen."""


def test_a_view_cut_on_the_side_shows_its_level_one_cut_at_the_top_or_bottom_does_not() -> None:
    cap = MIDDLE.captures[0]
    sig = observation_sigma(MIDDLE.objects[0], cap)
    assert sig.cut and sig.partial and sig.level_seen  # cut by the right border, top and bottom in the photo
    below = _far_end_view(0.59, (580.3, 300.0, 639.5, 480.0)).objects[0]  # its bottom edge at the image's
    assert not observation_sigma(below, cap).level_seen
    short = _far_end_view(0.59, (580.3, 214.6, 639.5, 234.6)).objects[0]  # 20 px of a box 53 px high: occluded
    assert not observation_sigma(short, cap).level_seen
    assert not observation_sigma(MIDDLE.objects[0], None).level_seen  # no image size: not known


def test_other_level_compares_the_bottoms_of_floor_standing_objects() -> None:
    view, top = MIDDLE.objects[0], _top_row_box().objects[0]
    assert other_level(view, top)  # bottoms 0.39 and 0.82 m: 0.43 m apart, over 3/4 of 0.4 m
    assert not other_level(_far_end_view(0.80, None).objects[0], top)  # 0.22 m apart: the same row, placed high
    cup = SceneObject("cup-1", "cup", (0.48, 4.03, 0.59), (0.08, 0.1, 0.08), 0.0)
    assert not other_level(cup, SceneObject("cup-2", "cup", (0.48, 4.03, 1.02), (0.08, 0.1, 0.08), 0.0))


def test_a_side_cut_view_of_the_middle_row_does_not_join_the_box_above_it() -> None:
    before = _top_row_box()
    after, report = fuse(before, MIDDLE, check_consistency=False)
    assert report.updated == [], report.outcomes  # was: cardboard_box-22 updated, pulled down to z = 0.96
    assert len(report.added) == 1
    top = next(o for o in after.objects if o.id == "cardboard_box-22")
    assert top.position == before.objects[0].position
    new = next(o for o in after.objects if o.id != "cardboard_box-22")
    assert new.position[2] == pytest.approx(0.59)  # a box with nothing mapped under it: where the view put it


def test_the_same_view_of_the_top_row_still_joins_the_top_row_box() -> None:
    top_view = _far_end_view(1.01, (577.0, 95.0, 638.0, 170.0))
    assert observation_sigma(top_view.objects[0], top_view.captures[0]).level_seen
    _, report = fuse(_top_row_box(), top_view, check_consistency=False)
    assert report.updated == ["cardboard_box-22"], report.outcomes


def _stacked(oid: str, z: float) -> SceneObject:
    seen = Sighting("front", (3.86, 4.0, z), 0.0, BOX, (0.05, 0.02, 0.1), (3.4, 0.7, 0.35), 3.3)
    return SceneObject(oid, "cardboard_box", (3.86, 4.0, z), BOX, 0.0, source=Source("front", "depth"), history=(seen,))


def test_a_box_resting_on_another_within_the_tolerance_is_set_on_it_exactly_unflagged() -> None:
    lower, upper = _stacked("a", 0.2), _stacked("b", 0.64)  # its bottom 0.04 m above the lower box's top
    assert supported_z(upper, [lower]) == (pytest.approx(0.6), "")
    z, why = supported_z(_stacked("b", 0.7), [lower])  # 0.1 m above it: a correction, flagged
    assert z == pytest.approx(0.6) and why.startswith("set on a")
    assert supported_z(_stacked("b", 0.6), [lower]) is None  # on it already
    assert supported_z(_stacked("a", 0.18), []) == (pytest.approx(0.2), "")  # 2 cm in the floor: set on it


def test_the_boxes_on_a_touched_box_settle_with_it() -> None:
    """Seed 2's tour: a middle-row box mapped 0.05 m high, the top-row box on it; a view of the bottom box
    alone left both where they were, too high (the top one's error 0.067 -> 0.081 m)."""
    objects = [_stacked("bottom", 0.17), _stacked("middle", 0.64), _stacked("top", 1.03)]
    out = settle(objects, {"bottom"})
    assert [o.position[2] for o in objects] == [pytest.approx(0.2), pytest.approx(0.6), pytest.approx(1.0)]
    assert out == [] and all(o.flags == () for o in objects)  # each within the tolerance of its support
    beside = [_stacked("bottom", 0.17), SceneObject("other", "cardboard_box", (4.5, 4.0, 0.64), BOX, 0.0)]
    settle(beside, {"bottom"})
    assert beside[1].position[2] == 0.64  # not on the moved box: left alone


def test_a_middle_row_box_in_the_map_settles_when_a_capture_sees_the_box_under_it() -> None:
    scene = Scene(objects=(_stacked("cardboard_box-1", 0.64), _stacked("cardboard_box-2", 1.03)), captures=())
    view = SceneObject("cardboard_box-3", "cardboard_box", (3.86, 4.0, 0.19), BOX, 0.0,
                       source=Source("front-2", "depth", bbox=(495.0, 255.0, 601.0, 314.0)))
    after, report = fuse(scene, Scene(objects=(view,), captures=(Capture("front-2", intrinsics=CAM,
                                                                            camera_position=(3.4, 0.7, 0.35)),)),
                         check_consistency=False)
    assert report.added == ["cardboard_box-3"], report.outcomes
    z = {o.id: o.position[2] for o in after.objects}
    assert z == {"cardboard_box-3": pytest.approx(0.2), "cardboard_box-1": pytest.approx(0.6),
                 "cardboard_box-2": pytest.approx(1.0)}
