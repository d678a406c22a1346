"""The console's screen layout rules: what stays in sight at 1280 x 720 and up, and on a phone.

- **Pinned robot and mission block.** The folder holding the robot status line, the vehicle buttons
  (Hold, Land here, Return) and the mission (Build mission, the segment table, Execute, Pause,
  Resume, Abort) sticks to the top of the control panel (CSS ``position: sticky``) while the rest
  (Map, Plan, Find, Scene summary, Session) scrolls beneath it. The folder is found by a marker
  (:data:`PIN_MARK`) placed in it; a long mission table scrolls inside the block, its rows tight (a segment's
  start and end on two lines, so that every column fits the panel's width).
- **Tables** in the panel never wrap a cell ("take- / off"): a wide table scrolls sideways.
- **Phone** (a window at most :data:`PHONE_MAX_PX` wide): viser shows the controls as a sheet at the
  bottom (the camera panel is its last section); the sheet takes the full width and at most
  :data:`PHONE_SHEET_VH` % of the height, a line above it says the console is made for wider
  screens, and each phone tab's 3D view is fitted so the whole room and the robot sit in the part of
  the screen above the sheet (:func:`install_phone_view`).

The rules are CSS sent once as a ``<style>`` block (:func:`layout_style`); the selectors rely on
viser's Mantine class names (``mantine-ScrollArea-viewport``, ``mantine-Paper-root``) and on the
marker, never on generated class names.
"""

from __future__ import annotations

import logging
import threading
from typing import Any, Callable, Sequence

from console.views.view_fit import fit_view

log = logging.getLogger(__name__)

PIN_MARK = '<span data-mn-pin="robot-mission" style="display:none"></span>'
"""Put (as HTML) into the folder that stays pinned at the top of the control panel."""

PHONE_MAX_PX = 575
"""Widest window [CSS px] viser lays out as a phone (Mantine's ``xs`` breakpoint, 36 em)."""

PHONE_SHEET_VH = 55
"""Most of a phone screen's height [%] the control sheet takes; the 3D view keeps the rest."""

PHONE_ASPECT = 0.7
"""A 3D view narrower than this (width / height) is a phone held upright: its view is refitted."""

PHONE_DIRECTION = (-0.2, -0.55, 1.0)
"""From the room towards a phone's camera: steeper than the desktop's, so the long room fills the tall
screen."""

WIDER_SCREEN_TEXT = ("MorphoNavi is made for screens at least 1280 px wide: here the controls are in the "
                     "sheet below (drag or scroll it; the camera is its last section).")
"""The line a phone shows above the 3D view."""

_SHEET = '.mantine-Paper-root[style*="position: fixed"]:has([data-mn-pin])'
"""viser's bottom sheet on a phone (a fixed Paper holding the control panel)."""
_PIN = '.mantine-ScrollArea-viewport .mantine-Paper-root:has([data-mn-pin]):not(:has(.mantine-Paper-root [data-mn-pin]))'


def layout_style() -> str:
    """HTML (one ``<style>`` block) with the layout rules of this module."""
    text = WIDER_SCREEN_TEXT.replace("\\", "\\\\").replace('"', '\\"')
    return f"""<style>
{_PIN} {{
  position: sticky; top: 0.7em; z-index: 5;
  background: var(--mantine-color-body);
  box-shadow: 0 -0.9em 0 0 var(--mantine-color-body), 0 0.6em 0.6em -0.5em rgba(0, 0, 0, 0.25);
}}
.mantine-ScrollArea-viewport div[style*="overflow: hidden"]:has([data-mn-pin]) {{ overflow: clip !important; min-width: 0; }}
{_PIN} table {{ display: block; max-height: 15em; overflow: auto; }}
{_PIN} td, {_PIN} th {{ line-height: 1.3; padding-top: 0.15em !important; padding-bottom: 0.15em !important; }}
.mantine-ScrollArea-viewport table {{ display: block; max-width: 100%; overflow-x: auto; }}
.mantine-ScrollArea-viewport td, .mantine-ScrollArea-viewport th {{ white-space: nowrap; }}
@media (max-width: {PHONE_MAX_PX}px) {{
  {_SHEET} {{ width: 100vw !important; max-height: {PHONE_SHEET_VH}vh !important; }}
  {_SHEET} div[style*="width: 20em"] {{ width: 100% !important; }}
  body::after {{
    content: "{text}";
    position: fixed; top: 0; left: 0; right: 0; z-index: 99999; padding: 0.35em 0.7em;
    background: rgba(255, 244, 214, 0.95); color: #5c4400; font: 500 12px/1.3 sans-serif;
    border-bottom: 1px solid #e0c060; pointer-events: none;
  }}
}}
</style>"""


