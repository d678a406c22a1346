"""The start-up line that says the console is not on the port asked for.

viser, asked for a port it cannot listen on (another console, another program, or a port below 1024 without
root), silently listens on the next free one; the console prints this line before its address so that the
operator does not open the old address (another console, or nothing).
"""

from __future__ import annotations

import os


def moved_port_line(asked: int, bound: int, what: str = "console") -> str | None:
    """``"port 8080 is in use: the console is on 8081"`` when ``bound`` (the port listened on) is not ``asked``
    (``--port``; 0 asks for any free port: never moved); ``None`` otherwise. A port below 1024 asked without
    root is named as such (the system refuses it, whether in use or not). ``what`` names the server."""
    asked, bound = int(asked), int(bound)
    if asked == 0 or asked == bound:
        return None
    root = getattr(os, "geteuid", lambda: 0)() == 0
    why = "is in use" if asked >= 1024 or root else "needs root (ports below 1024)"
    return f"port {asked} {why}: the {what} is on {bound}"


__all__ = ["moved_port_line"]
