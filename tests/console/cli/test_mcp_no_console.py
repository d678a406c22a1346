"""``morphonavi mcp --session DIR`` with no console running on DIR: one line saying what is wrong and what to do
(start a console on DIR), no traceback and no errno, whether the folder never had a console or holds the address
file of one that died (its port closed). Typed in a terminal it stops at once (exit status 2); started by an MCP
client (stdin a pipe) it serves and every tool answers that line, and exits with status 2 when the client leaves
before any console answered. Run as a subprocess, as a user or a desktop client starts it. Skipped without the
``mcp`` package (the command then says how to install it)."""

from __future__ import annotations

import json
import os
import socket
import subprocess
import sys
from pathlib import Path

import pytest

pytest.importorskip("mcp.server.mcpserver", reason="the mcp package is not installed (pip install 'mcp>=2.3,<3')")
REPO = Path(__file__).resolve().parents[3]
DEADLINE = 180.0  # [s] generous: the machine may be loaded (the command only imports and reads a file)


def _mcp(folder: Path, terminal: bool = False) -> subprocess.CompletedProcess[str]:
    """Run ``morphonavi mcp``: stdin a closed pipe (an MCP client that leaves at once), or a terminal."""
    cmd = [sys.executable, "-m", "console.cli.morphonavi", "mcp", "--session", str(folder)]
    if not terminal:
        return subprocess.run(cmd, cwd=REPO, stdin=subprocess.DEVNULL, capture_output=True, text=True, timeout=DEADLINE)
    import pty

    main_fd, tty_fd = pty.openpty()
    try:
        return subprocess.run(cmd, cwd=REPO, stdin=tty_fd, capture_output=True, text=True, timeout=DEADLINE)
    finally:
        os.close(main_fd)
        os.close(tty_fd)


def _refused(proc: subprocess.CompletedProcess[str], prefix: str = "morphonavi mcp: waiting: ") -> str:
    """The one line ``proc`` said (after ``prefix``), checking exit status 2, no traceback, nothing on stdout."""
    assert proc.returncode == 2, (proc.returncode, proc.stderr)
    err = proc.stderr
    assert "Traceback" not in err and "Errno" not in err and "[" not in err, err
    assert len(err.strip().splitlines()) == 1, err  # one line
    assert proc.stdout == "", proc.stdout  # stdout is for MCP only
    assert err.startswith(prefix), err
    return err.strip()[len(prefix):].removesuffix("; every tool answers so until then")


def _closed_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def test_no_console_ever_ran_on_the_folder(tmp_path: Path) -> None:
    folder = tmp_path / "session"
    folder.mkdir()
    said = f"no console is running on the session folder {folder}: start one with `morphonavi console --session {folder}`"
    assert _refused(_mcp(folder)) == said
    assert _refused(_mcp(folder, terminal=True), "morphonavi mcp: error: ") == said  # typed: stops at once


def test_the_console_that_wrote_the_address_file_is_gone(tmp_path: Path) -> None:
    folder = tmp_path / "session"
    folder.mkdir()
    url = f"http://127.0.0.1:{_closed_port()}"
    (folder / ".agent.json").write_text(json.dumps({"url": url, "token": "t", "pid": 1, "robot": "sim"}))
    err = _refused(_mcp(folder))
    assert err == (f"no console is running on the session folder {folder} (.agent.json names "
                   f"{url}, which does not answer: connection refused): start one with "
                   f"`morphonavi console --session {folder}`"), err


def test_a_damaged_address_file_says_to_restart_the_console(tmp_path: Path) -> None:
    folder = tmp_path / "my session"  # a folder name with a space: the command to run is quoted
    folder.mkdir()
    (folder / ".agent.json").write_text('{"url": ')
    err = _refused(_mcp(folder))
    assert err.startswith(f"{folder / '.agent.json'}: not the address file a console writes"), err
    assert err.endswith(f"restart the console (`morphonavi console --session '{folder}'`)"), err


def test_an_mcp_client_started_before_the_console_hears_what_to_do(tmp_path: Path) -> None:
    """A desktop client starts its servers when it starts: the server stays, and each tool says what to do."""
    import anyio
    from mcp.client.session import ClientSession
    from mcp.client.stdio import StdioServerParameters, stdio_client

    folder = tmp_path / "s"
    folder.mkdir()

    async def agent() -> str:
        params = StdioServerParameters(command=sys.executable, cwd=str(REPO),
                                       args=["-m", "console.cli.morphonavi", "mcp", "--session", str(folder)])
        async with stdio_client(params) as (read, write), ClientSession(read, write) as client:
            await client.initialize()
            res = await client.call_tool("get_scene_summary", {})
            assert res.is_error
            return res.content[0].text

    text = anyio.run(agent)
    assert f"no console is running on the session folder {folder}" in text and "morphonavi console --session" in text
