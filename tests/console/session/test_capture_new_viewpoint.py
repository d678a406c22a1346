"""Capture & map from a new place in the paper's room: a desk seen from the right wall, partly hidden
by its chair and placed 1.1 m too far, is not added outside the workspace (the panel says so) and
joins the mapped desk once the desk is known."""

from __future__ import annotations

import math
import re
from pathlib import Path

from console.link.sim import SimRobot
from console.session.mapping_job import GROUND_TRUTH_LABEL, MapperPerceiver, MappingJob, ground_truth_bundle_for
from console.session.session import NOTICE, Session
from pipeline.camera.geometry import Pose

SIDE = (4.12, 1.12, math.pi)
"""From the right wall facing -x: desk-1 at the right edge of the view, behind office_chair-1."""


def _capture(session: Session, pose: tuple[float, float, float]) -> None:
    robot = SimRobot(start=Pose.from_xyz_yaw(pose[0], pose[1], 0.0, pose[2]), manual_clock=True)
    robot.connect()
    try:
        assert MappingJob(session, robot.capture, MapperPerceiver(GROUND_TRUTH_LABEL, ground_truth_bundle_for)).run()
    finally:
        robot.close()


def test_the_side_view_adds_no_desk_outside_the_room(tmp_path: Path) -> None:
    session = Session(tmp_path / "s", autosave=False)
    notices = []
    session.subscribe(lambda t, p: notices.append(p) if t == NOTICE else None)
    _capture(session, SIDE)
    ws = session.workspace
    assert not [o for o in session.scene.objects if o.label == "desk"]
    assert all(ws.contains(o.position) for o in session.scene.objects)
    line = session.job.message
    assert "1 not used" in line and re.search(r"; not used: detection \d+ \(desk, \d\.\d\d\): \d+\.\d m outside "
                                              r"the workspace: not added", line), line
    assert notices[-1].title == "Mapped" and "outside the workspace: not added" in notices[-1].body


def test_the_side_view_joins_the_desk_mapped_from_the_start(tmp_path: Path) -> None:
    session = Session(tmp_path / "s", autosave=False)
    _capture(session, (2.5, 0.7, math.pi / 2))
    desks = {o.id: o.position for o in session.scene.objects if o.label == "desk"}
    assert len(desks) == 2
    _capture(session, SIDE)
    after = {o.id: o.position for o in session.scene.objects if o.label == "desk"}
    assert after.keys() == desks.keys()  # no "desk-1-2", nothing renamed
    assert all(math.dist(after[k], desks[k]) < 0.15 for k in desks)
    assert all(session.workspace.contains(o.position) for o in session.scene.objects)


def test_merging_a_held_back_capture_adds_nothing_outside_the_workspace(tmp_path: Path) -> None:
    from pipeline.scene import Capture, Scene, SceneObject, Source

    session = Session(tmp_path / "s", autosave=False)
    job = MappingJob(session, lambda: None, MapperPerceiver(GROUND_TRUTH_LABEL, ground_truth_bundle_for))
    desk = SceneObject("desk-1", "desk", (-0.6, 3.0, 0.375), (1.4, 0.75, 0.7), 0.0, source=Source("c9", "depth"))
    chair = SceneObject("office_chair-1", "office_chair", (1.5, 2.3, 0.5), (0.62, 1.05, 0.62), 0.0,
                        source=Source("c9", "depth"))
    job._held = (Scene(objects=(desk, chair), captures=(Capture("c9"),)), "c9")  # as run() holds one back
    assert job.resolve_held("merge") == "capture c9: 1 new, 0 updated (merge)"
    assert [o.label for o in session.scene.objects] == ["office_chair"]
