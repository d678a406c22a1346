"""A console (or a replay) asked for a port that is in use listens on the next free one, and says so on start-up in
one line before its address ("port 8080 is in use: the console is on 8081"); before, only the printed address
differed from the one asked for."""

from __future__ import annotations

import os
import re
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path
from typing import Iterator

import pytest

from console.cli.port_note import moved_port_line

REPO = Path(__file__).resolve().parents[3]


def test_the_line_names_the_port_asked_for_and_the_one_taken() -> None:
    assert moved_port_line(8080, 8081) == "port 8080 is in use: the console is on 8081"
    assert moved_port_line(8080, 8082, "replay") == "port 8080 is in use: the replay is on 8082"
    assert moved_port_line(8080, 8080) is None  # where it was asked: nothing to say
    assert moved_port_line(0, 43117) is None  # --port 0 asks for any free port


def test_a_low_port_without_root_is_named_as_such(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(os, "geteuid", lambda: 1000, raising=False)
    assert moved_port_line(80, 1024) == "port 80 needs root (ports below 1024): the console is on 1024"
    monkeypatch.setattr(os, "geteuid", lambda: 0, raising=False)
    assert moved_port_line(80, 81) == "port 80 is in use: the console is on 81"


@pytest.fixture()
def busy_port() -> Iterator[int]:
    """A port on 127.0.0.1 that another program listens on (this test) while the test runs."""
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.bind(("127.0.0.1", 0))
        s.listen(1)
        yield int(s.getsockname()[1])


def test_a_console_on_a_busy_port_says_where_it_is(tmp_path: Path, busy_port: int, monkeypatch: pytest.MonkeyPatch,
                                                    capsys: pytest.CaptureFixture[str]) -> None:
    session = tmp_path / "session"
    env = {**os.environ, "PYTHONUNBUFFERED": "1"}
    proc = subprocess.Popen([sys.executable, "-m", "console.cli.morphonavi", "console", "--port", str(busy_port),
                             "--session", str(session), "--scene", str(tmp_path / "scenes"), "--fresh"], cwd=REPO,
                            env=env, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True)
    try:
        deadline = time.monotonic() + 180  # a loaded 2-core machine: the start takes seconds, sometimes many
        lines: list[str] = []
        assert proc.stdout is not None
        while not any("open http" in line for line in lines) and time.monotonic() < deadline and proc.poll() is None:
            lines.append(proc.stdout.readline())
        url = next((line for line in lines if "open http" in line), None)
        assert url is not None, lines
        bound = int(re.search(r"http://127\.0\.0\.1:(\d+)/", url).group(1))  # type: ignore[union-attr]
        assert bound != busy_port
        note = f"port {busy_port} is in use: the console is on {bound}\n"
        assert note in lines and lines.index(note) == lines.index(url) - 1, lines  # one line, just before the address
        proc.send_signal(signal.SIGTERM)
        proc.communicate(timeout=120)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    assert proc.returncode == 0

    # the session's recording replayed on the same busy port: the replay says where it is too
    from console.cli.morphonavi import main
    from console.recording.replay_app import ReplayApp

    rec = next((session / "recordings").glob("*.mcap"))
    monkeypatch.setattr(ReplayApp, "serve_forever", lambda self: self.stop())  # started, printed, stopped at once
    assert main(["replay", str(rec), "--port", str(busy_port)]) == 0
    out = capsys.readouterr().out.splitlines()
    moved = [line for line in out if line.startswith(f"port {busy_port} is in use: the replay is on ")]
    assert len(moved) == 1, out
    port = moved[0].rsplit(" ", 1)[1]
    assert f":{port}/ in a browser" in out[out.index(moved[0]) + 1]
