"""Wire the agent interface into a running console: the door, its control API, the Agent panel and,
with ``console --mcp PORT``, the MCP server itself (streamable HTTP on 127.0.0.1).

Called once by :meth:`console.app.ConsoleApp.start`. The control API always runs (loopback only, a
token in ``<session>/.agent.json``) so ``morphonavi mcp`` can attach to the console; the MCP server
runs in the console only when asked.
"""

from __future__ import annotations

import logging
import threading
import time
from typing import Any

from console.mcp.control_api import ControlAPI, LocalBridge
from console.mcp.door import AgentDoor

log = logging.getLogger(__name__)


class HttpHost:
    """An MCP server served over streamable HTTP by uvicorn on a thread (``http://127.0.0.1:PORT/mcp``).

    Args:
        mcp: The :class:`mcp.server.mcpserver.MCPServer`.
        port: TCP port on 127.0.0.1 (0: any free port).
    """

    def __init__(self, mcp: Any, port: int = 0) -> None:
        import uvicorn

        if not (isinstance(port, int) and 0 <= port <= 65535):
            raise ValueError(f"--mcp: must be a TCP port from 0 to 65535, got {port!r}")
        app = mcp.streamable_http_app(host="127.0.0.1")
        self.server = uvicorn.Server(uvicorn.Config(app, host="127.0.0.1", port=port, log_level="warning",
                                                    lifespan="on"))
        self._thread = threading.Thread(target=self.server.run, name="mcp-http", daemon=True)

    def start(self, timeout: float = 30.0) -> "HttpHost":
        self._thread.start()
        end = time.monotonic() + timeout
        while not self.server.started:
            if not self._thread.is_alive():
                raise OSError(f"--mcp: the MCP server could not start on 127.0.0.1:{self.server.config.port} "
                              "(is the port in use?)")
            if time.monotonic() > end:
                raise OSError(f"--mcp: the MCP server did not start within {timeout:.0f} s")
            time.sleep(0.05)
        return self

    @property
    def port(self) -> int:
        return int(self.server.servers[0].sockets[0].getsockname()[1])

    @property
    def url(self) -> str:
        return f"http://127.0.0.1:{self.port}/mcp"

    def close(self) -> None:
        self.server.should_exit = True
        self._thread.join(10.0)


def attach_agent(app: Any) -> AgentDoor:
    """Open the agent door on ``app`` (a started :class:`~console.app.ConsoleApp`): control API, Agent
    panel, and the in-process MCP server when ``app.config.mcp_port`` is set. Closed with the app."""
    from console.views.approval_view import ApprovalView

    cfg, session = app.config, app.session
    door = AgentDoor(session, commands=getattr(app, "commands", None), runner=app.runner, mapping=app.mapping,
                     robot_spec=cfg.robot, real_vehicle=getattr(cfg, "agent_real_vehicle", False),
                     look=getattr(app, "look", None), search=getattr(app, "search", None))
    app._closers.append(door.close)
    app.agent = door
    view = ApprovalView(app.server, session, door)
    app.views["approval"] = view
    app._closers.append(view.close)
    try:
        api = ControlAPI(door, session.folder).start()
    except OSError as exc:  # a read-only session folder: the console goes on without `morphonavi mcp`
        log.warning("agent control API off: %s", exc)
    else:
        app._closers.append(api.close)
        app.agent_api = api
    port = getattr(cfg, "mcp_port", None)
    if port is not None:
        from console.mcp.server import make_server

        host = HttpHost(make_server(LocalBridge(door, getattr(cfg, "mcp_allow_actions", False))), port).start()
        app._closers.append(host.close)
        app.mcp_host = host
        log.info("MCP server (streamable HTTP) at %s%s", host.url,
                 "" if getattr(cfg, "mcp_allow_actions", False) else " (read and safety tools; --mcp-allow-actions for proposals)")
    return door


__all__ = ["HttpHost", "attach_agent"]
