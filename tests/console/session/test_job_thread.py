"""The background jobs' shared shape (console/session/job_thread.py): start, Pause / Resume / Stop at the
worker's pause points, wait, and 'not running' as soon as the run says it ended (its thread may still be
finishing). Every wait here is on an event or the job's state, with a generous deadline."""

from __future__ import annotations

import threading
from types import SimpleNamespace
from typing import Any

import pytest

from console.session.job_thread import BackgroundRun, JobThread
from console.session.session import JobStatus, SessionError

DEADLINE = 60.0  # [s] a loaded machine is slow; a passing run takes milliseconds


class _Session:
    """Records each job update with what the job's ``running`` / ``paused`` read at that moment."""

    def __init__(self) -> None:
        self.job_obj: Any = None
        self.updates: list[tuple[str, bool, bool, bool]] = []  # (message, status.running, job.running, job.paused)
        self.changed = threading.Condition()

    def set_job(self, status: JobStatus) -> None:
        with self.changed:
            self.updates.append((status.message, status.running, self.job_obj.running, self.job_obj.paused))
            self.changed.notify_all()

    def wait_for(self, message: str) -> tuple[str, bool, bool, bool]:
        with self.changed:
            assert self.changed.wait_for(lambda: any(u[0] == message for u in self.updates), DEADLINE), self.updates
            return next(u for u in self.updates if u[0] == message)


class _StepJob(JobThread):
    """A worker of ``steps`` steps, each one a pause point; after saying it ended it waits for ``linger``."""

    def __init__(self, session: _Session, steps: int = 3) -> None:
        # re-entrant: the recording session reads ``running`` during the 'starting' update, under the start's lock
        super().__init__(session, threading.RLock())  # type: ignore[arg-type]
        session.job_obj = self
        self.steps = steps
        self.go = threading.Semaphore(0)  # one release lets the worker take one step
        self.linger = threading.Event()  # the thread finishes after its last update once this is set
        self.done: list[int] = []

    def start(self) -> None:
        with self._lock:
            assert not self._alive()
            self.done = []
            self._launch(self._run, "step-job",
                         announce=lambda: self._set_job(JobStatus("steps", True, 0.0, "starting")))

    def _run(self) -> None:
        for i in range(self.steps):
            assert self.go.acquire(timeout=DEADLINE)
            if not self._wait_resumed(lambda: self._set_job(JobStatus("steps", True, 0.5, f"paused before {i}"))):
                self._set_job(JobStatus("steps", False, 1.0, f"stopped before {i}"))
                break
            self.done.append(i)
            self._set_job(JobStatus("steps", True, (i + 1) / self.steps, f"step {i}"))
        else:
            self._set_job(JobStatus("steps", False, 1.0, "done"))
        self.linger.wait(DEADLINE)


def test_a_run_starts_announced_then_pauses_resumes_and_ends_not_running_while_its_thread_finishes() -> None:
    s = _Session()
    job = _StepJob(s)
    assert not job.running and not job.paused and job.wait(0)  # nothing ran yet
    job.start()
    assert job.running and not job.paused
    assert [u[:2] for u in s.updates] == [("starting", True)]  # announced before the worker's first line
    job.go.release()
    s.wait_for("step 0")
    job._request_pause()
    assert job.paused
    job.go.release()
    assert s.wait_for("paused before 1") == ("paused before 1", True, True, True)  # said once at the pause point
    assert job.done == [0]  # held at the pause point
    assert not job.wait(0.05)  # a paused run is still under way
    job._request_resume()
    job.go.release()
    s.wait_for("step 2")
    assert [u[0] for u in s.updates].count("paused before 1") == 1
    assert not job.paused and job.done == [0, 1, 2]
    end = s.wait_for("done")
    assert end == ("done", False, False, False)  # the last update already reads: not running, not paused
    assert job._thread is not None and job._thread.is_alive()  # though the thread is still finishing
    assert not job.running
    job.linger.set()
    assert job.wait(DEADLINE)


def test_stop_while_paused_ends_at_the_pause_point_and_a_new_run_starts_neither_paused_nor_stopped() -> None:
    s = _Session()
    job = _StepJob(s, steps=2)
    job.start()
    job._request_pause()
    job.go.release()
    s.wait_for("paused before 0")
    job._request_stop()  # wakes the paused worker at once
    assert s.wait_for("stopped before 0") == ("stopped before 0", False, False, False)
    assert job.done == []
    job.linger.set()
    assert job.wait(DEADLINE)
    job.linger.clear()
    s.updates.clear()
    job.start()  # the last run's Pause and Stop do not carry over
    assert job.running and not job.paused
    job.go.release()
    job.go.release()
    assert s.wait_for("done")[1:] == (False, False, False)
    assert job.done == [0, 1] and not any(u[0].startswith("paused") for u in s.updates)
    job.linger.set()
    assert job.wait(DEADLINE)


def test_a_background_run_with_a_reentrant_lock_may_read_itself_while_it_announces() -> None:
    run = BackgroundRun(threading.RLock())  # as Capture & map: its 'starting' listeners read the job
    release = threading.Event()
    seen: list[bool] = []
    with run._lock:
        run._launch(lambda: release.wait(DEADLINE), "reentrant", announce=lambda: seen.append(run._alive()))
        assert run._alive()
    assert seen == [False]  # announced before the thread started
    assert run.running and not run.wait(0.01)
    release.set()
    assert run.wait(DEADLINE) and not run.running


def test_a_robot_job_refuses_to_start_while_it_runs_a_capture_is_mapped_a_mission_is_under_way_or_no_state() -> None:
    s = _Session()
    s.run = SimpleNamespace(active=False)  # type: ignore[attr-defined]
    job = _StepJob(s, steps=1)
    mapping = SimpleNamespace(running=False)
    state = SimpleNamespace(link_ok=True)
    link = SimpleNamespace(latest_state=lambda: state)
    assert job._robot_ready(link, mapping, "already", "testing") is state
    lost = SimpleNamespace(link_ok=False)
    for link_ in (None, SimpleNamespace(latest_state=lambda: None), SimpleNamespace(latest_state=lambda: lost)):
        with pytest.raises(SessionError, match="^no state from the robot: is the link connected\\?$"):
            job._robot_ready(link_, mapping, "already", "testing")
    s.run.active = True  # type: ignore[attr-defined]
    with pytest.raises(SessionError, match=r"a mission is under way \(running or paused\): abort it before testing"):
        job._robot_ready(link, mapping, "already", "testing")
    mapping.running = True
    with pytest.raises(SessionError, match="a capture is being mapped: wait for it"):
        job._robot_ready(link, mapping, "already", "testing")
    job.start()
    with pytest.raises(SessionError, match="^already$"):
        job._robot_ready(link, mapping, "already", "testing")
    job._request_stop()
    job.go.release()
    job.linger.set()
    assert job.wait(DEADLINE)
