"""The simulated robot: kinematics in time, occupancy, state stream, camera, photo folders."""

from __future__ import annotations

import json
import math
import time
from pathlib import Path

import cv2
import numpy as np
import pytest

from console.app import wait_until
from console.link import LinkError, open_link
from console.link.base import Mode, RobotState, RunStatus
from console.link.captures import CapturesError, CapturesFolder
from console.link.sim import SimConfig, SimRobot
from console.link.world import BOX_LINE_Y, BOX_SIZE, DEFAULT_START, SEARCH_GOAL, paper_room
from pipeline.camera.geometry import Pose, camera_pose_in_world
from planner.grid import Workspace
from planner.mission import MissionSegment, SegmentKind

WALK, TAKEOFF, FLY, LAND = SegmentKind.WALK, SegmentKind.TAKEOFF, SegmentKind.FLY, SegmentKind.LAND


def _manual(start: Pose = DEFAULT_START, **cfg: float) -> SimRobot:
    robot = SimRobot(start=start, config=SimConfig(**cfg), manual_clock=True)
    robot.connect()
    return robot


def _run_until_done(robot: SimRobot, run, limit: float = 60.0, dt: float = 0.01) -> float:
    """Step the manual clock until the run finishes; returns the simulated time it took."""
    t0 = robot.sim_time
    while not run.done and robot.sim_time - t0 < limit:
        robot.step(dt)
    return robot.sim_time - t0


# --- the hidden world ----------------------------------------------------------------------------


def test_paper_room_has_the_papers_objects_and_a_closed_box_line() -> None:
    world = paper_room()
    labels = [o.label for o in world.objects]
    for label, n in (("desk", 2), ("office_chair", 2), ("suitcase", 2), ("compressor", 1),
                     ("office_cabinet", 1), ("robot_dog", 1)):
        assert labels.count(label) == n, label
    boxes = [o for o in world.objects if o.label == "cardboard_box"]
    # stacked about 1.2 m high, on the line y = 4 m, from wall to wall without a walkable gap
    assert max(o.position[2] + o.size[1] / 2 for o in boxes) == pytest.approx(1.2, abs=0.02)
    assert all(abs(o.position[1] - BOX_LINE_Y) < 0.05 for o in boxes)
    bottom = sorted((o.position[0] - BOX_SIZE[2] / 2, o.position[0] + BOX_SIZE[2] / 2)
                    for o in boxes if o.position[2] < BOX_SIZE[1])
    assert bottom[0][0] < 0.05 and bottom[-1][1] > 4.95
    assert max(b[0] - a[1] for a, b in zip(bottom, bottom[1:])) < 0.05
    dog = next(o for o in world.objects if o.label == "robot_dog")
    assert dog.position[1] > BOX_LINE_Y + 1.0  # hidden behind the line
    assert all(o.frame == "world" and o.source.method == "ground_truth" for o in world.objects)


# --- kinematics ----------------------------------------------------------------------------------


@pytest.mark.parametrize("speed", [0.5, 1.0])
def test_walking_takes_distance_over_speed(speed: float) -> None:
    robot = _manual(walk_speed=speed)
    run = robot.run_segment(MissionSegment(WALK, ((2.5, 0.7, 0.0), (2.5, 2.7, 0.0))))  # straight ahead
    took = _run_until_done(robot, run)
    assert run.status is RunStatus.DONE
    assert took == pytest.approx(2.0 / speed, abs=0.03)
    st = robot.latest_state()
    assert st.position == pytest.approx((2.5, 2.7, 0.0), abs=1e-6)
    assert st.mode is Mode.IDLE and st.landed


def test_the_robot_turns_to_face_where_it_walks() -> None:
    robot = _manual(walk_speed=0.5, yaw_rate=math.radians(90))
    run = robot.run_segment(MissionSegment(WALK, ((2.5, 0.7, 0.0), (3.5, 0.7, 0.0))))  # to the right (+x)
    took = _run_until_done(robot, run)
    assert took == pytest.approx(1.0 + 1.0 / 0.5, abs=0.03)  # 90 degree turn, then 1 m
    assert robot.latest_state().yaw == pytest.approx(0.0, abs=1e-6)


