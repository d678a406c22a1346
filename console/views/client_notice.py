"""Pop-up notifications: for the one browser tab an operator action came from, how long they stay,
which newer news replaces them, and where the page shows them (with the "disconnected" banner).

Every notification closes by itself: errors (red) after :data:`ERROR_SECONDS`, the rest after
:data:`INFO_SECONDS`. A notification about the same *subject* as one still shown in that tab
replaces it (a "Mission done" replaces the "Mission: walk refused" error before it; a second
"Capture & map failed" replaces the first), and a tab shows at most :data:`MAX_SHOWN`, the oldest
closed first: notices never stack over the 3D view. The page shows them at the bottom right of the
3D view, beside the control panel, never over the middle or the upper left where the operator
clicks goals, nor over the panel's mission buttons.

A capture's notice (and the Find panel's refusal of a target the perception cannot name) is short: a body longer than :data:`SHORT_CHARS` (subjects in :data:`SHORTENED`) is cut
to its summary (its first clause, up to the first "; ", or its first words) and says where the rest is; the whole text goes to the listeners of
:func:`on_long_notice` (the *Notices: full text* expander under **Capture & map**,
:mod:`console.views.notice_details`), one click away.

A tab whose connection is lost retries every second whether or not it has the focus
(:func:`reconnect_script`): viser's page retries only while the tab has the focus, so a tab in the
background stayed "Disconnected ... reconnecting" after a restart while a new tab connected at once.
"""

from __future__ import annotations

import logging
import threading
import time
from collections import OrderedDict
from typing import Any, Callable

log = logging.getLogger(__name__)

INFO_SECONDS = 6.0
"""How long a notification that is not an error stays [s]."""

ERROR_SECONDS = 30.0
"""How long an error stays [s] (unless newer news about the same subject replaces it first)."""

MAX_SHOWN = 4
"""Most notifications one tab shows at a time; a newer one closes the oldest."""

SUBJECTS = (
    ("mission", ("Mission", "Cannot execute", "Cannot pause", "Cannot resume", "Cannot abort", "No mission",
                 "Execute", "Re-planned", "Landing added", "Battery")),
    ("capture", ("Capture", "Mapped", "Check the camera pose", "Models not loaded", "Held capture")),
    ("robot", ("Robot link", "Robot says", "Hold", "Land here", "Return", "Disarm", "Vehicle command")),
    ("camera", ("Live camera",)),
    ("goal", ("No goal there", "Goal not reachable", "Candidate path", "Cannot go there", "Go to ", "Planning")),
)
"""Notification subjects by title prefix: newer news about a subject replaces the older notice."""

SHORT_CHARS = 150
"""Longest notice body shown whole [characters] (about three lines of a notice); longer ones show their summary."""

SHORTENED = ("capture", "Scene file spawned", "find")
"""Subjects whose long notices are shown as their summary (a capture's or a scene file's report: the objects
seen, then a note per object; the Find panel's refusal of a target the perception cannot name, then every class
it can); other notices (a refusal and its reason) are shown whole."""

DETAILS_WHERE = "full text: Notices, under Capture & map"
"""What a shortened notice says about where its whole text is."""

_DEFAULT = object()
_lock = threading.Lock()
_shown: dict[Any, "OrderedDict[str, Any]"] = {}  # client id -> subject -> notification handle, oldest first
_long_listeners: dict[int, list[Callable[[str, str], None]]] = {}  # id(viser server) -> listeners
_last_long: dict[int, tuple[str, str, float]] = {}  # id(server) -> the last long notice passed on (one per broadcast)


