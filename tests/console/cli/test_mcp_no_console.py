"""``morphonavi mcp --session DIR`` with no console running on DIR stops at once: one line saying what is wrong
and what to do (start a console on DIR), exit status 2, no traceback and no errno, whether the folder never had
a console or holds the address file of one that died (its port closed). Run as a subprocess, as a user or a
desktop client starts it. Skipped without the ``mcp`` package (the command then says how to install it)."""

from __future__ import annotations

import json
import socket
import subprocess
import sys
from pathlib import Path

import pytest

pytest.importorskip("mcp.server.mcpserver", reason="the mcp package is not installed (pip install 'mcp>=2.3,<3')")
REPO = Path(__file__).resolve().parents[3]
DEADLINE = 180.0  # [s] generous: the machine may be loaded (the command only imports and reads a file)


def _mcp(folder: Path) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "console.cli.morphonavi", "mcp", "--session", str(folder)],
                          cwd=REPO, stdin=subprocess.DEVNULL, capture_output=True, text=True, timeout=DEADLINE)


def _refused(proc: subprocess.CompletedProcess[str]) -> str:
    assert proc.returncode == 2, (proc.returncode, proc.stderr)
    err = proc.stderr
    assert "Traceback" not in err and "Errno" not in err and "[" not in err, err
    assert len(err.strip().splitlines()) == 1, err  # one line
    assert proc.stdout == "", proc.stdout  # stdout is for MCP only
    return err.strip()


def _closed_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def test_no_console_ever_ran_on_the_folder(tmp_path: Path) -> None:
    folder = tmp_path / "session"
    folder.mkdir()
    err = _refused(_mcp(folder))
    assert err == (f"morphonavi mcp: error: no console is running on the session folder {folder}: start one with "
                   f"`morphonavi console --session {folder}`"), err


def test_the_console_that_wrote_the_address_file_is_gone(tmp_path: Path) -> None:
    folder = tmp_path / "session"
    folder.mkdir()
    url = f"http://127.0.0.1:{_closed_port()}"
    (folder / ".agent.json").write_text(json.dumps({"url": url, "token": "t", "pid": 1, "robot": "sim"}))
    err = _refused(_mcp(folder))
    assert err == (f"morphonavi mcp: error: no console is running on the session folder {folder} (.agent.json names "
                   f"{url}, which does not answer: connection refused): start one with "
                   f"`morphonavi console --session {folder}`"), err


def test_a_damaged_address_file_says_to_restart_the_console(tmp_path: Path) -> None:
    folder = tmp_path / "my session"  # a folder name with a space: the command to run is quoted
    folder.mkdir()
    (folder / ".agent.json").write_text('{"url": ')
    err = _refused(_mcp(folder))
    assert err.startswith(f"morphonavi mcp: error: {folder / '.agent.json'}: not the address file a console writes"), err
    assert err.endswith(f"restart the console (`morphonavi console --session '{folder}'`)"), err
