"""Pop-up notifications: for the one browser tab an operator action came from, how long they stay,
and where the page shows them (with the "disconnected" banner).

Errors (red) stay until the operator closes them; everything else closes by itself. The page
shows notifications at the bottom right of the 3D view, beside the control panel, never over the
middle or the upper left of the view where the operator clicks goals.
"""

from __future__ import annotations

from typing import Any

INFO_SECONDS = 6.0
"""How long a notification that is not an error stays [s]."""

_DEFAULT = object()


def notice_seconds(color: str) -> float | None:
    """How long a notification of ``color`` stays [s]; ``None`` (until closed) for errors (red)."""
    return None if color == "red" else INFO_SECONDS


def tell(client: Any, title: str, body: str, color: str = "blue", seconds: Any = _DEFAULT) -> None:
    """Show ``title`` / ``body`` in ``client``'s tab (nothing when the event had no client).

    ``seconds`` [s] before it closes by itself; by default :func:`notice_seconds` of the colour.
    """
    if client is not None:
        wait = notice_seconds(color) if seconds is _DEFAULT else seconds
        client.add_notification(title, body, color=color, auto_close_seconds=wait)


DISCONNECTED_TEXT = "Disconnected from the MorphoNavi console server: reconnecting… (the view is frozen)"


def page_style(right_panel_px: int) -> str:
    """HTML (a ``<style>`` block) that places notifications and shows a banner while disconnected.

    Notifications go to the bottom right of the 3D view, left of the right-docked control panel
    ``right_panel_px`` [px] wide. The banner: viser greys out and disables its GUI while the
    websocket is down (its ``DisconnectedGate`` wrapper gets ``pointer-events: none``); a CSS
    ``:has()`` rule on that state shows a red bar across the top of the page, gone on reconnect.
    """
    text = DISCONNECTED_TEXT.replace("\\", "\\\\").replace('"', '\\"')
    return f"""<style>
.mantine-Notifications-root {{
  top: auto !important; left: auto !important;
  bottom: 1em !important; right: calc({int(right_panel_px)}px + 1em) !important;
}}
body:has(div[style*="pointer-events: none"][style*="opacity: 0.5"])::before {{
  content: "{text}";
  position: fixed; top: 0; left: 0; right: 0; z-index: 100000; padding: 0.6em 1em;
  background: #c92a2a; color: white; font: 600 15px/1.3 sans-serif; text-align: center;
  box-shadow: 0 2px 8px rgba(0, 0, 0, 0.3);
}}
</style>"""