def test_walking_into_a_hidden_object_stops_at_contact_without_naming_it() -> None:
    robot = _manual()
    robot.run_segment(MissionSegment(WALK, ((2.5, 0.7, 0.0), (2.55, 3.2, 0.0))))
    robot.run_for(10.0)
    run = robot.run_segment(MissionSegment(WALK, ((2.55, 3.2, 0.0), (2.55, 5.5, 0.0))))  # through the boxes
    _run_until_done(robot, run)
    assert run.status is RunStatus.FAILED
    assert "walking stopped: contact with an unmapped obstacle ahead at (" in run.error
    assert "cardboard_box" not in run.error and "box-" not in run.error  # the hidden world is not named
    y = robot.latest_state().position[1]
    face = BOX_LINE_Y - BOX_SIZE[2] / 2  # the near face of the line
    radius = robot.config.body_radius
    assert face - radius - 0.06 <= y < face - radius  # stopped where its body touches, not before
    # a target inside an object is not refused up front: the robot moves until it touches
    run = robot.run_segment(MissionSegment(WALK, ((2.55, y, 0.0), (2.5, BOX_LINE_Y, 0.0))))
    assert not run.done
    _run_until_done(robot, run)
    assert run.status is RunStatus.FAILED and "contact with an unmapped obstacle ahead" in run.error
    robot.run_for(0.1)
    said = [t for _, t in robot.latest_state().messages]  # the robot tells the operator, as an autopilot would
    assert said[-1].startswith("ERROR: ") and "contact with an unmapped obstacle ahead" in said[-1]
    assert not any("box" in t or "occupies" in t for t in said)


def test_takeoff_flight_and_landing_take_time_and_report_modes() -> None:
    robot = _manual(spool_time=1.0, climb_rate=0.5, fly_speed=1.0, descent_rate=0.25, settle_time=0.5)
    modes: list[Mode] = []
    robot.subscribe(lambda s: modes.append(s.mode))
    robot.run_segment(MissionSegment(WALK, ((2.5, 0.7, 0.0), (2.5, 3.0, 0.0))))
    robot.run_for(10.0)
    run = robot.run_segment(MissionSegment(TAKEOFF, ((2.5, 3.0, 0.0), (2.5, 3.0, 1.5))))
    assert robot.latest_state().landed
    took = _run_until_done(robot, run)
    assert took == pytest.approx(1.0 + 1.5 / 0.5, abs=0.03)
    st = robot.latest_state()
    assert st.armed and not st.landed and st.position[2] == pytest.approx(1.5)
    assert st.mode is Mode.HOLDING  # hovering, no command
    run = robot.run_segment(MissionSegment(FLY, ((2.5, 3.0, 1.5), (2.5, 5.0, 1.5))))
    assert _run_until_done(robot, run) == pytest.approx(2.0, abs=0.03)
    run = robot.run_segment(MissionSegment(LAND, ((2.5, 5.0, 1.5), (2.5, 5.0, 0.0))))
    assert _run_until_done(robot, run) == pytest.approx(1.5 / 0.25 + 0.5, abs=0.03)
    st = robot.latest_state()
    assert st.landed and not st.armed and st.position == pytest.approx((2.5, 5.0, 0.0))
    seen = [m for i, m in enumerate(modes) if i == 0 or modes[i - 1] is not m]
    assert seen == [Mode.WALKING, Mode.IDLE, Mode.TAKING_OFF, Mode.HOLDING, Mode.FLYING,
                    Mode.HOLDING, Mode.LANDING, Mode.IDLE]


