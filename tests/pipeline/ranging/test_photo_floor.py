"""The photo's floor in ranging: a given pose checked (warning with numbers, contact widened, nothing moved) or
found (no pose); the depth sigma pooled over few references; implausibly wide boxes down-weight the size prior."""

from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np
import pytest

from pipeline.ranging.distance import DistanceError, Truncation, pooled_sigma
from pipeline.ranging.fusion import Cue
from pipeline.ranging.ground_contact import GroundModel, ground_contact_cue
from pipeline.ranging.photo_floor import DISAGREE_SIGMAS, contacts_of, decide_floor, floor_spread
from pipeline.ranging.placement import geometric_estimate
from pipeline.ranging.size_prior import size_prior_cue, too_wide
from tests.pipeline.camera.test_floor_fit import INTR, floor_contacts, gravity

PERSON = (0.65, 1.75, 0.70)
SPREAD = (0.15, 0.07, 0.15)


def fake_objects(g: np.ndarray, H: float, points: list[tuple[float, float]], score: float = 0.9) -> list:
    """Measured-object stand-ins standing on the floor at ``points`` with exact size-prior distances."""
    objs = []
    for c in floor_contacts(g, H, points):
        u, v = c.uv
        half = (PERSON[0] + PERSON[2]) / math.pi
        sp = Cue("size_prior", c.depth + half, 0.07 * (c.depth + half))
        objs.append(SimpleNamespace(
            skipped=None, on_floor=True, size_known=True, truncation=Truncation(), size=PERSON, spread=SPREAD,
            detection=SimpleNamespace(box=(u - 10, v - 60, u + 10, v), label="person", score=score),
            cue=lambda name, sp=sp: sp if name == "size_prior" else None))
    return objs


POINTS = [(-1.5, 4.0), (0.0, 6.0), (1.0, 8.0), (2.0, 11.0), (-2.0, 14.0)]


def test_a_right_given_pose_is_kept_without_warning() -> None:
    g, H = gravity(5.0), 1.5
    given = GroundModel(tuple(g), H)
    d = decide_floor(fake_objects(g, H, POINTS), INTR, given, True, g, H, None, 0.05)
    assert d.warning is None and not d.remeasure and d.gravity is None
    assert all(x is given for x in d.grounds) and "the photo agrees" in d.note


def test_a_wrong_given_pose_is_named_and_only_widens_the_contact() -> None:
    g, H = gravity(5.0), 1.5  # the truth; given: level and 1.1 m
    given = GroundModel((0.0, 1.0, 0.0), 1.1)
    objs = fake_objects(g, H, POINTS)
    d = decide_floor(objs, INTR, given, True, (0.0, 1.0, 0.0), 1.1, None, 0.05)
    assert d.warning is not None and d.remeasure and d.gravity is None  # the given gravity stays: nothing moves
    assert ("pitch 4.9 deg" in d.warning or "pitch 5.0 deg" in d.warning) and "(given 0.0)" in d.warning and "(given 1.10 m)" in d.warning
    assert "5 object contacts" in d.warning and "ground contact down-weighted" in d.warning
    widened = d.grounds[0]
    assert widened.gravity_cam == given.gravity_cam and widened.camera_height == given.camera_height
    box = objs[3].detection.box
    plain = ground_contact_cue(box, Truncation(), given, INTR, 0.4, 0.1, 0.87)[0]
    wide = ground_contact_cue(box, Truncation(), widened, INTR, 0.4, 0.1, 0.87)[0]
    assert wide.distance == pytest.approx(plain.distance) and wide.sigma > 2 * plain.sigma
    # the scene file's reason for this cue (source.down_weighted)
    assert not plain.down_weighted and wide.down_weighted.startswith("the photo's floor disagrees with the given "
                                                                     "camera pose by ")


def test_without_a_pose_the_floor_comes_from_the_other_objects() -> None:
    g, H = gravity(15.0), 1.4
    objs = fake_objects(g, H, POINTS)
    d = decide_floor(objs, INTR, None, False, (0.0, 1.0, 0.0), None, None, 0.05)
    assert d.remeasure and d.gravity is not None and d.estimate is not None
    assert abs(math.degrees(math.acos(float(np.dot(d.gravity, g))))) < 1.5
    assert "camera pose not given: floor from the photo" in d.note
    for obj, ground in zip(objs, d.grounds):  # each judged on the floor of the others (4 contacts)
        assert ground is not None and ground.floor is not None and ground.floor.n_contacts == 4
    # low-score detections are not evidence of the floor; nothing then: level, no floor cue
    assert contacts_of(fake_objects(g, H, POINTS, score=0.3))[0] == []
    none = decide_floor(fake_objects(g, H, POINTS, score=0.3), INTR, None, False, (0.0, 1.0, 0.0), None, None, 0.05)
    assert none.gravity is None and all(x is None for x in none.grounds) and "level camera assumed" in none.note


