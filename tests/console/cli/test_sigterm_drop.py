"""SIGTERM while the console handles a large dropped scene file ends the process cleanly (it aborted with
"FATAL: exception not rethrown", exit -6, when the watcher thread was killed inside a library call)."""

from __future__ import annotations

import json
import os
import random
import signal
import subprocess
import sys
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[3]


def _boxes(n: int, seed: int) -> dict:
    rng = random.Random(seed)
    return {"version": 1, "objects": [
        {"id": f"box-{seed}-{i}", "label": "cardboard_box", "position": [rng.uniform(0.3, 4.7), rng.uniform(1.5, 7.7),
                                                                          0.2],
         "size": [0.3, 0.4, 0.3], "source": {"method": "ground_truth"}} for i in range(n)]}


def test_sigterm_during_a_dropped_file_exits_cleanly(tmp_path: Path) -> None:
    session, scenes = tmp_path / "session", tmp_path / "scenes"
    scenes.mkdir()
    env = {**os.environ, "PYTHONUNBUFFERED": "1"}
    proc = subprocess.Popen([sys.executable, "-m", "console.cli.morphonavi", "console", "--port", "0", "--session",
                             str(session), "--scene", str(scenes), "--fresh", "--no-record"], cwd=REPO, env=env,
                            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    seen = ""
    try:
        assert proc.stdout is not None
        deadline = time.monotonic() + 180
        while "open http" not in seen and time.monotonic() < deadline and proc.poll() is None:
            seen += proc.stdout.readline()
        assert "open http" in seen, seen
        (scenes / "a.json").write_text(json.dumps(_boxes(400, 1)))
        while "spawned" not in seen and time.monotonic() < deadline and proc.poll() is None:
            seen += proc.stdout.readline()
        assert "spawned" in seen, seen
        (scenes / "b.json").write_text(json.dumps(_boxes(400, 2)))  # merged into the 400 already there
        t = time.time() - 5
        os.utime(scenes / "b.json", (t, t))  # settled: read on the next pass
        proc.send_signal(signal.SIGTERM)
        out, _ = proc.communicate(timeout=300)
        seen += out
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    assert proc.returncode == 0, seen
    assert "FATAL" not in seen and "Traceback" not in seen, seen
