"""Known space in the session: each capture updates it (simulator: rendered depth), it is saved and
restored with the session, undone with its capture, and an object placed over the robot is named."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

from console.link.sim import SimConfig, SimRobot
from console.session.known_space_state import KNOWN_SPACE, objects_over
from console.session.mapping_job import GROUND_TRUTH_LABEL, MapperPerceiver, MappingJob, ground_truth_bundle_for
from console.session.session import NOTICE, RobotSnapshot, Session
from pipeline.camera.geometry import Pose
from pipeline.mapping.known_space import KnownState
from pipeline.scene import Scene, SceneObject


@pytest.fixture
def mapped(tmp_path: Path):
    robot = SimRobot(config=SimConfig(time_scale=4.0))
    robot.connect()
    session = Session(tmp_path / "s")
    job = MappingJob(session, robot.capture, MapperPerceiver(GROUND_TRUTH_LABEL, ground_truth_bundle_for))
    try:
        yield robot, session, job
    finally:
        robot.close()


def test_a_capture_fills_the_known_space_and_says_what_the_depth_saw(mapped) -> None:
    robot, session, job = mapped
    events: list[object] = []
    session.subscribe(lambda t, p: events.append(p) if t == KNOWN_SPACE else None)
    assert session.known_space is None and "none yet" in session.known_summary().text()
    assert job.run()
    space = session.known_space
    assert space is not None and space.shape == session.workspace.shape
    st = space.state()
    ws = session.workspace
    # in front of the robot, up to the desks: seen free; the line of boxes at y = 4 m seen occupied where visible
    i, j = int((2.5 - ws.min[0]) / ws.resolution), int((1.6 - ws.min[1]) / ws.resolution)
    assert st[i, j, 0] == KnownState.FREE
    assert (st[:, int(4.0 / ws.resolution) - 1:int(4.0 / ws.resolution) + 1, :3] == KnownState.OCCUPIED).any()
    # behind the line nothing was seen
    assert (st[:, int(6.5 / ws.resolution), 0] == KnownState.UNKNOWN).all()
    # the robot's own cells are free
    assert st[int(2.5 / ws.resolution), int(0.7 / ws.resolution), 0] == KnownState.FREE
    summary = session.known_summary()
    assert events and events[-1] == summary
    assert 0.05 < summary.seen_share < 0.9 and summary.text().startswith("known space: ")
    assert "unlabelled obstacle cell" in session.job.message and "of the near depth" in session.job.message


def test_known_space_is_saved_restored_and_undone_with_its_capture(mapped, tmp_path: Path) -> None:
    robot, session, job = mapped
    assert job.run()
    saved = json.loads((session.folder / "session.json").read_text())
    assert saved["known_space"]["format"] == "morphonavi.known_space" and saved["plan_unknown"] == "closed"
    before = session.known_space.log_odds.copy()
    again = Session(tmp_path / "s")
    assert again.restore_last() is not None
    assert again.known_space is not None and np.array_equal(again.known_space.log_odds, before)
    # a second capture from another heading, then undo: the known space of the first capture comes back
    robot.run_segment(__import__("planner.mission", fromlist=["turn_segment"]).turn_segment(
        robot.latest_state().position, 0.0)).wait(30)
    assert job.run()
    assert not np.array_equal(session.known_space.log_odds, before)
    session.undo_edit()
    assert np.array_equal(session.known_space.log_odds, before)
    session.undo_edit()  # the first capture: no known space at all
    assert session.known_space is None


def test_a_bad_or_foreign_known_space_in_a_session_file_is_dropped_with_the_reason(tmp_path: Path) -> None:
    s = Session(tmp_path / "a")
    s.spawn(Scene(objects=(SceneObject("box", "cardboard_box", (1.0, 1.0, 0.2), (0.4, 0.4, 0.4)),)))
    data = s.to_dict()
    data["known_space"] = {"format": "morphonavi.known_space", "version": 1, "origin": [0, 0, 0], "resolution": 0.5,
                           "shape": [2, 2, 2], "encoding": "int8 log-odds/32, C order, zlib, base64", "data": "eJxjYAAAAAIAAQ=="}
    data["plan_unknown"] = "sometimes"
    (tmp_path / "b").mkdir()
    (tmp_path / "b" / "session.json").write_text(json.dumps(data))
    b = Session(tmp_path / "b")
    b.restore_last()
    problems = " | ".join(b.restore_problems)
    assert "plan_unknown: must be 'closed' or 'allow'" in problems
    assert "known_space" in problems and "not restored" in problems
    assert b.known_space is None and len(b.scene.objects) == 1  # the rest of the session is kept


def test_an_object_placed_over_the_robot_is_named(tmp_path: Path) -> None:
    s = Session(tmp_path / "s", autosave=False)
    told: list[str] = []
    s.subscribe(lambda t, p: told.append(p.body) if t == NOTICE else None)
    s.set_robot(RobotSnapshot(Pose.from_xyz_yaw(2.5, 0.7, 0.0), mode="idle", landed=True))
    desk = SceneObject("desk-9", "desk", (2.6, 0.9, 0.375), (1.4, 0.75, 0.7), 0.0, "world")
    s.spawn(Scene(objects=(desk,)))
    notes = s.warn_objects_over_robot("scene file desk.json")
    assert notes and "desk 'desk-9' lies over the robot at (2.50, 0.70)" in notes[0] and told[-1] == notes[0]
    assert objects_over((2.5, 0.7, 0.0), [desk], 0.35) == [desk]
    far = SceneObject("far", "desk", (4.5, 5.0, 0.375), (1.4, 0.75, 0.7), 0.0, "world")
    assert objects_over((2.5, 0.7, 0.0), [far], 0.35) == []
    high = SceneObject("shelf", "desk", (2.5, 0.7, 2.0), (1.0, 0.1, 1.0), 0.0, "world")  # well above the body
    assert objects_over((2.5, 0.7, 0.0), [high], 0.35) == []
    assert math.isfinite(s.known_summary().seen_share)


def test_unknown_space_is_closed_until_the_operator_allows_it_and_the_unseen_part_is_measured(mapped) -> None:
    robot, session, job = mapped
    assert job.run()
    behind = (2.5, 5.3, 0.0)  # behind the line of boxes: not seen from the start
    res = session.add_goal(behind)
    assert not res.ok and "not seen yet" in res.message, res.message
    assert session.unseen_route()[1] == 0.0
    text = session.set_plan_unknown(True)
    assert text.startswith("planning into unknown space") and session.plan_unknown == "allow"
    assert json.loads((session.folder / "session.json").read_text())["plan_unknown"] == "allow"
    res = session.add_goal((4.5, 1.0, 0.0))  # beside the robot, past the edge of the photo
    assert res.ok and res.unseen_m > 0, res.message
    segs, metres = session.unseen_route()
    assert len(segs) > 0 and metres == pytest.approx(res.unseen_m, abs=1e-6) and "unseen space" in res.message
    assert "planning into unknown space" in session.known_summary().text()
    session.set_plan_unknown(False)
    assert session.plan_unknown == "closed" and session.unseen_route()[1] == 0.0
