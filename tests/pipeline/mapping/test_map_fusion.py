"""Map fusion over captures (pipeline/mapping/map_fusion.py), against the simulator's hidden room (issue 12).

Captures are rendered by the simulated robot and mapped with ground-truth perception through the real
Mapper, as the console does without model weights; world frame, z up [m].
"""

from __future__ import annotations

import math
from dataclasses import replace

import pytest

from console.link.sim import SimRobot
from console.link.world import paper_room
from console.session.mapping_job import ground_truth_bundle_for
from pipeline.catalog import default_catalog
from pipeline.camera.geometry import Pose
from pipeline.mapping.map_fusion import FusionConfig, fuse
from pipeline.mapper import Mapper
from pipeline.scene import Capture, Scene, SceneError, SceneObject, Source, scene_from_dict, scene_from_json, scene_to_dict, scene_to_json
from planner.grid import CellState, Workspace, build_grid

TRUTH = {o.id: o for o in paper_room().objects}
START = (2.5, 0.7, math.pi / 2)
LEFT = (2.5, 0.7, math.pi / 2 + 0.55)  # desk-1 and chair-1 whole in view
CLOSE_UP = (0.8, 2.38, math.pi / 2)  # the camera 0.07 m from desk-1's front
CAM = {"fx": 320.0, "fy": 320.0, "cx": 320.0, "cy": 240.0, "width": 640.0, "height": 480.0}


def capture(pose: tuple[float, float, float], cid: str, world: Scene | None = None) -> Scene:
    robot = SimRobot(world=world, start=Pose.from_xyz_yaw(pose[0], pose[1], 0.0, pose[2]), manual_clock=True)
    robot.connect()
    try:
        shot = robot.capture()
    finally:
        robot.close()
    with Mapper(ground_truth_bundle_for(shot), default_catalog()) as mapper:
        return mapper.run(shot.image, shot.intrinsics, shot.mount, shot.robot_pose, capture_id=cid).scene


def nearest(scene: Scene, truth_id: str) -> tuple[SceneObject, float]:
    t = TRUTH[truth_id]
    o = min((o for o in scene.objects if o.label == t.label), key=lambda o: math.dist(o.position, t.position))
    return o, math.dist(o.position, t.position)


def map_errors(scene: Scene) -> tuple[list[float], dict[str, int]]:
    """3D centre error [m] of every mapped object against the nearest hidden one of its label (within
    1 m), and how many mapped objects each hidden object got."""
    errors, count = [], {}
    for m in scene.objects:
        t = min((t for t in TRUTH.values() if t.label == m.label), key=lambda t: math.dist(t.position, m.position))
        e = math.dist(t.position, m.position)
        if e < 1.0:
            errors.append(e)
            count[t.id] = count.get(t.id, 0) + 1
    return errors, count


