"""A line of boxes seen along its length (end-on) maps each box once.

From the side of a line of cardboard boxes, looking along it, each box shows only the part its nearer
neighbour leaves: its image box ends where the neighbour's begins, and its centre is placed off across
the ray by up to its extent (the noisy tour, seed 4: every box 0.13-0.16 m towards the camera). With the
narrow gate, the first box's view took its far neighbour, whose own view then found nothing and started
a second copy of it. Synthetic captures in the paper's room (world frame, z up [m]); 640 x 480 px.
"""

from __future__ import annotations

import pytest

from pipeline.mapping.map_fusion import fuse
from pipeline.mapping.observation_sigma import occluded_sides, observation_sigma
from pipeline.scene import Capture, Scene, SceneObject, Sighting, Source

CAM = {"fx": 525.0, "fy": 525.0, "cx": 319.5, "cy": 239.5, "width": 640.0, "height": 480.0}
BOX = (0.45, 0.4, 0.45)
SIDE = (0.4, 5.5, 0.35)
"""The camera behind the line's left end, facing +x: the line (y = 4.0) runs away from it on the right."""


def _mapped(oid: str, pos) -> SceneObject:
    """A box the front captures mapped (3 cm sigma) where the tour's map had it."""
    seen = Sighting(capture="front", position=pos, yaw=0.0, size=BOX, sigma=(0.03, 0.03, 0.1), camera=(3.4, 0.7, 0.35))
    return SceneObject(oid, "cardboard_box", pos, BOX, 0.0, source=Source("front", "depth"), history=(seen,))


def _line() -> Scene:
    """Boxes 6, 7 and 8 of the line's bottom row (true x 2.95, 3.41, 3.86), as mapped from the front."""
    return Scene(objects=(_mapped("cardboard_box-6", (2.95, 4.0, 0.2)), _mapped("cardboard_box-7", (3.36, 3.99, 0.17)),
                          _mapped("cardboard_box-8", (3.76, 3.93, 0.17))),
                 captures=(Capture("front", intrinsics=CAM, camera_position=(3.4, 0.7, 0.35)),))


def _end_on(*, with_nearest: bool = True) -> Scene:
    """The look along the line: each box 0.13-0.16 m off towards the camera, its image box ending where
    its nearer neighbour's begins (the nearest, box 6, cut by the image border)."""
    def obs(oid, pos, bbox):
        return SceneObject(oid, "cardboard_box", pos, BOX, 0.0, source=Source("side", "depth", bbox=bbox))
    objs = [obs("cardboard_box-1", (3.1, 4.12, 0.2), (579, 228, 640, 316))] if with_nearest else []
    objs += [obs("cardboard_box-2", (3.56, 4.13, 0.19), (539, 230, 578, 310)),
             obs("cardboard_box-3", (4.05, 4.16, 0.18), (509, 231, 537, 303))]
    return Scene(objects=tuple(objs), captures=(Capture("side", intrinsics=CAM, camera_position=SIDE),))


def test_a_box_whose_nearer_neighbour_hides_its_side_is_known_across_the_ray_only_to_its_extent() -> None:
    view = _end_on()
    cap = view.captures[0]
    nearest, middle, far = view.objects
    assert [occluded_sides(o, cap, view.objects) for o in view.objects] == [0, 1, 1]
    sig = observation_sigma(far, cap, view.objects)
    assert sig.side_extent == pytest.approx(0.45 / (2 * 3 ** 0.5)) and "1 side behind a nearer cardboard_box" in sig.factors
    assert observation_sigma(far, cap).side_extent == 0.0  # alone in its photo: nothing hides it
    side_by_side = SceneObject("b", "cardboard_box", (4.1, 4.5, 0.2), BOX, 0.0,  # as far: beside it, not in front
                               source=Source("side", "depth", bbox=(538, 231, 590, 303)))
    assert occluded_sides(far, cap, [far, side_by_side]) == 0


def test_a_look_along_a_line_of_boxes_maps_no_box_twice() -> None:
    after, report = fuse(_line(), _end_on())
    assert report.added == [], report.outcomes  # was cardboard_box-9: box 8 mapped a second time
    assert sorted(report.updated) == ["cardboard_box-6", "cardboard_box-7", "cardboard_box-8"]
    got = {o.observation: o.object_id for o in report.outcomes}
    assert got == {"cardboard_box-1": "cardboard_box-6", "cardboard_box-2": "cardboard_box-7",
                   "cardboard_box-3": "cardboard_box-8"}
    assert len(after.objects) == 3


def test_the_wide_gate_is_a_second_try_only() -> None:
    """Where the narrow gate finds an object for every view, a hidden side changes nothing: the look
    without the far box's view associates as the same look with the boxes' image sides apart."""
    near, middle = _end_on().objects[:2]
    apart = SceneObject(middle.id, middle.label, middle.position, BOX, 0.0,
                        source=Source("side", "depth", bbox=(519, 230, 558, 310)))
    cap = _end_on().captures
    _, touching = fuse(_line(), Scene(objects=(near, middle), captures=cap))
    _, separate = fuse(_line(), Scene(objects=(near, apart), captures=cap))
    assert occluded_sides(middle, cap[0], (near, middle)) == 1 and occluded_sides(apart, cap[0], (near, apart)) == 0
    assert [(o.observation, o.object_id) for o in touching.outcomes] == \
        [(o.observation, o.object_id) for o in separate.outcomes]
