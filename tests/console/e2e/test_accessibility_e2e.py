"""Accessibility and buttons that tell the truth, in a real headless browser (Playwright, Debian's Chromium),
at 1440 x 900 and 1280 x 720, on the simulated robot with a crate in the operator's map:

- the operator fills the Plan fields found by their labels (Goal on, Goal x / y / z [m]) and presses Add goal,
  Register and Build mission; Execute, off before the mission is built, says why on hover;
- the mission ends hovering over the crate: Land here is off and its hover text says the crate is below,
  Hold is off ("nothing to hold"), Return's hover text says where it lands (the take-off spot), and the robot
  panel shows the battery time left to land;
- the scene summary's Copy button says "Copied ✓" once the clipboard has the text.

Screenshots go to the test's folder. Every step waits on state (session, page), never on time. Skipped with
the reason when Chromium or Playwright is missing.
"""

from __future__ import annotations

import math
import re
import tempfile
from pathlib import Path
from typing import Any

import pytest

from console.app import ConsoleApp, ConsoleConfig, wait_until
from pipeline.scene import Scene, SceneObject
from tests.console.e2e.e2e_helpers import copy_and_hear
from tests.console.e2e.test_console_e2e import BROWSER_ARGS, CHROMIUM, needs_browser

LONG = 90_000  # [ms] generous waits for the page on a loaded 2-core machine
HIDE_NOTICES = ".mantine-Notifications-root { display: none !important; }"
CRATE = SceneObject("crate", "cardboard_box", (3.3, 1.8, 0.3), (0.5, 0.6, 0.5))
GOAL = (3.3, 1.8, 1.5)  # hovering 1.2 m above the crate


def _start(tmp_path: Path) -> ConsoleApp:
    from console.link.sim import SimConfig, SimRobot

    # 8x real time; a drain in the air that leaves a few minutes of hover for the estimate
    robot = SimRobot(world=Scene(objects=(CRATE,)), room=None,
                     config=SimConfig(time_scale=8.0, drain_fly=5e-4))
    app = ConsoleApp(ConsoleConfig(robot="sim", session_dir=tmp_path / "session", scene_dir=tmp_path / "scenes",
                                   port=0, fresh=True), link=robot)
    return app.start()


def _wait(predicate: Any, what: str, timeout: float = 90.0) -> None:
    assert wait_until(predicate, timeout, 0.05), f"timed out waiting for {what}"


def _title(page: Any, name: str, pattern: str) -> str:
    """The hover text (title) of button ``name`` once it matches ``pattern`` (the page script copies it).

    Read again until it matches: the panel may redraw (and the page script copy the text again) in between."""
    button = page.get_by_role("button", name=name, exact=True)
    seen: list[str] = []

    def matches() -> bool:
        try:
            seen.append(str(button.get_attribute("title", timeout=5_000)))
        except Exception:  # redrawn meanwhile: read again
            return False
        return re.search(pattern, seen[-1]) is not None

    assert wait_until(matches, LONG / 1000, 0.2), f"{name}: no hover text matching {pattern!r} (last: {seen[-1:]})"
    return seen[-1]


