"""Shared waits and clicks for the browser tests, made for a loaded 2-core machine.

A page there may draw one frame every few seconds, so Playwright's "wait until stable" (two frames with
the same box) alone can take ten seconds, and a panel re-drawn between two tries detaches the button
found before. :func:`click_until` therefore finds the element afresh each try, bounds each try by the
time left, and stops when the console's *state* says the click took, never after a fixed sleep.
:func:`sim_console` starts the console on the simulated robot (with ``conftest.py``'s ``captured_console``
fixture) and :func:`open_tab` opens a tab on it, ready.
"""

from __future__ import annotations

import time
from contextlib import contextmanager
from pathlib import Path
from typing import Any, Callable, Iterator

from console.app import wait_until


def wait_for(predicate: Callable[[], bool], what: str, timeout: float = 300.0) -> None:
    """Wait until ``predicate()`` holds (polled), else fail naming ``what``."""
    assert wait_until(predicate, timeout, 0.05), f"timed out waiting for {what}"


def click_until(locate: Callable[[], Any], done: Callable[[], bool], what: str, timeout: float = 300.0,
                settle: float = 15.0) -> None:
    """Click the element ``locate()`` returns until ``done()`` holds.

    Args:
        locate: Returns a Playwright locator; called again each try (a re-drawn panel detaches the last one).
        done: The state that shows the click took (the console's session, or the page's own state).
        what: Named in the failure, with the last errors Playwright gave.
        timeout: Overall deadline [s].
        settle: How long [s] to wait for ``done`` after a click that raised no error before clicking again.
    """
    from playwright.sync_api import Error

    deadline = time.monotonic() + timeout
    errors: list[str] = []
    while not done():
        left = deadline - time.monotonic()
        assert left > 0, f"timed out clicking for {what}: {errors[-3:]}"
        attempt = max(1000.0, min(60_000.0, 1000.0 * left))  # [ms] one try, bounded by the time left
        try:
            target = locate()
            target.scroll_into_view_if_needed(timeout=attempt)
            target.click(timeout=attempt)
        except Error as exc:  # detached, hidden, covered or not yet stable: find it again
            errors.append(str(exc).splitlines()[0][:300])
            continue
        wait_until(done, max(0.1, min(settle, deadline - time.monotonic())), 0.05)


SAID_JS = ("() => { window.__said = []; new MutationObserver(() => { for (const b of document.querySelectorAll('button'))"
           " { const t = b.textContent; if (t.startsWith('Cop') && t !== 'Copy' && !window.__said.includes(t))"
           " window.__said.push(t); } }).observe(document.body, {subtree: true, childList: true, characterData: true}); }")


def copy_and_hear(page: Any, timeout: float = 300.0) -> list[str]:
    """Click the scene summary's Copy button until it answers; returns what it said (``Copied ✓`` first).

    Its answer lasts 2.5 s and a loaded page may draw a frame every few seconds, so every word the button
    says is recorded in the page as it happens (a MutationObserver) rather than polled."""
    page.evaluate(SAID_JS)
    click_until(lambda: page.get_by_role("button", name="Copy", exact=True),
                lambda: bool(page.evaluate("window.__said.length")), "the Copy button's answer", timeout)
    return list(page.evaluate("window.__said"))


def button(page: Any, name: str) -> Callable[[], Any]:
    """A locator factory for the button named exactly ``name`` (the first one), for :func:`click_until`."""
    return lambda: page.get_by_role("button", name=name, exact=True).first


LONG_MS = 90_000
"""[ms] a generous wait for the page on a loaded 2-core machine."""


@contextmanager
def sim_console(folder: Path, *, time_scale: float = 12.0, capture: bool = True, **config: Any) -> Iterator[Any]:
    """The console on the simulated robot in the paper's room: a fresh session in ``folder``, a free port,
    ``time_scale`` times real time, ``config`` more :class:`console.app.ConsoleConfig` fields; yields the started
    :class:`console.app.ConsoleApp` once the robot's state came and (``capture``) one Capture & map is mapped;
    stops it after."""
    from console.app import ConsoleApp, ConsoleConfig
    from console.link.sim import SimConfig, SimRobot

    cfg = ConsoleConfig(robot="sim", session_dir=folder / "session", scene_dir=folder / "scenes", port=0,
                        fresh=True, **config)
    app = ConsoleApp(cfg, link=SimRobot(config=SimConfig(time_scale=time_scale))).start()
    try:
        s = app.session
        wait_for(lambda: s.robot is not None, "the robot's state", 60)
        if capture:
            assert app.mapping.start()
            wait_for(lambda: s.capture is not None and not s.job.running, f"the first capture ({s.job})", 180)
        yield app
    finally:
        app.stop()


def open_tab(browser: Any, app: Any, width: int, height: int, *, ready: str = "Capture & map",
             init_script: str | None = None, style: str | None = None) -> tuple[Any, Any]:
    """A new tab of ``app``'s console at ``width`` x ``height`` CSS px: the page loaded (its button ``ready``
    there), connected, and its camera state on the server. ``init_script`` runs in the page before its own
    scripts; ``style`` (CSS) is added once loaded. Returns ``(page, client)``: the Playwright page and the
    tab's viser client."""
    before = set(app.server.get_clients())
    page = browser.new_page(viewport={"width": width, "height": height})
    page.set_default_timeout(LONG_MS)
    if init_script:
        page.add_init_script(init_script)
    page.goto(app.url)
    page.get_by_role("button", name=ready, exact=True).first.wait_for(state="attached", timeout=LONG_MS)
    if style:
        page.add_style_tag(content=style)
    wait_for(lambda: set(app.server.get_clients()) - before, "the page to connect", 60)
    client = app.server.get_clients()[max(set(app.server.get_clients()) - before)]
    wait_for(lambda: client.camera.image_height > 0, "the tab's camera state", 60)
    return page, client
