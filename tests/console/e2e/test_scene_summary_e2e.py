"""In a real headless browser: the Scene summary panel's Copy button and its "Go to" list.

Starts the console (simulated robot, fresh session), spawns the paper's room into the map, opens
the page in Debian's Chromium (Playwright), copies the summary to the clipboard with the panel's
button and reads the clipboard back, then chooses "robot dog" in "Go to" and checks on the server
that the candidate path flies over the line of boxes to the dog. Skipped, with the reason, when
``/usr/bin/chromium`` or the ``playwright`` package is missing.
"""

from __future__ import annotations

import math
import tempfile
from pathlib import Path
from typing import Any

import pytest

from console.app import ConsoleApp, ConsoleConfig
from console.link.world import paper_room
from console.views.scene_summary_view import option_label
from tests.console.e2e.e2e_helpers import click_until, copy_and_hear, wait_for

CHROMIUM = Path("/usr/bin/chromium")
LONG = 120_000  # [ms] one page wait on a loaded machine
BROWSER_ARGS = ["--headless", "--no-sandbox", "--disable-gpu", "--no-first-run", "--disable-background-networking",
                "--disable-component-update", "--disable-sync", "--use-angle=swiftshader", "--enable-unsafe-swiftshader"]


def _browser_missing() -> str | None:
    if not CHROMIUM.exists():
        return "Debian's chromium is not installed (/usr/bin/chromium); run `make browser`"
    try:
        import playwright.sync_api  # noqa: F401
    except ImportError:
        return "the playwright package is not installed (pip install playwright)"
    return None


@pytest.mark.skipif(_browser_missing() is not None, reason=_browser_missing() or "")
def test_copy_the_summary_and_go_to_the_robot_dog(tmp_path: Path) -> None:
    from playwright.sync_api import sync_playwright

    app = ConsoleApp(ConsoleConfig(robot="sim", session_dir=tmp_path / "s", scene_dir=tmp_path / "scenes", port=0,
                                   fresh=True)).start()
    try:
        session, view = app.session, app.views["summary"]
        session.spawn(paper_room(), origin="test")
        wait_for(lambda: "robot_dog-1" in view.text, "the summary naming the robot dog")
        with sync_playwright() as pw:
            ctx = pw.chromium.launch_persistent_context(
                tempfile.mkdtemp(prefix="chromium-", dir=tmp_path), executable_path=str(CHROMIUM), headless=True,
                args=BROWSER_ARGS, viewport={"width": 1440, "height": 900},
                permissions=["clipboard-read", "clipboard-write"])
            try:
                page = ctx.new_page()
                page.goto(app.url)
                box = page.locator("textarea", has_text="robot dog (robot_dog-1)").first
                box.wait_for(timeout=LONG)
                said = copy_and_hear(page)  # its answer is recorded as it happens: a loaded page draws slowly
                assert said[0] == "Copied \u2713", said
                copied = page.evaluate("navigator.clipboard.readText()")
                assert copied == view.text  # the whole summary, as the server wrote it

                assert session.route_snapshot().candidate_goal is None
                dog = page.get_by_role("option", name=option_label("robot_dog", "robot_dog-1"))

                def the_dog_option() -> Any:  # open the Mantine combobox when it is closed, then pick the option
                    if not dog.is_visible():
                        goto = page.get_by_label("Go to")
                        goto.scroll_into_view_if_needed(timeout=LONG)
                        goto.click(timeout=LONG)
                        dog.wait_for(timeout=LONG)
                    return dog

                click_until(the_dog_option, lambda: session.route_snapshot().candidate_goal is not None,
                            "a candidate after choosing the robot dog in Go to")
            finally:
                ctx.close()
        goal = session.route_snapshot().candidate_goal
        mapped = paper_room().object("robot_dog-1")
        assert math.dist(goal[:2], mapped.position[:2]) < 1.0 and goal[2] == 0.0
        assert session.route_snapshot().candidate[:, 2].max() > 1.2  # over the boxes
    finally:
        app.stop()
