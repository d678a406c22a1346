"""``morphonavi mcp``: the MCP server for language-model agents, attached to a running console.

It speaks MCP over stdio (what desktop clients start) or, with ``--http PORT``, streamable HTTP on
127.0.0.1, and forwards every tool to the console whose session folder is ``--session`` (default
``.morphonavi/session``) through that console's loopback control API (:mod:`console.mcp.control_api`).
Reading and the safety tools (Hold, Land here, Return) are always on; the proposal tools only with
``--allow-actions``, and then every action waits for the operator's Approve in the console. With no
console running on ``--session``: started from a terminal (or with ``--http``) it stops at once, saying so in
one line (exit status 2); started by an MCP client (stdin a pipe) it serves and every tool answers that line
until a console starts (exit status 2 if none ever answered). Once attached it outlives console restarts.
Registered by :mod:`console.cli.morphonavi`. Nothing is printed on stdout but MCP (stdio).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

INSTALL_HINT = "pip install 'mcp>=2.3,<3' (or: pip install 'morphonavi[agents]')"


def need_mcp(what: str) -> None:
    """Raise :class:`~console.cli.errors.CliError` saying how to install the MCP SDK when it is missing."""
    from console.cli.errors import CliError

    try:
        import mcp.server.mcpserver  # noqa: F401
    except ImportError:
        raise CliError(f"{what} needs the MCP Python SDK (mcp 2.x), which is not installed: {INSTALL_HINT}") from None


def _port(text: str) -> int:
    try:
        v = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a TCP port number, got {text!r}") from None
    if not 0 < v <= 65535:
        raise argparse.ArgumentTypeError(f"port must be within 1..65535, got {v}")
    return v


def cmd_mcp(args: argparse.Namespace) -> int:
    import logging

    from console.cli.cli_args import DEFAULT_SESSION  # noqa: F401 (same default folder)
    from console.cli.errors import CliError
    from console.mcp.control_api import ConsoleBridge, ConsoleUnavailable

    need_mcp("morphonavi mcp")
    from console.mcp.server import make_server

    logging.basicConfig(level=logging.WARNING, stream=sys.stderr, format="morphonavi mcp: %(levelname)s %(message)s")
    session = Path(args.session)
    if session.exists() and not session.is_dir():
        from console.cli.console_folders import not_a_folder

        raise CliError(not_a_folder("--session", session, "give the session folder of the running console",
                                    str(session.parent)))
    if not session.is_dir():
        raise CliError(f"--session {session}: no such folder (start `morphonavi console --session {session}` first)")
    bridge = ConsoleBridge(session, args.allow_actions)
    try:
        status = bridge.call("status")
    except ConsoleUnavailable as exc:
        if args.http is not None or sys.stdin.isatty():  # a person started it: one line, exit status 2
            raise CliError(str(exc)) from None
        # an MCP client started it (stdin is its pipe), maybe before the console: serve, every tool answers
        # this line until a console starts on the folder (clients do not restart a server that exits)
        print(f"morphonavi mcp: waiting: {exc}; every tool answers so until then", file=sys.stderr)
        status = None
    if status is not None:
        real = status.get("real_vehicle_link") and not status.get("proposals_allowed_on_this_link")
        print(f"morphonavi mcp: attached to the console on {session} (robot {status.get('robot')}); "
              f"proposal tools {'on' if args.allow_actions else 'off (--allow-actions)'}"
              + ("; the console refuses proposals on this real vehicle link (console --agent-real-vehicle)" if real
                 and args.allow_actions else ""), file=sys.stderr)
    server = make_server(bridge, allow_actions=args.allow_actions)
    if args.http is None:
        server.run("stdio")
        return 0 if bridge.answered else 2  # the client left before any console answered: not a success
    else:
        print(f"morphonavi mcp: serving MCP at http://127.0.0.1:{args.http}/mcp (Ctrl-C to stop)", file=sys.stderr)
        try:
            server.run("streamable-http", host="127.0.0.1", port=args.http)
        except KeyboardInterrupt:
            pass
    return 0


def add_mcp_parser(sub: argparse._SubParsersAction) -> argparse.ArgumentParser:  # type: ignore[type-arg]
    """Register ``morphonavi mcp``."""
    from console.cli.cli_args import DEFAULT_SESSION

    p = sub.add_parser(
        "mcp", help="MCP server for language-model agents, attached to a running console (stdio; --http)",
        description="Serve the Model Context Protocol to a language-model agent (Claude Desktop, Codex, local "
                    "models) attached to the running console of --session: read the map, the robot and the mission; "
                    "Hold, Land here and Return at once; with --allow-actions propose paths, captures and missions "
                    "that the operator approves or rejects in the console. Speaks stdio unless --http PORT. With no "
                    "console on --session it stops (exit status 2) when started from a terminal or with --http; "
                    "started by an MCP client it waits, every tool saying so, until a console starts.")
    p.add_argument("--session", type=Path, default=DEFAULT_SESSION, metavar="DIR",
                   help=f"session folder of the running console (default {DEFAULT_SESSION})")
    p.add_argument("--allow-actions", action="store_true",
                   help="offer the proposal tools (plan_to_object, plan_to_point, propose_mission, "
                        "propose_capture_and_map); every action still waits for the operator's Approve")
    p.add_argument("--http", type=_port, default=None, metavar="PORT",
                   help="serve streamable HTTP on 127.0.0.1:PORT/mcp instead of stdio")
    p.set_defaults(func=cmd_mcp)
    return p


__all__ = ["INSTALL_HINT", "add_mcp_parser", "cmd_mcp", "need_mcp"]
