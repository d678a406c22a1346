"""The capture panel's "Little of the photo explained" warning: the room's own walls (on or beyond the
workspace's faces, within the depth's sigma) are explained by the workspace; an obstacle the detector
did not name still warns."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from console.link.sim import SimConfig, SimRobot
from console.link.world import ROOM_MAX, ROOM_MIN
from console.session.mapping_job import MapperPerceiver, MappingJob
from console.session.session import NOTICE, Session
from pipeline.camera.geometry import Pose
from pipeline.models.ground_truth import ground_truth_bundle
from pipeline.scene import Scene, SceneObject

WARNING = "Little of the photo explained"


def _depth_model_bundle(shot):
    """A depth model's scaled map of the render (reads 3 % short, as a scale fit can), naming nothing."""
    return ground_truth_bundle([], [], None, np.asarray(shot.ground_truth.depth, dtype=np.float32) * 0.97)


def _capture_facing_x0(tmp_path: Path, world: Scene) -> tuple[Session, list[object]]:
    """One capture by a robot hovering at (2.5, 4.0, 1.2) m facing -x: the room's wall x = 0, 2.5 m away,
    fills the photo (the workspace is 0..5 x 0..8 x 0..3 m, the wall stands on its face x = 0)."""
    robot = SimRobot(world=world, start=Pose.from_xyz_yaw(2.5, 4.0, 1.2, math.pi), config=SimConfig(time_scale=4.0),
                     room=(ROOM_MIN, ROOM_MAX))
    robot.connect()
    try:
        session = Session(tmp_path / "s", autosave=False)
        assert tuple(session.workspace.min) == (0.0, 0.0, 0.0)
        notices: list[object] = []
        session.subscribe(lambda t, p: notices.append(p) if t == NOTICE else None)
        job = MappingJob(session, robot.capture, MapperPerceiver("offline models (test)", _depth_model_bundle))
        assert job.run(), session.job
        return session, notices
    finally:
        robot.close()


def test_a_photo_of_the_rooms_own_wall_is_explained_by_the_workspace(tmp_path: Path) -> None:
    session, notices = _capture_facing_x0(tmp_path, Scene())
    assert not [n for n in notices if getattr(n, "title", "") == WARNING], notices
    assert "mapped objects explain 100 % of the near depth" in session.job.message, session.job.message


def test_an_obstacle_the_detector_did_not_name_still_warns(tmp_path: Path) -> None:
    cabinet = SceneObject("cabinet", "office_cabinet", (1.0, 4.0, 0.925), (0.8, 1.85, 0.42))
    session, notices = _capture_facing_x0(tmp_path, Scene(objects=(cabinet,)))
    warned = [n for n in notices if getattr(n, "title", "") == WARNING]
    assert warned and "explain only 0 % of the near depth" in warned[-1].body, notices