def test_segments_that_do_not_fit_the_robots_state_fail_clearly() -> None:
    robot = _manual()
    run = robot.run_segment(MissionSegment(FLY, ((2.5, 0.7, 0.0), (2.5, 2.0, 1.0))))
    assert run.status is RunStatus.FAILED and "take off first" in run.error
    run = robot.run_segment(MissionSegment(WALK, ((1.0, 1.0, 0.0), (1.0, 2.0, 0.0))))
    assert run.status is RunStatus.FAILED and "starts at" in run.error
    run = robot.run_segment(MissionSegment(WALK, ((2.5, 0.7, 0.0), (2.5, 8.5, 0.0))))
    assert run.status is RunStatus.FAILED and "outside the workspace" in run.error
    robot.run_segment(MissionSegment(TAKEOFF, ((2.5, 0.7, 0.0), (2.5, 0.7, 1.0))))
    robot.run_for(5.0)
    run = robot.run_segment(MissionSegment(WALK, ((2.5, 0.7, 0.0), (2.5, 1.5, 0.0))))
    assert run.status is RunStatus.FAILED and "in the air" in run.error


def test_hold_stops_in_the_air_and_tells_where_to_continue() -> None:
    robot = _manual(fly_speed=1.0)
    robot.run_segment(MissionSegment(TAKEOFF, ((2.5, 0.7, 0.0), (2.5, 0.7, 1.5))))
    robot.run_for(6.0)
    run = robot.run_segment(MissionSegment(FLY, ((2.5, 0.7, 1.5), (2.5, 1.5, 1.5), (2.5, 3.0, 1.5))))
    robot.run_for(1.2)
    assert not run.done
    with pytest.raises(LinkError, match="still running"):
        robot.run_segment(MissionSegment(LAND, ((2.5, 1.9, 1.5), (2.5, 1.9, 0.0))))
    robot.hold()
    assert run.status is RunStatus.HELD and run.next_waypoint == 2
    here = robot.latest_state().position
    robot.run_for(2.0)
    st = robot.latest_state()
    assert st.position == pytest.approx(here) and st.mode is Mode.HOLDING and not st.landed
    assert 0.3 < run.progress < 0.7
    assert st.messages == ()  # the operator's own hold is not echoed back as a robot message


def test_state_stream_is_sampled_at_its_configured_rate() -> None:
    # waits on state (30 samples), never on time: a loaded machine may stall the stream a while, so the figure
    # checked is the stream's own sample clock (the median spacing of the sample times), not the wall clock's
    robot = SimRobot(config=SimConfig(rate=50.0))
    states: list[RobotState] = []
    robot.subscribe(states.append)
    robot.connect()
    try:
        assert wait_until(lambda: len(states) >= 30, 120.0), len(states)
    finally:
        robot.close()
    gaps = np.diff([s.time for s in states[:30]])
    assert np.all(gaps > 0)
    assert 1.0 / 50.0 * 0.5 <= float(np.median(gaps)) <= 1.0 / 20.0  # at least 20 Hz by its own clock
    assert robot.latest_state() is states[-1]
    with pytest.raises(ValueError, match="rate"):
        SimConfig(rate=5.0)


def test_link_outage_freezes_the_stream_then_the_robot_holds_and_lands_by_itself() -> None:
    robot = _manual(fly_speed=1.0, link_loss_hold=1.0, link_loss_land=3.0)
    robot.run_segment(MissionSegment(TAKEOFF, ((2.5, 0.7, 0.0), (2.5, 0.7, 1.0))))
    robot.run_for(5.0)
    run = robot.run_segment(MissionSegment(FLY, ((2.5, 0.7, 1.0), (2.5, 3.0, 1.0))))
    robot.run_for(0.5)
    robot.drop_link(8.0)
    robot.run_for(0.5)
    st = robot.latest_state()
    assert not st.link_ok and st.link_age == pytest.approx(0.5, abs=0.05)
    with pytest.raises(LinkError, match="no link"):
        robot.capture()
    robot.run_for(1.0)
    assert run.status is RunStatus.HELD and "link lost" in run.error
    robot.run_for(7.5)  # outage over; the robot landed where it held
    st = robot.latest_state()
    assert st.link_ok and st.landed and st.position[1] == pytest.approx(0.7 + 1.0 * 1.5, abs=0.05)
    said = [t for _, t in st.messages]
    assert said[-2].startswith("WARNING: ") and "link lost" in said[-2]
    assert said[-1] == "CRITICAL: link lost for 3 s: landing by itself"


