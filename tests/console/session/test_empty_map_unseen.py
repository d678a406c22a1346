"""Before the first capture, the console's empty map is space no capture has seen: every way of planning
(a goal, Land here, Return, an agent's plan) refuses to cross it while unknown space is closed, and says
so; a capture opens what it saw (its undo closes it again); a spawned or loaded scene file is a hand-made
map, taken as fully known; sessions made without the console's flag (scripts) keep the fully known rule.
World frame, z up [m]."""

from __future__ import annotations

import json
import math
import time
from dataclasses import replace
from pathlib import Path
from typing import Any

import pytest

from console.link.base import Mode, RobotState
from console.mcp.door import AgentDoor, AgentError
from console.session.goal_rules import NOTHING_SEEN
from console.session.session import Session, SessionError
from console.session.session_types import robot_snapshot
from pipeline.camera.geometry import CameraMount, Intrinsics, Pose, camera_pose_in_world
from pipeline.scene import Scene, SceneObject, Source
from planner.grid import Closed

START = (2.5, 0.7, 0.0)
BEHIND = (2.5, 5.3, 0.0)  # behind where the paper room's line of boxes stands: never seen here
NEAR = (2.5, 2.2, 0.0)  # in front of the robot, 1.5 m: seen by a capture looking +y
SIDE = (0.4, 0.8, 0.0)  # beside the robot, 2.1 m: outside the view of a capture looking +y
BOX = SceneObject("box-1", "cardboard_box", (1.0, 3.0, 0.25), (0.5, 0.5, 0.5))


def _console(tmp_path: Path, name: str = "s", autosave: bool = False) -> Session:
    return Session(tmp_path / name, start=START, autosave=autosave, empty_is_unseen=True)


def _state(p: tuple[float, float, float], flying: bool) -> Any:
    mode = Mode.HOLDING if flying else Mode.IDLE
    return robot_snapshot(RobotState(time=time.time(), position=p, mode=mode, landed=not flying, armed=flying))


def _capture(s: Session, cap_id: str = "0001") -> None:
    """One capture from the start looking +y (no depth: the mapped boxes and the floor bound the rays);
    its objects (none) and its known space are one undo step, as the mapping job makes them."""
    s.spawn(Scene(), origin=f"capture {cap_id}")
    robot = Pose.from_xyz_yaw(*START, math.pi / 2)
    camera = camera_pose_in_world(robot, CameraMount())
    s.observe_capture(cap_id, None, Intrinsics(320.0, 320.0, 320.0, 240.0, 640, 480), camera, robot)


def test_a_goal_on_the_consoles_empty_map_is_refused_with_what_to_do(tmp_path: Path) -> None:
    s = _console(tmp_path)
    assert s.grid.rule == "closed" and s.known_space is None
    summary = s.known_summary()
    assert summary.rule == "nothing_seen" and summary.unknown == summary.cells > 0
    assert summary.text() == ("known space: nothing seen yet (every cell is unknown) · unknown space closed: "
                              "no goal is planned until Capture & map or Look around")
    res = s.add_goal(BEHIND)
    assert not res.ok and res.message.startswith(NOTHING_SEEN + " (goal (2.50, 5.30, 0.00) is not seen yet")
    assert "Go look" in res.message
    assert res.viewpoint is not None and math.dist(res.viewpoint[:2], START[:2]) < 0.3  # look from where it stands
    assert s.route_snapshot().candidate_goal is None
    hover = s.add_goal((2.5, 0.7, 1.0))  # straight up: the air is not seen either
    assert not hover.ok and hover.message.startswith(NOTHING_SEEN)
    s.set_plan_unknown(True)  # the operator's deliberate choice: planned, the unseen metres said
    res = s.add_goal(BEHIND)
    assert res.ok and res.unseen_m > 4.0 and "through unseen space" in res.message
    assert "planning into unknown space" in s.known_summary().text()


def test_land_here_and_return_do_not_cross_unseen_space_before_the_first_capture(tmp_path: Path) -> None:
    s = _console(tmp_path)
    s.set_robot(_state(START, flying=False))  # stood disarmed at the start: where Return goes
    s.set_robot(_state((2.5, 3.0, 1.0), flying=True))
    land = s.operator_state().commands["land"]
    assert not land.enabled and land.reason == ("Land here is off: the floor below (2.50, 3.00) has not been seen: "
                                                "look down there first, or Return")
    with pytest.raises(SessionError, match="has not been seen"):
        s.land_mission()
    with pytest.raises(SessionError, match="cannot plan the return: .*(not seen yet|has not been seen)"):
        s.return_mission()


def test_an_agents_plan_is_refused_the_same_way(tmp_path: Path) -> None:
    door = AgentDoor(_console(tmp_path), runner=None, robot_spec="sim")
    try:
        with pytest.raises(AgentError, match="^goal: nothing seen yet: Capture & map or Look around first"):
            door.call("plan_to_point", {"x": BEHIND[0], "y": BEHIND[1]}, allow_actions=True)
        unseen = door.call("unseen_space")
        assert unseen["known"] is False and "nothing seen yet" in unseen["text"] and unseen["seen_share"] == 0.0
    finally:
        door.close()


