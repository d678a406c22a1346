"""The known space is recorded in the MCAP: its compact JSON form and counts after every capture."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from console.link.sim import SimConfig, SimRobot
from console.recording.recording import Recorder
from console.session.mapping_job import GROUND_TRUTH_LABEL, MapperPerceiver, MappingJob, ground_truth_bundle_for
from console.session.session import Session
from pipeline.mapping.known_space import KnownSpace
from tests.console.recording.test_recording import read_all


def test_each_capture_records_the_known_space(tmp_path: Path) -> None:
    robot = SimRobot(config=SimConfig(time_scale=4.0))
    robot.connect()
    try:
        session = Session(tmp_path / "s", autosave=False)
        rec = Recorder(session, folder=tmp_path / "rec").start()
        job = MappingJob(session, robot.capture, MapperPerceiver(GROUND_TRUTH_LABEL, ground_truth_bundle_for))
        assert job.run()
        rec.close()
    finally:
        robot.close()
    files = sorted((tmp_path / "rec").glob("*.mcap"))
    _, messages = read_all(files[0])
    known = [m for t, schema, _, m in messages if t == "/map/known_space"]
    assert known and [s for t, s, _, _ in messages if t == "/map/known_space"][0] == "morphonavi.KnownSpace"
    last = known[-1]
    space = KnownSpace.from_dict(last["known_space"])
    assert np.array_equal(space.log_odds, session.known_space.log_odds)  # the recorded grid is the session's
    assert last["free"] > 0 and last["occupied"] > 0 and last["unknown"] > 0 and last["plan_unknown"] == "closed"
    assert last["unlabelled"] == session.known_summary().unlabelled
