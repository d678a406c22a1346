"""Found by trying the console as a newcomer: `kill PID` (SIGTERM, what service managers and `kill`
send) left the session's recording unfinished (no MCAP footer), so `morphonavi replay` refused it."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[3]


def test_sigterm_stops_the_console_cleanly_and_finishes_the_recording(tmp_path: Path) -> None:
    session = tmp_path / "session"
    env = {**os.environ, "PYTHONUNBUFFERED": "1"}
    proc = subprocess.Popen([sys.executable, "-m", "console.cli.morphonavi", "console", "--port", "0", "--session", str(session),
                             "--scene", str(tmp_path / "scenes"), "--fresh"], cwd=REPO, env=env,
                            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    try:
        deadline = time.monotonic() + 120
        seen = ""
        assert proc.stdout is not None
        while "open http" not in seen and time.monotonic() < deadline and proc.poll() is None:
            seen += proc.stdout.readline()
        assert "open http" in seen, seen
        recs = list((session / "recordings").glob("*.mcap"))
        assert len(recs) == 1
        proc.send_signal(signal.SIGTERM)
        out, _ = proc.communicate(timeout=120)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    assert proc.returncode == 0, out
    assert "Traceback" not in out, out
    data = recs[0].read_bytes()
    assert data.endswith(b"\x89MCAP0\r\n"), "the recording has no footer: it was not finished"
