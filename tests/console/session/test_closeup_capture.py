"""A close-up capture drops only the objects it cannot range, and says which and why on the panel."""

from __future__ import annotations

import re
import time
from pathlib import Path

from console.link.base import RunStatus
from console.link.sim import SimConfig, SimRobot
from console.session.mapping_job import GROUND_TRUTH_LABEL, MapperPerceiver, MappingJob, ground_truth_bundle_for
from console.session.session import Session
from planner.mission import MissionSegment, SegmentKind


def test_a_close_up_keeps_what_it_can_range_and_names_what_it_dropped(tmp_path: Path) -> None:
    robot = SimRobot(config=SimConfig(time_scale=8.0))
    robot.connect()
    try:
        session = Session(tmp_path / "s", autosave=False)
        mapping = MappingJob(session, robot.capture, MapperPerceiver(GROUND_TRUTH_LABEL, ground_truth_bundle_for))
        assert mapping.run()
        first = {o.id for o in session.scene.objects}
        # walk up to the line of boxes until the body touches it: the camera is a few cm from a box
        run = robot.run_segment(MissionSegment(SegmentKind.WALK, ((2.5, 0.7, 0.0), (2.45, 3.0, 0.0))))
        deadline = time.monotonic() + 60
        while not run.done and time.monotonic() < deadline:
            time.sleep(0.01)
        assert run.status is RunStatus.DONE, run.error
        run = robot.run_segment(MissionSegment(SegmentKind.WALK, ((2.45, 3.0, 0.0), (2.45, 4.0, 0.0))))
        while not run.done and time.monotonic() < deadline:
            time.sleep(0.01)
        assert run.status is RunStatus.FAILED and "contact with an unmapped obstacle" in run.error
        assert mapping.run()
        job = session.job
        assert not job.running and job.error is None
        assert re.search(r"not used: detection \d+ \(cardboard_box, \d\.\d\d\): camera too close", job.message), \
            job.message  # what and why, on the panel
        assert first <= {o.id for o in session.scene.objects}  # nothing of the map was lost
    finally:
        robot.close()