# --- camera --------------------------------------------------------------------------------------


def test_render_capture_carries_pose_intrinsics_and_ground_truth() -> None:
    robot = _manual()
    shot = robot.capture()
    assert shot.source == "sim-render" and shot.image.shape == (480, 640, 3)
    assert shot.robot_pose.translation == pytest.approx(DEFAULT_START.translation)
    expected = camera_pose_in_world(DEFAULT_START, robot.mount)
    assert shot.camera_pose.translation == pytest.approx(expected.translation)
    assert np.allclose(shot.camera_pose.rotation.as_matrix(), expected.rotation.as_matrix())
    gt = shot.ground_truth
    assert gt is not None and gt.depth.shape == (480, 640) and gt.instances.shape == (480, 640)
    visible = {v.id: v for v in gt.visible}
    # from the start the dog is hidden behind the boxes; the desks in front are seen
    assert "robot_dog-1" not in visible
    assert {"desk-1", "desk-2"} <= set(visible)
    for v in gt.visible:
        mask = gt.mask(v.id)
        assert mask.sum() == v.pixels >= robot.min_visible_pixels
        vs, us = np.nonzero(mask)
        assert v.bbox == (us.min(), vs.min(), us.max() + 1, vs.max() + 1)
        assert v.truncated == (us.min() == 0 or vs.min() == 0 or us.max() == 639 or vs.max() == 479)
    assert any(v.truncated for v in gt.visible) and not all(v.truncated for v in gt.visible)
    with pytest.raises(KeyError):
        gt.mask("robot_dog-1")


def test_behind_the_boxes_the_dog_is_in_view() -> None:
    x, y, _ = SEARCH_GOAL
    robot = _manual(start=Pose.from_xyz_yaw(x, y, 0.0, math.pi / 2))
    gt = robot.capture().ground_truth
    dog = next(v for v in gt.visible if v.label == "robot_dog")
    assert dog.pixels > 2000
    # median depth on the dog is about its distance from the camera
    d = float(np.median(gt.depth[gt.mask(dog.id)]))
    dog_obj = paper_room().object(dog.id)
    cam_y = y + robot.mount.position[0]
    assert dog_obj.position[1] - dog_obj.size[2] / 2 - cam_y - 0.05 < d < dog_obj.position[1] + 0.3 - cam_y


def _write_photo(folder: Path, stem: str, w: int, h: int, value: int, objects: list | None = None) -> None:
    img = np.full((h, w, 3), value, np.uint8)
    cv2.imwrite(str(folder / f"{stem}.png"), img)
    meta = {"image": f"{stem}.png", "width": w, "height": h,
            "K": [[300.0, 0, w / 2], [0, 300.0, h / 2], [0, 0, 1]]}
    if objects is not None:
        meta["objects"] = objects
    (folder / f"{stem}.json").write_text(json.dumps(meta))


def test_captures_folder_serves_real_photos_in_order(tmp_path: Path) -> None:
    obj = {"label": "chair", "center_cam": [0.1, 0.2, 2.5], "size": [0.5, 0.9, 0.5], "yaw": 0.3,
           "bbox2d_gt": [10, 20, 60, 90]}
    _write_photo(tmp_path, "a", 160, 120, 40, [obj])
    sub = tmp_path / "more"
    sub.mkdir()
    _write_photo(sub, "b", 200, 100, 200)
    robot = SimRobot(captures=tmp_path, manual_clock=True)
    robot.connect()
    shots = [robot.capture() for _ in range(3)]
    assert [s.name for s in shots] == ["a.png", "more/b.png", "a.png"]
    first = shots[0]
    assert first.source == "captures-folder" and first.image.shape == (120, 160, 3)
    assert first.intrinsics.fx == 300.0 and first.intrinsics.cx == 80.0
    assert int(first.image[0, 0, 0]) == 40
    assert first.robot_pose.translation == pytest.approx(DEFAULT_START.translation)
    gt = first.ground_truth
    assert gt.depth is None and gt.instances is None
    assert gt.objects[0].frame == "camera" and gt.objects[0].position == (0.1, 0.2, 2.5)
    assert gt.visible[0].bbox == (10.0, 20.0, 60.0, 90.0) and gt.visible[0].label == "chair"
    assert shots[1].ground_truth is None


