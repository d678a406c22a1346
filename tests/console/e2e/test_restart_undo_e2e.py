"""Undo after a restart, in a real headless browser (Playwright, Debian's Chromium) at 1440 x 900.

The console starts on a session folder (not ``--fresh``) with two boxes in the map; the operator deletes
one in the page (Delete, then Delete object). The console is stopped and started again on the same
folder: the page's Undo button reads "Undo delete crate-b" and is enabled, a click brings the box back,
and Redo (now "Redo delete crate-b") takes it away again.

Every step waits on state (the session, the page), never on time; each click is retried, bounded by the
time left (:mod:`tests.console.e2e.e2e_helpers`). Skipped with the reason when Chromium or Playwright is
missing. Screenshots go to the test's folder.
"""

from __future__ import annotations

import tempfile
import warnings
from pathlib import Path
from typing import Any

import pytest

from console.app import ConsoleApp, ConsoleConfig
from pipeline.scene import Scene, SceneObject
from tests.console.e2e.e2e_helpers import button, click_until, wait_for
from tests.console.e2e.test_console_e2e import BROWSER_ARGS, CHROMIUM, needs_browser

LONG = 90_000  # [ms] generous waits for the page on a loaded 2-core machine
VIEWPORT = (1440, 900)
BOXES = (SceneObject("crate-a", "cardboard_box", (1.0, 3.0, 0.3), (0.5, 0.5, 0.6)),
         SceneObject("crate-b", "cardboard_box", (4.0, 3.0, 0.3), (0.5, 0.5, 0.6)))


def _start(tmp: Path) -> ConsoleApp:
    from console.link.sim import SimConfig, SimRobot

    return ConsoleApp(ConsoleConfig(robot="sim", session_dir=tmp / "session", scene_dir=tmp / "scenes", port=0,
                                    record=False), link=SimRobot(config=SimConfig(time_scale=8.0))).start()


def _open(ctx: Any, app: ConsoleApp) -> Any:
    page = ctx.new_page()
    page.goto(app.url, timeout=LONG)
    page.get_by_role("button", name="Add goal").wait_for(timeout=LONG)
    assert app.server is not None
    wait_for(lambda: len(app.server.get_clients()) >= 1, "the page connected")
    return page


def _shot(page: Any, path: Path) -> None:
    """A screenshot for the reader, never the test's verdict: a page drawing a frame every few seconds under
    load may not give one within the (generous) time; the test goes on without it."""
    from playwright.sync_api import TimeoutError as PlaywrightTimeout

    try:
        page.screenshot(path=str(path), timeout=LONG)
    except PlaywrightTimeout:
        warnings.warn(f"no screenshot {path.name} within {LONG / 1000:.0f} s (a loaded machine)", stacklevel=2)


def _ids(app: ConsoleApp) -> set[str]:
    assert app.session is not None
    return {o.id for o in app.session.scene.objects}


@needs_browser
def test_undo_after_a_restart_is_enabled_with_its_step_and_puts_the_map_back(tmp_path: Path) -> None:
    from playwright.sync_api import expect, sync_playwright

    shots = tmp_path / "shots"
    shots.mkdir()
    with sync_playwright() as pw:
        ctx = pw.chromium.launch_persistent_context(
            tempfile.mkdtemp(prefix="chromium-", dir=tmp_path), executable_path=str(CHROMIUM), headless=True,
            args=BROWSER_ARGS, viewport={"width": VIEWPORT[0], "height": VIEWPORT[1]}, timeout=LONG)
        try:
            # --- first run: the map, and a delete made in the page ------------------------------------------
            app = _start(tmp_path)
            try:
                s = app.session
                assert s is not None
                s.spawn(Scene(objects=BOXES), origin="file room.json")
                page = _open(ctx, app)
                s.select("crate-b")
                click_until(button(page, "Delete"), lambda: page.get_by_text("Delete crate-b?").count() > 0,
                            "Delete asks first")
                click_until(button(page, "Delete object"), lambda: "crate-b" not in _ids(app), "crate-b deleted")
                wait_for(lambda: s.undo_label == "delete crate-b", "the delete in the history")
                page.close()
            finally:
                app.stop()

            # --- the console again, on the same folder ------------------------------------------------------
            again = _start(tmp_path)
            try:
                s2 = again.session
                assert s2 is not None and s2.restore_problems == (), s2.restore_problems
                assert _ids(again) == {"crate-a"} and s2.undo_label == "delete crate-b"
                page = _open(ctx, again)
                undo = page.get_by_role("button", name="Undo delete crate-b", exact=True)
                expect(undo).to_be_enabled(timeout=LONG)  # before the fix: a bare "Undo", disabled
                expect(page.get_by_role("button", name="Redo", exact=True)).to_be_disabled(timeout=LONG)
                _shot(page, shots / "restart-undo-1440x900.png")
                click_until(button(page, "Undo delete crate-b"), lambda: "crate-b" in _ids(again),
                            "the Undo after the restart")
                assert _ids(again) == {"crate-a", "crate-b"}  # the map as it was before the delete
                expect(page.get_by_role("button", name="Redo delete crate-b", exact=True)).to_be_enabled(timeout=LONG)
                expect(page.get_by_role("button", name="Undo spawn from file room.json", exact=True)).to_be_enabled(
                    timeout=LONG)
                click_until(button(page, "Redo delete crate-b"), lambda: "crate-b" not in _ids(again),
                            "the Redo after the restart")
                expect(page.get_by_role("button", name="Undo delete crate-b", exact=True)).to_be_enabled(timeout=LONG)
                _shot(page, shots / "restart-redo-1440x900.png")
            finally:
                again.stop()
        finally:
            ctx.close()