def pin_script() -> str:
    """JavaScript for the page: keep the panel's ``scroll-padding-top`` at the pinned block's height, so
    a control scrolled into view (keyboard focus, "scroll into view") lands below the block, not under it."""
    return ("if (!window.__morphonaviPin) { window.__morphonaviPin = true; setInterval(function () {"
            " var m = document.querySelector('[data-mn-pin]'); if (!m) return;"
            " var block = m.closest('.mantine-Paper-root'), view = m.closest('.mantine-ScrollArea-viewport');"
            " if (!block || !view) return;"
            " var pad = Math.round(block.getBoundingClientRect().height + 20) + 'px';"
            " if (view.style.scrollPaddingTop !== pad) view.style.scrollPaddingTop = pad; }, 400); }")


def install_pin_script(server: Any) -> None:
    """Send :func:`pin_script` to every page of ``server`` (kept for pages that connect later), as
    :func:`console.views.client_notice.install_tab_rules` sends its script."""
    from viser._messages import RunJavascriptMessage

    server.gui._websock_interface.queue_message(RunJavascriptMessage(source=pin_script()))


def phone_view(workspace: Any, fov: float, aspect: float,
               extra: Sequence[Sequence[float]] = ()) -> tuple[tuple[float, float, float], ...]:
    """A phone's 3D view: the workspace and ``extra`` (the robot, world [m]) in the part of the screen
    above the control sheet, below the wider-screen line. Returns ``(position, look_at, up)``."""
    bottom = 1.0 - PHONE_SHEET_VH / 100.0
    return fit_view(workspace, PHONE_DIRECTION, fov, aspect, extra=extra, frame=(0.0, 0.06, 1.0, bottom))


def install_phone_view(server: Any, workspace: Any, robot_position: Callable[[], Sequence[float] | None]) -> None:
    """Refit the 3D view of every tab whose picture is a phone's (narrower than :data:`PHONE_ASPECT`),
    once, when its first camera state arrives; desktop tabs keep the default view."""
    lock = threading.Lock()
    done: set[int] = set()

    def connected(client: Any) -> None:
        def on_camera(cam: Any) -> None:
            with lock:
                if client.client_id in done:
                    return
                try:
                    width, height, fov = float(cam.image_width), float(cam.image_height), float(cam.fov)
                except Exception:  # noqa: BLE001 - no camera state yet
                    return
                if width <= 0 or height <= 0 or fov <= 0:
                    return
                done.add(client.client_id)
            if width / height >= PHONE_ASPECT:
                return
            robot = robot_position()
            extra = [tuple(robot)] if robot is not None else []
            try:
                position, look_at, up = phone_view(workspace, fov, width / height, extra)
            except ValueError as exc:
                log.info("phone view not fitted: %s", exc)
                return
            with client.atomic():
                cam.up_direction = up
                cam.position = position
                cam.look_at = look_at

        client.camera.on_update(on_camera)

    server.on_client_connect(connected)
    server.on_client_disconnect(lambda client: done.discard(client.client_id))


__all__ = ["PIN_MARK", "PHONE_MAX_PX", "WIDER_SCREEN_TEXT", "install_phone_view", "install_pin_script", "layout_style",
           "phone_view", "pin_script"]
