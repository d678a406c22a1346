"""Starting Capture & map while the session's listeners read the job (the held-capture buttons do, on
every job report): no deadlock. ``start()`` reports 'starting' before its thread runs, under the
job's lock; a listener asking ``held`` in that same call must not wait for that lock forever."""

from __future__ import annotations

import threading
from pathlib import Path

from console.session.mapping_job import JOB_NAME, MappingJob
from console.session.session import JOB, Session


def test_a_listener_reading_the_job_during_start_does_not_deadlock(tmp_path: Path) -> None:
    session = Session(tmp_path / "session")
    job = MappingJob(session, lambda: None, None)  # type: ignore[arg-type]  # the run fails at once: no photo
    seen: list[tuple[str, str | None]] = []
    session.subscribe(lambda topic, payload: seen.append((payload.message, job.held)) if topic == JOB else None)
    starter = threading.Thread(target=job.start, daemon=True)
    starter.start()
    starter.join(60)
    assert not starter.is_alive(), "MappingJob.start() deadlocked with a listener reading job.held"
    assert job.wait(60)
    assert seen and seen[0] == ("starting", None)  # 'starting' reached the listener before the run
    assert session.job.name == JOB_NAME
