"""A pop-up notification for the one browser tab an operator action came from."""

from __future__ import annotations

from typing import Any


def tell(client: Any, title: str, body: str, color: str = "blue", seconds: float | None = 6.0) -> None:
    """Show ``title`` / ``body`` in ``client``'s tab (nothing when the event had no client)."""
    if client is not None:
        client.add_notification(title, body, color=color, auto_close_seconds=seconds)
