"""Models load in the background at console start (console.session.model_preload): progress in the job status,
a capture requested before they are ready waits and says so, a failure (missing weights) is shown and
the console stays up.

The offline-model tests use the real weights in ``../shared/models`` (skipped, with the reason, when
they are not there); the failure tests use an empty model folder.
"""

from __future__ import annotations

import time
import urllib.request
from pathlib import Path
from typing import Any, Callable

import pytest

from console.app import ConsoleApp, ConsoleConfig
from console.link.sim import SimRobot
from console.session.mapping_job import (
    GROUND_TRUTH_LABEL, JOB_NAME, STAGE_TEXT, WAITING_TEXT, MapperPerceiver, MappingJob, OfflineModels,
    ground_truth_bundle_for, missing_offline_models,
)
from console.session.model_preload import PRELOAD_NAME, ModelPreload
from console.session.session import NOTICE, JobStatus, Notice, Session
from pipeline.stage_progress import STAGES

SHARED_MODELS = Path(__file__).resolve().parents[4] / "shared" / "models"


def _wait_until(cond: Callable[[], bool], timeout: float = 120.0) -> bool:
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        if cond():
            return True
        time.sleep(0.02)
    return cond()


def _record(session: Session) -> tuple[list[JobStatus], list[Notice]]:
    jobs: list[JobStatus] = []
    notices: list[Notice] = []
    session.subscribe(lambda t, p: jobs.append(p) if t == "job" else notices.append(p) if t == NOTICE else None)
    return jobs, notices


@pytest.fixture()
def robot():
    r = SimRobot()
    r.connect()
    try:
        yield r
    finally:
        r.close()


def _offline_missing() -> str | None:
    if not SHARED_MODELS.is_dir():
        return f"no offline model weights: {SHARED_MODELS} does not exist"
    missing = missing_offline_models(SHARED_MODELS)
    return f"offline models {', '.join(missing)} missing in {SHARED_MODELS}" if missing else None


def test_missing_weights_are_shown_not_raised_and_a_capture_says_why(tmp_path: Path, robot: SimRobot) -> None:
    session = Session(tmp_path / "session")
    jobs, notices = _record(session)
    perceiver = MapperPerceiver("offline models", OfflineModels(tmp_path / "no-models"))
    preload = ModelPreload(session, perceiver)
    preload.start()
    assert _wait_until(lambda: preload.state == "failed")
    assert preload.error is not None and "morphonavi models fetch" in preload.error
    assert _wait_until(lambda: session.job.error is not None)
    assert session.job.name == PRELOAD_NAME and not session.job.running
    assert "yolox_nano" in session.job.error
    assert any(n.level == "error" and n.title == "Models not loaded" for n in notices)
    # Capture & map after the failure: tries again, fails with the same reason, reported not raised
    job = MappingJob(session, robot.capture, perceiver, preload)
    assert job.run() is False
    assert session.job.name == JOB_NAME and "morphonavi models fetch" in (session.job.error or "")


def test_the_console_starts_and_stays_up_when_the_weights_are_missing(tmp_path: Path, robot: SimRobot) -> None:
    perceiver = MapperPerceiver("offline models", OfflineModels(tmp_path / "no-models"))
    app = ConsoleApp(ConsoleConfig(robot="sim", session_dir=tmp_path / "session", scene_dir=tmp_path / "scenes",
                                   port=0, fresh=True, record=False), link=robot, perceiver=perceiver)
    app.start()
    try:
        assert app.preload is not None
        assert _wait_until(lambda: app.preload.state == "failed")
        assert app.session is not None
        assert _wait_until(lambda: app.session.job.error is not None)
        assert app.session.job.name == PRELOAD_NAME and "morphonavi models fetch" in app.session.job.error
        # the page's job line (the view's markdown handle) shows the failure and its cure
        assert _wait_until(lambda: "failed" in app._job_md.content and "models fetch" in app._job_md.content)
        with urllib.request.urlopen(app.url, timeout=30) as page:  # the page is still served
            assert page.status == 200
    finally:
        app.stop()


def test_ground_truth_perception_is_ready_at_start(tmp_path: Path, robot: SimRobot) -> None:
    session = Session(tmp_path / "session")
    jobs, _ = _record(session)
    preload = ModelPreload(session, MapperPerceiver(GROUND_TRUTH_LABEL, ground_truth_bundle_for))
    assert preload.state == "idle"
    preload.start()
    assert _wait_until(lambda: preload.state == "ready")
    assert _wait_until(lambda: not session.job.running and session.job.name == PRELOAD_NAME)
    assert session.job.error is None and session.job.message.startswith("models ready in")
    assert any(j.running and j.name == PRELOAD_NAME for j in jobs)  # progress was shown while loading