def short_body(body: str, limit: int = SHORT_CHARS) -> str | None:
    """A notice body's summary when ``body`` is longer than ``limit`` characters, else ``None`` (shown whole).

    The summary is the text before the first "; " (a capture's "26 objects seen (2 new, 21 updated) in 4.1 s")
    when that fits, else the first words that fit, with "…"; then where the whole text is
    (:data:`DETAILS_WHERE`)."""
    text = " ".join(str(body).split())
    if len(text) <= limit:
        return None
    head = text.split("; ", 1)[0].rstrip(" .,:;")
    if len(head) > limit - 1:
        cut = text[:limit - 1]
        head = (cut.rsplit(" ", 1)[0] if " " in cut[limit // 2:] else cut).rstrip(" .,:;(")
    return f"{head} … ({DETAILS_WHERE})"


def on_long_notice(server: Any, listener: Callable[[str, str], None]) -> None:
    """Call ``listener(title, body)`` with the whole text of every notice shown shortened in a tab of the viser
    ``server`` (once per notice, even when it went to several tabs)."""
    with _lock:
        _long_listeners.setdefault(id(server), []).append(listener)


def _pass_on_long(client: Any, title: str, body: str) -> None:
    key = id(getattr(client, "_viser_server", None))
    now = time.monotonic()
    with _lock:
        last = _last_long.get(key)
        if last is not None and (title, body) == last[:2] and now - last[2] < 5.0:
            return  # the same notice broadcast to another tab
        _last_long[key] = (title, body, now)
        listeners = list(_long_listeners.get(key, ()))
    for listener in listeners:
        try:
            listener(title, body)
        except Exception:  # noqa: BLE001 - a details panel failing must not stop the notice
            log.exception("notice details listener failed")


def notice_seconds(color: str) -> float:
    """How long a notification of ``color`` stays [s]: :data:`ERROR_SECONDS` for errors (red), else
    :data:`INFO_SECONDS`."""
    return ERROR_SECONDS if color == "red" else INFO_SECONDS


def subject(title: str) -> str:
    """What a notification is about (see :data:`SUBJECTS`); the title itself when not listed."""
    for name, prefixes in SUBJECTS:
        if title.startswith(prefixes):
            return name
    return title


def _remove(handle: Any) -> None:
    remove = getattr(handle, "remove", None)
    if remove is None:
        return
    try:
        remove()
    except Exception:  # noqa: BLE001 - a tab that is gone or a notice already closed: nothing to remove
        pass


def tell(client: Any, title: str, body: str, color: str = "blue", seconds: Any = _DEFAULT,
         about: str | None = None) -> None:
    """Show ``title`` / ``body`` in ``client``'s tab (nothing when the event had no client).

    ``seconds`` [s] before it closes by itself; by default :func:`notice_seconds` of the colour.
    ``about`` is its subject (default :func:`subject` of the title): a notification about the same
    subject still shown in that tab is replaced, and the tab keeps at most :data:`MAX_SHOWN`. A body of a
    :data:`SHORTENED` subject longer than :data:`SHORT_CHARS` is shown as its summary (:func:`short_body`), the whole text passed to
    :func:`on_long_notice`'s listeners.
    """
    if client is None:
        return
    key = about if about is not None else subject(title)
    short = short_body(body) if key in SHORTENED else None
    if short is not None:
        _pass_on_long(client, title, body)
        body = short
    wait = notice_seconds(color) if seconds is _DEFAULT else seconds
    cid = getattr(client, "client_id", id(client))
    with _lock:
        shown = _shown.setdefault(cid, OrderedDict())
        old = [shown.pop(key)] if key in shown else []
        while len(shown) >= MAX_SHOWN:
            old.append(shown.popitem(last=False)[1])
        handle = client.add_notification(title, body, color=color, auto_close_seconds=wait)
        shown[key] = handle
    for h in old:
        _remove(h)


def forget(client_id: Any) -> None:
    """Drop what is remembered about a tab that disconnected."""
    with _lock:
        _shown.pop(client_id, None)


def reconnect_script() -> str:
    """JavaScript for the page: retry a lost connection every second even while the tab has no focus.

    viser's page (``WebsocketInterface.tsx``) retries only while ``document.hasFocus()``; a page
    that reports focus always retries as a focused tab does (immediately, then every second)."""
    return ("if (!window.__morphonaviReconnect) { window.__morphonaviReconnect = true; "
            "document.hasFocus = function () { return true; }; "
            "window.dispatchEvent(new Event('focus')); }")


def install_tab_rules(server: Any) -> None:
    """Send :func:`reconnect_script` to every page of ``server`` (now and to pages that connect later),
    and forget a tab's notifications when it disconnects.

    The script goes as viser's message for page scripts (the one its Plotly support sends), which
    the server keeps for pages that connect later."""
    from viser._messages import RunJavascriptMessage

    server.gui._websock_interface.queue_message(RunJavascriptMessage(source=reconnect_script()))
    server.on_client_disconnect(lambda client: forget(client.client_id))


DISCONNECTED_TEXT = "Disconnected from the MorphoNavi console server: reconnecting… (the view is frozen)"


def page_style(right_panel_px: int) -> str:
    """HTML (a ``<style>`` block) that places notifications and shows a banner while disconnected.

    Notifications go to the bottom right of the 3D view, left of the right-docked control panel
    ``right_panel_px`` [px] wide; on a phone (:data:`console.views.screen_layout.PHONE_MAX_PX`), where the panel
    is a sheet at the bottom, across the top of the screen below the wider-screen line, over neither.
    The banner: viser greys out and disables its GUI while the websocket is down (its ``DisconnectedGate`` wrapper gets ``pointer-events: none``); a CSS
    ``:has()`` rule on that state shows a red bar across the top of the page, gone on reconnect.
    """
    from console.views.screen_layout import PHONE_MAX_PX

    text = DISCONNECTED_TEXT.replace("\\", "\\\\").replace('"', '\\"')
    return f"""<style>
.mantine-Notifications-root {{
  top: auto !important; left: auto !important;
  bottom: 1em !important; right: calc({int(right_panel_px)}px + 1em) !important;
}}
@media (max-width: {PHONE_MAX_PX}px) {{
  .mantine-Notifications-root {{
    top: 4.2em !important; bottom: auto !important; left: 0.5em !important; right: 0.5em !important;
    width: auto !important; max-width: none !important;
  }}
}}
body:has(div[style*="pointer-events: none"][style*="opacity: 0.5"])::before {{
  content: "{text}";
  position: fixed; top: 0; left: 0; right: 0; z-index: 100000; padding: 0.6em 1em;
  background: #c92a2a; color: white; font: 600 15px/1.3 sans-serif; text-align: center;
  box-shadow: 0 2px 8px rgba(0, 0, 0, 0.3);
}}
</style>"""