def median(v: list[float]) -> float:
    s = sorted(v)
    return 0.5 * (s[(len(s) - 1) // 2] + s[len(s) // 2])


def test_a_close_up_that_sees_only_the_desk_does_not_drag_it() -> None:
    scene, _ = fuse(Scene(), capture(LEFT, "left"))
    desk, before = nearest(scene, "desk-1")
    close = capture(CLOSE_UP, "close")
    seen = [o for o in close.objects if o.label == "desk"]
    assert seen and math.dist(seen[0].position, TRUTH["desk-1"].position) > 0.3  # the bad view is real
    fused, report = fuse(scene, close)
    assert fused.object(desk.id).position == desk.position
    assert len([o for o in fused.objects if o.label == "desk"]) == len([o for o in scene.objects if o.label == "desk"])
    rejected = [o for o in report.rejected if o.label == "desk"]
    assert rejected and "camera too close" in rejected[0].reason and rejected[0].object_id == desk.id
    assert fused.object(desk.id).history[-1].used is False  # recorded in its history, not used
    assert any("camera too close" in n for n in report.notes())


def _seen_by(cid: str, label: str, pos, yaw: float, bbox, camera=(1.2, 0.8, 0.35), method: str = "depth") -> Scene:
    obj = SceneObject("x-1", label, pos, TRUTH["desk-1"].size if label == "desk" else TRUTH["office_chair-1"].size,
                      yaw, source=Source(cid, method, bbox=bbox))
    return Scene(objects=(obj,), captures=(Capture(cid, intrinsics=CAM, camera_position=camera),))


def test_a_border_sliver_does_not_move_a_desk_and_a_cut_view_barely_moves_a_chair() -> None:
    desk_t, chair_t = TRUTH["desk-1"], TRUTH["office_chair-1"]
    good = Scene(objects=(
        replace(desk_t, id="desk-1", source=Source("c1", "depth", bbox=(200.0, 150.0, 420.0, 330.0))),
        replace(chair_t, id="office_chair-1", source=Source("c1", "depth", bbox=(300.0, 100.0, 380.0, 330.0))),
    ), captures=(Capture("c1", intrinsics=CAM, camera_position=(1.3, 0.6, 0.35)),))
    scene, _ = fuse(Scene(), good)
    desk, chair = scene.object("desk-1"), scene.object("office_chair-1")
    # the desk seen only as a sliver 613-640 px of 640, its estimate 0.5 m and 50 degrees off
    sliver = _seen_by("c2", "desk", (desk_t.position[0] + 0.5, desk_t.position[1], 0.375),
                      desk_t.yaw + math.radians(50), (613.0, 120.0, 640.0, 340.0))
    after, report = fuse(scene, sliver)
    assert after.object("desk-1").position == desk.position and after.object("desk-1").yaw == desk.yaw
    assert "sliver at the image border" in report.rejected[0].reason
    # a chair cut by the left border (67 px wide: a real view, but a biased one) mapped 0.55 m off
    cut = _seen_by("c3", "office_chair", (chair_t.position[0] - 0.3, chair_t.position[1] + 0.46, 0.5),
                   chair_t.yaw + 1.0, (0.0, 26.0, 67.0, 365.0))
    after, report = fuse(after, cut)
    assert report.updated == ["office_chair-1"] and len([o for o in after.objects if o.label == "office_chair"]) == 1
    moved = math.dist(after.object("office_chair-1").position, chair.position)
    assert moved < 0.1  # a cut view weighs 1/9 of a whole one
    assert abs(after.object("office_chair-1").yaw - chair.yaw) < math.radians(2)  # its heading says nothing


def test_the_cabinet_behind_the_box_line_rests_on_the_floor_without_a_correction() -> None:
    obs = capture(START, "start")
    seen = [o for o in obs.objects if o.label == "office_cabinet"]
    # only its top is visible: the mapper places it from that top edge (it was 1.87 m up, "floating")
    assert seen and abs(seen[0].position[2] - TRUTH["office_cabinet-1"].position[2]) <= 0.1
    scene, report = fuse(Scene(), obs)
    cab, _ = nearest(scene, "office_cabinet-1")
    assert abs(cab.position[2] - TRUTH["office_cabinet-1"].position[2]) <= 0.1
    assert not any(oid == cab.id and "floating" in what for oid, what in report.corrections)
    ws = Workspace()
    floor = ws.cell_of((4.75, 6.2, 0.1))  # the hidden cabinet's centre, just above the floor
    assert build_grid(scene, ws, 0.35).state_at(floor) is CellState.OCCUPIED
    for o in scene.objects:  # every floor object of the map stands on the floor or on another object
        if o.label in ("desk", "office_chair", "office_cabinet"):
            assert abs(o.position[2] - o.size[1] / 2) <= 0.1, o


def test_a_floating_cabinet_is_set_on_the_floor_and_flagged() -> None:
    """A floor object placed well above the floor (a lower part hidden and not recognised) is set on it."""
    cab = SceneObject("office_cabinet-1", "office_cabinet", (2.5, 6.2, 1.87), (0.8, 1.85, 0.42),
                      source=Source("c1", "depth"))  # away from the walls (the workspace's edge closes its own band)
    scene, report = fuse(Scene(), Scene(objects=(cab,), captures=(Capture("c1"),)))
    got = scene.object("office_cabinet-1")
    assert got.position[2] == pytest.approx(got.size[1] / 2)
    assert got.flags and "floating" in got.flags[0]
    assert any(oid == got.id and "floating" in what for oid, what in report.corrections)
    # the planner no longer walks through its real footprint (the floating estimate left the floor free)
    ws = Workspace()
    floor = ws.cell_of((2.5, 6.2, 0.1))
    assert build_grid(Scene(objects=(cab,)), ws, 0.35).state_at(floor) is CellState.FREE
    assert build_grid(scene, ws, 0.35).state_at(floor) is CellState.OCCUPIED


def test_a_box_on_a_desk_stays_on_the_desk() -> None:
    desk = SceneObject("desk-1", "desk", (2.0, 3.0, 0.375), (1.4, 0.75, 0.7), source=Source("c1", "ground_truth"))
    box = SceneObject("box", "cardboard_box", (2.1, 3.0, 0.75 + 0.2 + 0.08), (0.45, 0.4, 0.45),
                      source=Source("c1", "depth"))
    scene, report = fuse(Scene(), Scene(objects=(desk, box), captures=(Capture("c1"),)))
    assert scene.object("box").position[2] == pytest.approx(0.95)  # on the desk's top, not the floor
    assert "set on desk-1" in scene.object("box").flags[0]


def test_a_chair_moved_by_hand_is_not_duplicated_by_the_next_capture() -> None:
    scene, _ = fuse(Scene(), capture(START, "start"))
    chair, err = nearest(scene, "office_chair-1")
    # the first estimate is off (0.14 m: cut by the border); the operator moves the chair to its right place
    assert err > 0.1
    truth = TRUTH["office_chair-1"]
    scene = scene.with_objects([o.moved(truth.position, truth.yaw) if o.id == chair.id else o for o in scene.objects])
    again, report = fuse(scene, capture(LEFT, "left"))
    chairs = [o for o in again.objects if o.label == "office_chair"
              and math.dist(o.position[:2], truth.position[:2]) < 1.0]
    assert [o.id for o in chairs] == [chair.id]
    assert again.object(chair.id).position == truth.position
    recorded = [o for o in report.outcomes if o.action == "recorded"]
    assert [o.object_id for o in recorded] == [chair.id]
    assert again.object(chair.id).history[-1].capture == "left" and not again.object(chair.id).history[-1].used


def _other_room() -> Scene:
    def obj(oid: str, label: str, x: float, y: float, size, yaw: float = 0.0) -> SceneObject:
        return SceneObject(oid, label, (x, y, size[1] / 2), size, yaw, source=Source(method="ground_truth"))

    return Scene(objects=(
        obj("sofa-1", "sofa", 1.2, 3.3, (2.0, 0.85, 0.9)),
        obj("office_cabinet-1", "office_cabinet", 3.0, 2.4, (0.8, 1.85, 0.42)),
        obj("table-1", "table", 4.0, 4.2, (0.9, 0.75, 1.6), 1.2),
        obj("trash_bin-1", "trash_bin", 2.2, 2.0, (0.4, 0.65, 0.4)),
        obj("suitcase-1", "suitcase", 0.6, 1.9, (0.45, 0.68, 0.27)),
        obj("plant-1", "plant", 3.8, 1.9, (0.4, 0.8, 0.4)),
    ))


def test_two_rooms_at_the_same_pose_are_not_merged_silently() -> None:
    scene, _ = fuse(Scene(), capture(START, "room-a"))
    other = capture(START, "room-b", world=_other_room())
    assert len(other.objects) >= 3
    held, report = fuse(scene, other)
    assert report.held_back and "another room" in report.held_back
    assert held is scene and report.added == [] and report.updated == []
    assert report.notes()[0].startswith("capture held back")
    # the operator can still merge it
    merged, report = fuse(scene, other, check_consistency=False)
    assert report.held_back is None and len(merged.objects) > len(scene.objects)
    # the same room from another pose agrees with the map
    _, report = fuse(scene, capture(LEFT, "room-a-again"))
    assert report.held_back is None and report.updated


TOUR = [START, (1.0, 1.0, math.pi / 2 - 0.4), (4.2, 0.9, math.pi / 2 + 0.5), LEFT, CLOSE_UP,
        (2.5, 0.7, math.pi / 2 - 0.5), (2.5, 1.2, math.pi / 2)]


def test_the_map_error_does_not_grow_over_captures_from_several_poses() -> None:
    scene = Scene()
    medians = []
    for k, pose in enumerate(TOUR):
        scene, report = fuse(scene, capture(pose, f"tour-{k}"))
        assert report.held_back is None
        errors, count = map_errors(scene)
        medians.append(median(errors))
        assert max(count.values()) == 1, {t: n for t, n in count.items() if n > 1}  # no duplicates
    assert all(m <= medians[0] + 0.02 for m in medians), medians
    assert medians[-1] < medians[0], medians


def test_yaw_is_fused_modulo_a_half_turn() -> None:
    def seen(cid: str, yaw: float) -> Scene:
        o = SceneObject("d", "desk", (2.0, 3.0, 0.375), (1.4, 0.75, 0.7), yaw, source=Source(cid, "depth"))
        return Scene(objects=(o,), captures=(Capture(cid),))

    scene, _ = fuse(Scene(), seen("a", 0.1))
    scene, _ = fuse(scene, seen("b", math.pi - 0.1))  # the same heading, the box turned half-way
    yaw = scene.objects[0].yaw
    assert min(abs(yaw), abs(abs(yaw) - math.pi)) < 0.01  # not pi / 2, the naive mean
    # the same capture fused again replaces its own view (it counts once)
    again, _ = fuse(scene, seen("b", math.pi - 0.1))
    assert len(again.objects[0].history) == 2


def test_history_and_pins_survive_the_scene_file_and_bad_input_is_named() -> None:
    scene, _ = fuse(Scene(), capture(LEFT, "left"))
    scene = scene.with_objects([replace(o, pinned=True) if i == 0 else o for i, o in enumerate(scene.objects)])
    back = scene_from_json(scene_to_json(scene))
    assert back.objects[0].pinned and back.objects[0].is_pinned
    assert [len(o.history) for o in back.objects] == [len(o.history) for o in scene.objects]
    assert back.objects[1].history[0].capture == "left"
    bad = Scene(objects=(SceneObject("a", "desk", (1.0, 1.0, 0.4), (1.4, 0.75, 0.7), frame="camera"),))
    with pytest.raises(SceneError, match=r"objects\[0\]\.frame"):
        fuse(Scene(), bad)
    with pytest.raises(ValueError, match="FusionConfig.gate"):
        FusionConfig(gate=float("nan"))
    data = scene_to_dict(back)
    data["objects"][0]["history"][0]["sigma"][0] = -0.1
    with pytest.raises(SceneError, match=r"objects\[0\]\.history\[0\]\.sigma\[0\]: must be > 0"):
        scene_from_dict(data)
