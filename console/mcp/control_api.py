"""The console's loopback control API for ``morphonavi mcp``, and the client the MCP server uses.

A running console serves :class:`~console.mcp.door.AgentDoor` requests over HTTP on 127.0.0.1 only
(any free port), each one ``POST /call`` with the JSON ``{"op": ..., "args": {...}, "allow_actions":
bool}`` and the header ``Authorization: Bearer <token>``; the answer is ``{"ok": true, "result": ...}``
or ``{"ok": false, "error": "..."}``. The port and a fresh random token are written to
``<session>/.agent.json`` (mode 0600, removed when the console stops): whoever can read the session
folder can reach the door, no one else. ``morphonavi mcp --session DIR`` reads that file.

:class:`ConsoleBridge` (the MCP server's side) re-reads ``.agent.json`` when a call fails, so an MCP
server outlives console restarts; :class:`LocalBridge` calls a door in the same process (``console
--mcp``).
"""

from __future__ import annotations

import hmac
import json
import logging
import os
import secrets
import shlex
import socket
import threading
import urllib.error
import urllib.request
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from pathlib import Path
from typing import Any, Mapping

from console.mcp.door import AgentDoor, AgentError

log = logging.getLogger(__name__)

AGENT_FILE = ".agent.json"
"""Where a console writes its control API's address and token, in its session folder (a dot file: never
listed among the session's saved snapshots)."""
MAX_BODY = 1 << 20
"""Largest request body accepted [bytes]."""
CALL_TIMEOUT = 60.0
"""Longest wait for one answer from the console [s] (waits for decisions are shorter: door.WAIT_MAX)."""


class ConsoleUnavailable(AgentError):
    """No console answers on this session folder; the message says what to do."""


class ControlAPI:
    """Serves ``door`` on 127.0.0.1 and writes ``<session_dir>/.agent.json`` (see the module docstring)."""

    def __init__(self, door: AgentDoor, session_dir: str | Path) -> None:
        self.door = door
        self.file = Path(session_dir) / AGENT_FILE
        self.token = secrets.token_urlsafe(32)
        api = self

        class Handler(BaseHTTPRequestHandler):
            def log_message(self, fmt: str, *args: Any) -> None:  # quiet: the door announces every call
                log.debug("control API: " + fmt, *args)

            def do_POST(self) -> None:  # noqa: N802 (http.server's name)
                status, body = api._handle(self.path, self.headers, self.rfile)
                data = json.dumps(body).encode("utf-8")
                self.send_response(status)
                self.send_header("Content-Type", "application/json")
                self.send_header("Content-Length", str(len(data)))
                self.end_headers()
                try:
                    self.wfile.write(data)
                except (BrokenPipeError, ConnectionResetError):  # the MCP server stopped waiting (its agent left)
                    log.info("control API: the client left before the answer to %s", self.path)

        self.httpd = ThreadingHTTPServer(("127.0.0.1", 0), Handler)
        self.httpd.daemon_threads = True
        self.url = f"http://127.0.0.1:{self.httpd.server_address[1]}"
        self._thread = threading.Thread(target=self.httpd.serve_forever, name="agent-control-api", daemon=True)

    def start(self) -> "ControlAPI":
        data = json.dumps({"url": self.url, "token": self.token, "pid": os.getpid(), "robot": self.door.robot_spec})
        tmp = self.file.with_name(f"{AGENT_FILE}.{os.getpid()}")
        try:
            fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o600)
            with os.fdopen(fd, "w", encoding="utf-8") as f:
                f.write(data + "\n")
            os.replace(tmp, self.file)
        except OSError:
            self.httpd.server_close()
            raise
        self._thread.start()
        log.info("agent control API at %s (address and token in %s)", self.url, self.file)
        return self

    def close(self) -> None:
        try:
            if json.loads(self.file.read_text(encoding="utf-8")).get("token") == self.token:
                self.file.unlink()
        except (OSError, ValueError):
            pass
        self.httpd.shutdown()
        self.httpd.server_close()

    def _handle(self, path: str, headers: Any, rfile: Any) -> tuple[int, dict[str, Any]]:
        if path != "/call":
            return 404, {"ok": False, "error": f"unknown path {path!r}: POST /call"}
        given = str(headers.get("Authorization", ""))
        if not hmac.compare_digest(given.encode(), f"Bearer {self.token}".encode()):
            return 401, {"ok": False, "error": "wrong or missing token (read it from the session folder's .agent.json)"}
        try:
            length = int(headers.get("Content-Length", "0"))
        except ValueError:
            length = -1
        if not 0 < length <= MAX_BODY:
            return 400, {"ok": False, "error": f"request body: must be 1 to {MAX_BODY} bytes of JSON"}
        try:
            req = json.loads(rfile.read(length))
        except ValueError as exc:
            return 400, {"ok": False, "error": f"request body: not JSON: {exc}"}
        if not isinstance(req, dict) or not isinstance(req.get("args", {}), dict):
            return 400, {"ok": False, "error": "request body: must be {\"op\": ..., \"args\": {...}}"}
        try:
            result = self.door.call(req.get("op"), req.get("args") or {}, allow_actions=req.get("allow_actions") is True)
        except AgentError as exc:
            return 200, {"ok": False, "error": str(exc)}
        except Exception as exc:  # a bug must reach the agent as a message, not kill the console
            log.exception("agent request %r failed", req.get("op"))
            return 200, {"ok": False, "error": f"internal error: {exc}"}
        return 200, {"ok": True, "result": result}


