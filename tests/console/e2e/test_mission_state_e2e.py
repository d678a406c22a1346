"""The console's own mission state, in a real headless browser (Playwright, Debian's Chromium), on the
simulated robot:

- while a mission is paused, **Build mission** is off and the panel says why; after Abort it is on again;
- an error notice is replaced by newer news about the same thing (the mission done);
- the robot panel drops "ERROR: walk refused" once a later mission is done;
- a tab in the background reconnects as soon as a console answers on the port again.

Every step waits on state (session, page), never on time. Skipped with the reason when Chromium or
Playwright is missing.
"""

from __future__ import annotations

import tempfile
from pathlib import Path
from typing import Any

from console.app import ConsoleApp, ConsoleConfig, wait_until
from pipeline.scene import Scene
from tests.console.e2e.test_console_e2e import needs_browser
from tests.console.e2e.test_console_goals_e2e import BANNER_JS
from tests.console.e2e.test_console_operator_e2e import (HIDE_NOTICES, LONG, _boxes, _button, _launch, _robot_at,
                                                         _start_console, _wait)

NOTICE = ".mantine-Notifications-root"


def _open_with_notices(ctx: Any, app: ConsoleApp, background: bool = False) -> Any:
    page = ctx.new_page()
    if background:  # headless Chromium gives every page the focus: make this one a tab in the background
        page.add_init_script("document.hasFocus = function () { return false; };")
    page.goto(app.url)
    page.get_by_role("button", name="Build mission").wait_for(timeout=LONG)
    page.add_style_tag(content=HIDE_NOTICES)  # still in the page (read below), never over a button
    assert wait_until(lambda: len(app.server.get_clients()) >= 1, 30), "the page did not connect"
    return page


def _plan(app: ConsoleApp, page: Any, goal: tuple[float, float, float]) -> None:
    """Add a goal (session), Register and Build mission (clicks, with the long deadline: a loaded machine)."""
    s = app.session
    n = len(s.route_snapshot().registered)
    res = s.add_goal(goal)
    assert res.ok, res.message
    _button(page, "Register").click(timeout=LONG)
    _wait(lambda: len(s.route_snapshot().registered) == n + 1, "registered")
    _button(page, "Build mission").click(timeout=LONG)
    _wait(lambda: s.mission is not None, "mission built")


def _notice_text(page: Any) -> str:
    # textContent: the notices are hidden (display: none) so that they never cover a button under test
    return str(page.evaluate(f"Array.from(document.querySelectorAll('{NOTICE}')).map(e => e.textContent).join('\\n')"))


@needs_browser
def test_build_is_off_while_paused_and_old_errors_give_way_to_newer_news(tmp_path: Path) -> None:
    from playwright.sync_api import expect

    app = _start_console(tmp_path, fresh=True, time_scale=1.0, walk=0.05)  # slow: a lagging page still pauses it
    pw, ctx = _launch(Path(tempfile.mkdtemp(prefix="chromium-", dir=tmp_path)))
    try:
        s = app.session
        s.spawn(Scene(objects=_boxes().objects), origin="the test's map")
        page = _open_with_notices(ctx, app)
        _wait(lambda: s.robot is not None, "the robot's first state")
        status = page.get_by_text("robot sim", exact=False).first

        # --- Build mission is off while a mission is paused, with the reason -----------------------------
        _plan(app, page, (2.5, 3.1, 0.0))
        built = s.mission.id
        expect(_button(page, "Execute")).to_be_enabled(timeout=LONG)
        _button(page, "Execute").click(timeout=LONG)
        _wait(lambda: s.run.state == "running", "the walk under way")
        _button(page, "Pause").click(timeout=LONG)
        _wait(lambda: s.run.state == "paused", f"paused (run {s.run})")
        expect(_button(page, "Build mission")).to_be_disabled(timeout=LONG)
        page.get_by_text("Build mission is off: a mission is paused: resume or abort it").wait_for(timeout=LONG)
        expect(_button(page, "Register")).to_be_disabled(timeout=LONG)
        assert s.mission.id == built  # nothing replaced the mission Resume runs
        _button(page, "Abort").click(timeout=LONG)
        _wait(lambda: s.run.state == "aborted", "aborted")
        expect(_button(page, "Build mission")).to_be_enabled(timeout=LONG)
        expect(page.get_by_text("Build mission is off")).to_have_count(0, timeout=LONG)

        # --- an old error on the robot panel and in a notice; a later mission done clears both ----------
        app.link._say("ERROR", "walk refused: blocked by the test")  # as the simulator says a refusal
        s.notify("Mission", "walk refused: notice from the test", "error")
        _wait(lambda: "walk refused: notice from the test" in _notice_text(page), "the error notice")
        expect(status).to_contain_text("ERROR: walk refused: blocked by the test", timeout=LONG)
        _button(page, "Clear").click(timeout=LONG)
        _wait(lambda: s.route_snapshot().registered == () and s.mission is None, "cleared")
        x, y, _ = _robot_at(app)
        _plan(app, page, (x, y + 0.5, 0.0))  # a short walk that succeeds
        expect(_button(page, "Execute")).to_be_enabled(timeout=LONG)
        _button(page, "Execute").click(timeout=LONG)
        _wait(lambda: s.run.state == "done", f"the short walk done (run {s.run})", 120)
        _wait(lambda: "walk refused" not in _notice_text(page), f"the error notice replaced ({_notice_text(page)!r})")
        expect(status).not_to_contain_text("walk refused", timeout=LONG)  # the panel shows the current state
        assert "Mission done" in _notice_text(page)
    finally:
        ctx.close()
        pw.stop()
        app.stop()


@needs_browser
def test_a_tab_in_the_background_reconnects_as_soon_as_the_console_answers(tmp_path: Path) -> None:
    from console.link.sim import SimConfig, SimRobot

    def start(port: int) -> ConsoleApp:
        return ConsoleApp(ConsoleConfig(robot="sim", session_dir=tmp_path / "session", scene_dir=tmp_path / "scenes",
                                        port=port, fresh=True), link=SimRobot(config=SimConfig(time_scale=4.0))).start()

    app = start(0)
    port = app.server.get_port()
    again: ConsoleApp | None = None
    pw, ctx = _launch(Path(tempfile.mkdtemp(prefix="chromium-", dir=tmp_path)))
    try:
        behind = _open_with_notices(ctx, app, background=True)  # document.hasFocus() is false there
        front = _open_with_notices(ctx, app)
        front.bring_to_front()  # the operator works in the new tab; the first is in the background
        assert wait_until(lambda: len(app.server.get_clients()) == 2, 30)
        app.stop()
        behind.wait_for_function(f"{BANNER_JS}.includes('Disconnected')", timeout=LONG)
        again = start(port)
        # a page retries every second: both tabs are back well within the deadline (was: over a minute for
        # the tab in the background, which retried only once it had the focus)
        behind.wait_for_function(f"{BANNER_JS} === 'none'", timeout=LONG)
        front.wait_for_function(f"{BANNER_JS} === 'none'", timeout=LONG)
        assert wait_until(lambda: len(again.server.get_clients()) == 2, 30)
        behind.get_by_role("button", name="Build mission").wait_for(timeout=LONG)
    finally:
        ctx.close()
        pw.stop()
        if again is not None:
            again.stop()