def test_the_check_threshold_is_the_99_percent_chi_square_of_three() -> None:
    assert DISAGREE_SIGMAS == pytest.approx(math.sqrt(11.34), abs=0.05)


def test_few_references_cannot_make_the_depth_map_look_exact() -> None:
    assert pooled_sigma(0.07, 3, 0.3) == pytest.approx(math.sqrt((3 * 0.09 + 3 * 0.0049) / 6))
    assert pooled_sigma(0.07, 26, 0.3) < 0.13  # many references: what they show
    assert pooled_sigma(0.5, 0, 0.3) == pytest.approx(0.3)
    with pytest.raises(DistanceError, match="measured"):
        pooled_sigma(float("nan"), 3, 0.3)


def test_a_box_too_wide_for_its_class_down_weights_the_size_prior() -> None:
    g = gravity(0.0)
    upright = (600.0, 200.0, 640.0, 300.0)  # 0.4 wide for 1.0 tall: a standing person
    crouching = (600.0, 250.0, 700.0, 300.0)  # twice as wide as tall: not a standing person's box
    assert too_wide(upright, PERSON, SPREAD, (INTR.fx, INTR.fy)) == 1.0
    k = too_wide(crouching, PERSON, SPREAD, (INTR.fx, INTR.fy))
    assert k > 2.0
    for box, widened in ((upright, False), (crouching, True)):
        est = geometric_estimate(box, PERSON, INTR, Truncation(), g, "box_fit")
        plain = size_prior_cue(est, box, Truncation(), PERSON, SPREAD)
        checked = size_prior_cue(est, box, Truncation(), PERSON, SPREAD, focal=(INTR.fx, INTR.fy))
        assert checked.distance == plain.distance
        assert (checked.sigma > 2 * plain.sigma) is widened
        assert ("size prior down-weighted: the box is" in checked.note) is widened


def test_people_on_ground_higher_than_the_cameras_widen_the_contact_instead_of_moving() -> None:
    """The street scene: people stand 0.4 m above the camera's floor plane; their contacts read them far."""
    g = gravity(0.0)
    given = GroundModel(tuple(g), 1.5)
    crowd = fake_objects(g, 1.1, [(-3.0, 13.0), (-1.5, 15.5), (0.0, 17.0), (1.5, 15.0), (3.0, 20.0)])
    d = decide_floor(crowd, INTR, given, True, g, 1.5, None, 0.05)
    assert d.remeasure and d.gravity is None and "off its plane: ground-contact sigma widened" in d.note
    box = crowd[1].detection.box
    before = ground_contact_cue(box, Truncation(), given, INTR, 0.43, 0.1, 0.87)[0]
    after = ground_contact_cue(box, Truncation(), d.grounds[1], INTR, 0.43, 0.1, 0.87)[0]
    size = crowd[1].cue("size_prior")
    assert after.distance == pytest.approx(before.distance)  # not moved
    assert (before.distance - size.distance) / math.hypot(before.sigma, size.sigma) > 1.5  # it out-voted
    assert (after.distance - size.distance) / math.hypot(after.sigma, size.sigma) < 1.0
    # the same crowd on the camera's floor: nothing to widen
    level = decide_floor(fake_objects(g, 1.5, [(-3.0, 13.0), (-1.5, 15.5), (0.0, 17.0), (1.5, 15.0), (3.0, 20.0)]),
                         INTR, given, True, g, 1.5, None, 0.05)
    assert not level.remeasure and all(x is given for x in level.grounds)
    assert floor_spread(contacts_of(crowd)[0][:2], g, 1.5, INTR) == 0.0  # two objects cannot tell


def test_a_side_cut_box_s_contact_may_be_hidden_by_the_border() -> None:
    from pipeline.ranging.ranger import Ranger

    def obj(box, trunc):
        gc = Cue("ground_contact", 5.0, 0.3)
        return SimpleNamespace(skipped=None, detection=SimpleNamespace(box=box, label="cabinet"), truncation=trunc,
                               contact_hidden_by=None, cue=lambda name: gc if name == "ground_contact" else None)

    cut, whole = obj((0.0, 100.0, 200.0, 400.0), Truncation(left=True)), obj((500.0, 100.0, 700.0, 400.0), Truncation())
    Ranger.mark_hidden_contacts([cut, whole])
    assert cut.contact_hidden_by == "image border" and whole.contact_hidden_by is None