def _quoted(path: Path) -> str:
    """``path`` as typed in a shell command (quoted when it holds spaces or the like)."""
    return shlex.quote(str(path))


def _words(exc: BaseException) -> str:
    """An OS error's reason in words, without its errno (``connection refused``, ``timed out``)."""
    reason = getattr(exc, "reason", exc)  # urllib's URLError wraps the socket's error
    if isinstance(reason, (TimeoutError, socket.timeout)):
        return "timed out"
    text = getattr(reason, "strerror", None) or str(reason) or type(reason).__name__
    return str(text).lower()


def _not_answering(session_dir: Path, url: str, exc: BaseException, hint: str) -> str:
    """Why the console of ``session_dir`` did not answer at ``url``, and what to do, in one line."""
    why = _words(exc)
    if why == "timed out":
        return (f"the console on the session folder {session_dir} did not answer at {url} within {CALL_TIMEOUT:.0f} s "
                "(busy or stopped): try again, or restart it")
    return (f"no console is running on the session folder {session_dir} ({AGENT_FILE} names {url}, which does not "
            f"answer: {why}): {hint}")


class LocalBridge:
    """Calls a door in this process (``console --mcp``)."""

    def __init__(self, door: AgentDoor, allow_actions: bool) -> None:
        self.door, self.allow_actions = door, bool(allow_actions)

    def call(self, op: str, args: Mapping[str, Any] | None = None) -> Any:
        return self.door.call(op, args or {}, allow_actions=self.allow_actions)


class ConsoleBridge:
    """Calls the console whose session folder is ``session_dir`` through its control API."""

    def __init__(self, session_dir: str | Path, allow_actions: bool) -> None:
        self.session_dir = Path(session_dir).expanduser()
        self.allow_actions = bool(allow_actions)
        self._where: tuple[str, str] | None = None
        self.answered = False  # True once a console answered a call (attached at least once)

    def _start_hint(self) -> str:
        return f"start one with `morphonavi console --session {_quoted(self.session_dir)}`"

    def _find(self) -> tuple[str, str]:
        f = self.session_dir / AGENT_FILE
        try:
            data = json.loads(f.read_text(encoding="utf-8"))
            url, token = str(data["url"]), str(data["token"])
        except FileNotFoundError:
            raise ConsoleUnavailable(f"no console is running on the session folder {self.session_dir}: "
                                     f"{self._start_hint()}") from None
        except OSError as exc:
            raise ConsoleUnavailable(f"{f}: cannot read it ({_words(exc)}): read it as the user who started the "
                                     "console, or restart the console") from None
        except (ValueError, KeyError, TypeError) as exc:
            raise ConsoleUnavailable(f"{f}: not the address file a console writes ({type(exc).__name__}): restart "
                                     f"the console (`morphonavi console --session {_quoted(self.session_dir)}`)") from None
        if not url.startswith("http://127.0.0.1:"):
            raise ConsoleUnavailable(f"{f}: the control API must be on 127.0.0.1, got {url!r}")
        return url, token

    def call(self, op: str, args: Mapping[str, Any] | None = None) -> Any:
        for attempt in (0, 1):  # a restarted console has a new port and token: read the file again once
            if self._where is None or attempt:
                self._where = self._find()
            url, token = self._where
            body = json.dumps({"op": op, "args": dict(args or {}), "allow_actions": self.allow_actions}).encode()
            req = urllib.request.Request(f"{url}/call", data=body, method="POST", headers={
                "Content-Type": "application/json", "Authorization": f"Bearer {token}"})
            try:
                with urllib.request.urlopen(req, timeout=CALL_TIMEOUT) as resp:  # noqa: S310 (loopback only)
                    answer = json.loads(resp.read())
            except urllib.error.HTTPError as exc:
                if exc.code == 401 and not attempt:
                    continue
                raise ConsoleUnavailable(f"the console refused the request: HTTP {exc.code}") from None
            except (urllib.error.URLError, ConnectionError, TimeoutError) as exc:
                if not attempt:
                    continue
                raise ConsoleUnavailable(_not_answering(self.session_dir, url, exc, self._start_hint())) from None
            self.answered = True
            if not answer.get("ok"):
                raise AgentError(str(answer.get("error", "refused")))
            return answer.get("result")
        raise ConsoleUnavailable(f"the console on {self.session_dir} does not answer")  # not reached


__all__ = ["AGENT_FILE", "ConsoleBridge", "ConsoleUnavailable", "ControlAPI", "LocalBridge"]