def test_captures_folder_errors_name_the_problem(tmp_path: Path) -> None:
    with pytest.raises(CapturesError, match="not found"):
        CapturesFolder(tmp_path / "nope")
    with pytest.raises(CapturesError, match="no photo"):
        CapturesFolder(tmp_path)
    _write_photo(tmp_path, "bad", 160, 120, 10)
    meta = json.loads((tmp_path / "bad.json").read_text())
    meta["width"] = 640  # does not match the image
    (tmp_path / "bad.json").write_text(json.dumps(meta))
    with pytest.raises(CapturesError, match="bad.json.*640x120"):
        CapturesFolder(tmp_path).next()


def test_reads_the_development_benchmark_format_when_present() -> None:
    dev = Path(__file__).resolve().parents[4] / "shared" / "bench" / "dev"
    if not (dev / "index.json").is_file():
        pytest.skip("development benchmark folder not present")
    folder = CapturesFolder(dev)
    photo = folder.next()
    h, w = photo.image.shape[:2]
    assert (photo.intrinsics.width, photo.intrinsics.height) == (w, h)
    assert photo.ground_truth is not None and photo.ground_truth.objects


# --- factory -------------------------------------------------------------------------------------


def test_open_link_builds_the_simulator_and_rejects_bad_specs() -> None:
    link = open_link("sim", config=SimConfig(time_scale=2.0))
    try:
        assert isinstance(link, SimRobot) and link.connected
        assert link.latest_state() is not None
    finally:
        link.close()
    assert not link.connected
    for spec in ("", "robot", "sim:foo", "mavlink:", "mavlink:bogus:1", "mavlink:udpin:1.2.3.4:99999",
                 "mavlink:/dev/ttyACM0,fast"):
        with pytest.raises(LinkError):
            open_link(spec, connect=False)
    with pytest.raises(LinkError, match="unexpected|argument"):
        open_link("sim", connect=False, colour="red")


def test_start_inside_an_obstacle_is_refused() -> None:
    with pytest.raises(LinkError, match="start is not free"):
        SimRobot(start=Pose.from_xyz_yaw(2.5, BOX_LINE_Y, 0.0))
    with pytest.raises(ValueError, match="walk_speed"):
        SimConfig(walk_speed=0)
    assert Workspace().contains(SEARCH_GOAL)


def test_close_racing_a_background_connect_does_not_raise() -> None:
    """The console connects its link in a background thread; a SIGTERM can close it between the loop
    thread's creation and its start ('cannot join thread before it is started' ended the console with a
    traceback on a loaded CI machine)."""
    import threading as _threading

    from console.link.sim import SimRobot

    robot = SimRobot()
    robot._thread = _threading.Thread(target=lambda: None)  # created by connect(), not started yet
    robot.close()  # must not raise
    assert not robot.connected


@pytest.mark.parametrize("height", [0.46, 0.65, 0.95, 1.31, 1.9])
def test_a_landing_in_one_long_step_ends_on_the_floor_not_under_it(height: float) -> None:
    """A loaded machine steps the simulator in long steps: the landing's last point was computed
    1e-17 m under the floor (rounding), outside the workspace, and 'Land here' failed."""
    robot = _manual(spool_time=0.1, climb_rate=1.0, descent_rate=0.5, settle_time=0.1)
    run = robot.run_segment(MissionSegment(TAKEOFF, ((2.5, 0.7, 0.0), (2.5, 0.7, height))))
    _run_until_done(robot, run)
    assert robot.latest_state().position[2] == pytest.approx(height)
    land = robot.land_here(0.0)
    robot.step(100.0)  # the whole descent in one step
    assert land.status is RunStatus.DONE, land.error
    st = robot.latest_state()
    assert st.landed and st.position[2] == 0.0