def test_a_capture_requested_while_the_models_load_waits_for_them_and_says_so(tmp_path: Path, robot: SimRobot) -> None:
    reason = _offline_missing()
    if reason:
        pytest.skip(reason)
    session = Session(tmp_path / "session")
    jobs, _ = _record(session)
    models = OfflineModels(SHARED_MODELS)
    perceiver = MapperPerceiver("offline models", models)
    preload = ModelPreload(session, perceiver)  # not started yet: the capture surely comes first
    job = MappingJob(session, robot.capture, perceiver, preload)
    assert job.start()
    assert _wait_until(lambda: session.job.message.startswith(WAITING_TEXT))
    assert job.running and session.job.name == JOB_NAME
    preload.start()
    assert _wait_until(lambda: not job.running, 600.0)
    assert session.job.error is None, session.job
    assert preload.state == "ready"
    messages = [j.message for j in jobs]
    waiting = [m for m in messages if m.startswith(WAITING_TEXT)]
    # the loading steps were shown in the capture's own status, not as a separate job
    assert any("first run of the segmenter" in m for m in waiting)
    assert all(j.name == JOB_NAME for j in jobs)
    last_wait = max(i for i, m in enumerate(messages) if m.startswith(WAITING_TEXT))
    stage_at = [messages.index(STAGE_TEXT[s]) for s in STAGES]
    assert last_wait < stage_at[0] and stage_at == sorted(stage_at)  # perception only once the models are in
    assert session.capture is not None and "detect" in session.capture.timings


def test_preloaded_models_are_the_ones_the_capture_uses(tmp_path: Path, robot: SimRobot) -> None:
    reason = _offline_missing()
    if reason:
        pytest.skip(reason)
    session = Session(tmp_path / "session")
    jobs, _ = _record(session)
    models = OfflineModels(SHARED_MODELS)
    preload = ModelPreload(session, MapperPerceiver("offline models", models))
    preload.start()
    assert _wait_until(lambda: preload.state == "ready", 600.0)
    bundle = models(robot.capture())  # what a capture gets: the bundle loaded at start, not a new one
    assert models(robot.capture()) is bundle
    preload_steps = [j.message for j in jobs if j.name == PRELOAD_NAME and j.running]
    for step in ("loading YOLOX-Nano", "first run of the detector", "first run of the depth model",
                 "first run of the segmenter"):
        assert any(step in m for m in preload_steps), (step, preload_steps)
    fr = [j.fraction for j in jobs if j.name == PRELOAD_NAME and j.running]
    assert fr == sorted(fr)


class _GatedPerceiver:
    """A perceiver whose loading ends only when the test says so."""

    label = "gated"

    def __init__(self) -> None:
        import threading

        self.release = threading.Event()

    def preload(self, progress: Callable[[float, str], None]) -> None:
        progress(0.5, "loading the gated model")
        assert self.release.wait(120), "the test never released the loading"


def test_a_loading_that_ends_during_a_capture_does_not_take_over_its_progress_bar(tmp_path: Path) -> None:
    """The start-up loading's status is a background job: once a capture has reported, the bar is the
    capture's (a late 'models ready' no longer replaced a running capture's progress)."""
    session = Session(tmp_path / "s")
    perceiver = _GatedPerceiver()
    preload = ModelPreload(session, perceiver)
    preload.start()
    assert _wait_until(lambda: session.job.name == PRELOAD_NAME and session.job.running)
    session.set_job(JobStatus(JOB_NAME, True, 0.3, "asking the robot for a photo"))  # a capture starts
    perceiver.release.set()
    assert preload.join(60) and preload.state == "ready"
    assert session.job.name == JOB_NAME and session.job.running and session.job.fraction == 0.3, session.job


def test_the_offline_label_says_whether_the_open_images_ssd_runs(tmp_path: Path) -> None:
    from console.session.mapping_job import offline_models_label

    assert offline_models_label(tmp_path) == "YOLOX-Nano, MobileSAM, FastDepth"  # only tmp_path is searched
    ssd = tmp_path / "oidv4_ssd"
    ssd.mkdir()
    for name in ("oidv4_ssd.onnx", "labelmap.txt"):
        (ssd / name).write_bytes(b"x")
    assert offline_models_label(tmp_path) == "YOLOX-Nano + Open Images SSD, MobileSAM, FastDepth"
