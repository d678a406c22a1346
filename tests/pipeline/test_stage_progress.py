"""The mapping run reports its stages (detect, segment, depth, distance), and the console's progress bar
shows them in order: pipeline.stage_progress, Mapper.run(on_stage=...), console.session.mapping_job.

Perception is the simulator's ground truth (boxes, masks, exact depth of a render): no weights needed.
"""

from __future__ import annotations

import time
from pathlib import Path
from typing import Any, Callable

import pytest

from console.link.sim import SimRobot
from console.session.mapping_job import GROUND_TRUTH_LABEL, STAGE_TEXT, MapperPerceiver, MappingJob, ground_truth_bundle_for
from console.session.session import JobStatus, Session
from pipeline.catalog import default_catalog
from pipeline.mapper import Mapper, MapperConfig
from pipeline.stage_progress import STAGE_BUDGET_S, STAGES, StageFractions, stage_reporter


def _wait_until(cond: Callable[[], bool], timeout: float = 60.0) -> bool:
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        if cond():
            return True
        time.sleep(0.02)
    return cond()


@pytest.fixture(scope="module")
def shot() -> Any:
    robot = SimRobot()
    robot.connect()
    try:
        return robot.capture()
    finally:
        robot.close()


@pytest.mark.parametrize("segment", ["all", "auto", "none"])
@pytest.mark.parametrize("parallel", [True, False])
def test_mapper_announces_each_stage_once_in_order(shot: Any, segment: str, parallel: bool) -> None:
    seen: list[str] = []
    bundle = ground_truth_bundle_for(shot)
    with Mapper(bundle, default_catalog(), MapperConfig(segment=segment, parallel=parallel)) as mapper:
        res = mapper.run(shot.image, shot.intrinsics, shot.mount, shot.robot_pose, on_stage=seen.append)
    assert seen == list(STAGES)
    assert len(res.scene.objects) > 0  # the stages did their work: the render's objects are placed
    for key in ("detect", "segment", "depth", "distance", "total"):
        assert res.timings[key] >= 0.0


def test_a_failing_progress_callback_does_not_fail_the_run(shot: Any) -> None:
    calls: list[str] = []

    def broken(stage: str) -> None:
        calls.append(stage)
        raise RuntimeError("display gone")

    with Mapper(ground_truth_bundle_for(shot), default_catalog()) as mapper:
        res = mapper.run(shot.image, shot.intrinsics, shot.mount, shot.robot_pose, on_stage=broken)
    assert calls == ["detect"]  # dropped after its first failure
    assert len(res.scene.objects) > 0
    report = stage_reporter(None)
    report("detect")  # no callback: nothing to call, no error


def test_stage_fractions_follow_the_budget_and_check_their_input() -> None:
    f = StageFractions()
    starts = [f.at_start(s) for s in STAGES]
    assert starts[0] == 0.0 and starts == sorted(starts) and starts[-1] < 1.0
    total = sum(STAGE_BUDGET_S.values())
    assert f.at_start("depth") == pytest.approx((STAGE_BUDGET_S["detect"] + STAGE_BUDGET_S["segment"]) / total)
    with pytest.raises(ValueError, match="stage: must be one of"):
        f.at_start("encode")
    with pytest.raises(ValueError, match=r"budget\.depth"):
        StageFractions({"detect": 1.0, "segment": 1.0, "distance": 1.0})
    with pytest.raises(ValueError, match=r"budget\.segment"):
        StageFractions({"detect": 1.0, "segment": float("nan"), "depth": 1.0, "distance": 1.0})


def test_the_progress_bar_shows_the_sub_stages_in_order(tmp_path: Path, shot: Any) -> None:
    session = Session(tmp_path / "session")
    jobs: list[JobStatus] = []
    session.subscribe(lambda topic, payload: jobs.append(payload) if topic == "job" else None)
    job = MappingJob(session, lambda: shot, MapperPerceiver(GROUND_TRUTH_LABEL, ground_truth_bundle_for))
    assert job.start()
    assert _wait_until(lambda: not job.running, 120.0)
    assert session.job.error is None and not session.job.running, session.job
    messages = [j.message for j in jobs]
    shown = [stage for stage in STAGES if STAGE_TEXT[stage] in messages]
    assert shown == list(STAGES)
    order = [messages.index(STAGE_TEXT[s]) for s in STAGES]
    assert order == sorted(order)
    fractions = [j.fraction for j in jobs]
    assert fractions == sorted(fractions)  # the bar never moves back
    stage_fractions = [jobs[i].fraction for i in order]
    assert len(set(stage_fractions)) == len(STAGES)  # each stage moves the bar
    assert session.capture is not None and len(session.scene.objects) > 0