@needs_browser
@pytest.mark.parametrize("viewport", [(1440, 900), (1280, 720)], ids=["1440x900", "1280x720"])
def test_fields_by_label_disabled_buttons_say_why_return_says_where_and_the_hover_battery(
        tmp_path: Path, viewport: tuple[int, int]) -> None:
    from playwright.sync_api import expect, sync_playwright

    app = _start(tmp_path)
    try:
        s = app.session
        assert s is not None
        s.spawn(Scene(objects=(CRATE,)), origin="the operator's map")
        _wait(lambda: s.robot is not None and s.operator_state().launch is not None, "the robot's first state")
        with sync_playwright() as pw:
            ctx = pw.chromium.launch_persistent_context(
                tempfile.mkdtemp(prefix="chromium-", dir=tmp_path), executable_path=str(CHROMIUM), headless=True,
                args=BROWSER_ARGS, viewport={"width": viewport[0], "height": viewport[1]},
                permissions=["clipboard-read", "clipboard-write"])
            try:
                page = ctx.new_page()
                page.set_default_timeout(LONG)  # every action: a page on a loaded machine can stall for many seconds
                page.goto(app.url)
                page.get_by_role("button", name="Build mission").wait_for(timeout=LONG)
                page.add_style_tag(content=HIDE_NOTICES)  # pop-ups must not cover the buttons under test

                # --- a disabled button says why (the session's own words) -----------------------------------
                assert _title(page, "Execute", "off") == \
                    "Execute is off: no mission: register a path, then Build mission"

                # --- the Plan fields, found by their labels --------------------------------------------------
                mode = page.get_by_label("Goal on", exact=True)
                mode.scroll_into_view_if_needed()
                mode.click()
                page.get_by_role("option", name="altitude").click()
                _wait(lambda: s.settings.goal_mode == "altitude", "altitude mode")
                for axis, value in zip("xyz", GOAL):
                    field = page.get_by_label(f"Goal {axis} [m]", exact=True)
                    field.fill(f"{value:.2f}")
                    expect(field).to_have_value(f"{value:.2f}", timeout=LONG)
                page.get_by_role("button", name="Add goal", exact=True).click()
                _wait(lambda: s.route_snapshot().candidate_goal is not None, "the typed goal's candidate")
                goal = s.route_snapshot().candidate_goal
                assert abs(goal[0] - GOAL[0]) < 0.2 and abs(goal[1] - GOAL[1]) < 0.2 and goal[2] > 1.0, goal
                page.get_by_role("button", name="Register", exact=True).click()
                _wait(lambda: len(s.route_snapshot().registered) == 1, "registered")
                page.get_by_role("button", name="Build mission", exact=True).click()
                _wait(lambda: s.mission is not None, "mission built")
                lift = next(seg.start for seg in s.mission.segments if seg.kind.value == "takeoff")  # type: ignore[union-attr]
                assert _title(page, "Execute", "^Run the mission") == "Run the mission on the robot"
                page.get_by_role("button", name="Execute", exact=True).click()
                _wait(lambda: s.run.state == "done", "the mission done", 180)
                r = s.robot
                assert r is not None and r.landed is False and r.pose.translation[2] > 1.0  # it ends hovering

                # --- hovering over the crate: Land here off with the reason, Hold off, Return says where ----
                land = _title(page, "Land here", "crate is below")
                x, y = (float(v) for v in s.robot.pose.translation[:2])  # type: ignore[union-attr]
                assert land == ("Vehicle command: Land here · Land here is off: cannot land here: crate is below "
                                f"the robot at ({x:.2f}, {y:.2f}): use Return, or plan a goal on free floor")
                expect(page.get_by_role("button", name="Land here", exact=True)).to_be_disabled()
                assert "nothing to hold" in _title(page, "Hold", "nothing to hold")
                expect(page.get_by_role("button", name="Hold", exact=True)).to_be_disabled()
                ret = _title(page, "Return", "^Return: lands")
                launch = s.operator_state().launch  # where it last stood disarmed: where it took off
                assert launch is not None and math.dist(launch[:2], lift[:2]) < 0.3, (launch, lift)
                assert ret == f"Return: lands at the take-off spot ({launch[0]:.2f}, {launch[1]:.2f})"
                expect(page.get_by_role("button", name="Return", exact=True)).to_be_enabled()

                # --- the battery time left to land, in the robot panel ----------------------------------------
                note = page.get_by_text(re.compile(r"hovering: (about \d+ min|less than 1 min) of battery left to land"))
                note.wait_for(timeout=LONG)
                assert s.operator_state().battery_note in note.inner_text()
                page.screenshot(path=str(tmp_path / f"accessibility-{viewport[0]}x{viewport[1]}.png"))

                # --- Copy says so once the clipboard has the summary ------------------------------------------
                _wait(lambda: "crate" in app.views["summary"].text, "the summary names the crate")
                said = copy_and_hear(page)  # its answer is recorded as it happens: a loaded page draws slowly
                assert said[0] == "Copied ✓", said
                assert "crate" in str(page.evaluate("navigator.clipboard.readText()"))
            finally:
                ctx.close()
    finally:
        app.stop()