def test_a_capture_opens_what_it_saw_and_its_undo_closes_it_again(tmp_path: Path) -> None:
    s = _console(tmp_path)
    _capture(s)
    assert s.known_summary().rule == "captures" and s.known_summary().seen_share > 0.0
    res = s.add_goal(NEAR)
    assert res.ok, res.message
    far = s.add_goal(SIDE)  # still not seen: the planner's own refusal, with no "nothing seen yet"
    assert not far.ok and "not seen yet" in far.message and not far.message.startswith(NOTHING_SEEN)
    s.undo_edit()
    assert s.known_space is None and s.known_summary().rule == "nothing_seen"
    assert s.add_goal(NEAR).message.startswith(NOTHING_SEEN)


def test_a_capture_that_maps_objects_is_not_a_hand_made_map(tmp_path: Path) -> None:
    s = _console(tmp_path)
    s.spawn(Scene(objects=(BOX,)), origin="capture 0001")  # the capture's objects come before its known space
    assert s.grid.rule == "closed" and s.known_summary().rule == "nothing_seen"
    assert s.add_goal(BEHIND).message.startswith(NOTHING_SEEN)


def test_a_spawned_scene_file_is_a_hand_made_map_taken_as_fully_known(tmp_path: Path) -> None:
    s = _console(tmp_path)
    s.spawn(Scene(objects=(BOX,)), origin="file room.json")
    assert s.grid.rule == "fully_known"
    assert s.known_summary().text() == ("known space: none yet (Capture & map builds it); the map from scene files "
                                        "is taken as fully known")
    assert s.add_goal(BEHIND).ok
    s.delete_object(BOX.id)  # nothing of the hand-made map is left: nothing seen again
    assert s.grid.rule == "closed" and s.add_goal(BEHIND).message.startswith(NOTHING_SEEN)


def test_a_restored_session_keeps_its_rule(tmp_path: Path) -> None:
    given = _console(tmp_path, "given", autosave=True)
    given.spawn(Scene(objects=(BOX,)), origin="file room.json")
    empty = _console(tmp_path, "empty", autosave=True)
    empty.discard()  # writes session.json with nothing in it
    assert json.loads((tmp_path / "empty" / "session.json").read_text())["known_space"] is None
    again = _console(tmp_path, "given")
    assert again.restore_last() is not None and again.grid.rule == "fully_known" and again.add_goal(BEHIND).ok
    again = _console(tmp_path, "empty")
    assert again.restore_last() is not None and again.known_summary().rule == "nothing_seen"
    assert again.add_goal(BEHIND).message.startswith(NOTHING_SEEN)


def test_a_restored_map_of_captured_objects_without_its_known_space_is_not_a_hand_made_map(tmp_path: Path) -> None:
    s = _console(tmp_path, autosave=True)
    s.spawn(Scene(objects=(replace(BOX, source=Source(capture="0001", method="ground_truth")),)), origin="capture 0001")
    data = json.loads((tmp_path / "s" / "session.json").read_text())
    assert data["known_space"] is None and data["scene"]["objects"]  # e.g. a known space that could not be kept
    again = _console(tmp_path)
    assert again.restore_last() is not None and len(again.scene.objects) == 1
    assert again.known_summary().rule == "nothing_seen" and again.add_goal(BEHIND).message.startswith(NOTHING_SEEN)


def test_scripts_without_the_consoles_flag_keep_the_fully_known_rule(tmp_path: Path) -> None:
    s = Session(tmp_path / "s", start=START, autosave=False)
    assert s.grid.rule == "fully_known" and not (s.grid.reason == Closed.UNKNOWN).any()
    assert s.known_summary().text() == "known space: none yet (Capture & map builds it); the map is taken as fully known"
    assert s.add_goal(BEHIND).ok


def test_go_look_on_the_empty_map_captures_where_the_robot_stands_and_plans_the_goal(tmp_path: Path) -> None:
    """The refusal's look is taken as offered: Go look turns to the goal where the robot stands (no move
    through unseen space), captures and maps, and the goal is then planned over seen-free floor."""
    from console.link.sim import SimRobot
    from console.link.sim_config import SimConfig
    from console.link.world_file import paper_world
    from console.session.go_look import GoLookJob
    from console.session.mapping_job import MappingJob, simulator_perceiver
    from console.views.mission_view import make_runner

    world = paper_world()
    robot = SimRobot(**world.link_options(config=SimConfig(time_scale=10.0)))
    robot.connect()
    start = tuple(float(v) for v in world.start.translation)
    s = Session(tmp_path / "s", start=start, workspace=world.workspace(), autosave=False, empty_is_unseen=True)
    unsubscribe = robot.subscribe(lambda st: s.set_robot(robot_snapshot(st)))
    job = GoLookJob(s, robot, MappingJob(s, robot.capture, simulator_perceiver("exact")), make_runner(robot, s))
    try:
        goal = (start[0], start[1] + 1.5, 0.0)  # 1.5 m ahead: open floor in the paper's room
        assert s.add_goal(goal).message.startswith(NOTHING_SEEN)
        job.start(goal[:2])
        assert job.wait(600), "Go look did not end"
        out = job.outcome
        assert out.planned and out.looks == 1 and out.kinds == [], out.message  # no move: captured where it stood
        assert s.known_summary().rule == "captures" and s.route_snapshot().candidate_goal is not None
        assert math.dist(robot.latest_state().position[:2], start[:2]) < 0.1
    finally:
        job.stop()
        job.wait(60)
        unsubscribe()
        robot.close()
