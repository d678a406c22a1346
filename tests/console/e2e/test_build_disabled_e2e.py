"""Build mission is off, with the reason in its hover text, when the click would be refused, in a real
headless browser (Playwright, Debian's Chromium) at 1440 x 900, on the simulated robot in the paper's room
after one Capture & map.

The robot flies to a low hover beside the start (unknown space allowed). A floor goal ahead is then planned
the way the planner did before it knew the landing rule (landings wherever the robot may walk: the test
replaces the rule with "nothing refused") and registered: its landing is on floor partly not seen, so
Build would refuse it. The page shows Build mission disabled, its hover text naming the refusal, and the
mission panel saying it; planned again with the rule, the route builds and Build is on. Every step waits on
state (the session, the page), never on time. Skipped with the reason when Chromium or Playwright is missing.
"""

from __future__ import annotations

import re
from typing import Any, Iterator

import numpy as np
import pytest

import planner.route as planner_route
from console.app import ConsoleApp, ConsoleConfig, wait_until
from tests.console.e2e.e2e_helpers import LONG_MS, open_tab, wait_for
from tests.console.e2e.test_console_e2e import needs_browser

HIDE_NOTICES = ".mantine-Notifications-root { display: none !important; }"
HOVER = (1.625, 1.125, 0.625)  # low over the floor beside the start, partly seen by the first capture
GOAL = (2.5, 3.0, 0.0)  # a floor goal ahead (seen)


@pytest.fixture(scope="module")
def console(tmp_path_factory: pytest.TempPathFactory) -> Iterator[ConsoleApp]:
    """The console on the simulator after one capture, with a battery that lasts the test in the air."""
    from console.link.sim import SimConfig, SimRobot

    folder = tmp_path_factory.mktemp("console")
    app = ConsoleApp(ConsoleConfig(robot="sim", session_dir=folder / "session", scene_dir=folder / "scenes", port=0,
                                   fresh=True), link=SimRobot(config=SimConfig(time_scale=12.0, drain_fly=1e-5))).start()
    try:
        s = app.session
        wait_for(lambda: s.robot is not None, "the robot's state", 60)
        assert app.mapping.start()
        wait_for(lambda: s.capture is not None and not s.job.running, f"the first capture ({s.job})", 180)
        yield app
    finally:
        app.stop()


def _build_state(page: Any) -> tuple[bool, str]:
    """``(disabled, hover text)`` of the Build mission button, read afresh (the panel redraws)."""
    b = page.get_by_role("button", name="Build mission", exact=True).first
    return b.is_disabled(timeout=5_000), str(b.get_attribute("title", timeout=5_000))


def _wait_build(page: Any, disabled: bool, pattern: str) -> str:
    seen: list[tuple[bool, str]] = []

    def matches() -> bool:
        try:
            seen.append(_build_state(page))
        except Exception:  # redrawn meanwhile: read again
            return False
        return seen[-1][0] == disabled and re.search(pattern, seen[-1][1]) is not None

    assert wait_until(matches, LONG_MS / 1000, 0.2), f"Build mission: not {disabled=} with {pattern!r} (last: {seen[-1:]})"
    return seen[-1][1]


def _page_says(page: Any, text: str) -> bool:
    try:
        return text in page.inner_text("body", timeout=5_000)
    except Exception:
        return False


def _hovering(app: ConsoleApp) -> bool:
    s = app.session
    r = s.robot
    return r is not None and not s.run.active and r.mode in ("idle", "holding") and not r.landed


@needs_browser
def test_build_is_off_with_the_refusal_in_its_hover_text_and_on_once_planned_by_the_rule(
        browser: Any, console: ConsoleApp, monkeypatch: pytest.MonkeyPatch) -> None:
    app, s = console, console.session
    s.set_plan_unknown(True)  # the operator's "Plan into unknown space"
    res = s.add_goal(HOVER)
    assert res.ok, res.message
    s.register()
    app.runner.execute(s.build_mission())  # type: ignore[union-attr]
    wait_for(lambda: s.run.state == "done" and _hovering(app), "the flight to the low hover", 180)
    wait_for(lambda: not s.route_snapshot().registered and s.route_snapshot().start[2] > 0.3,
             "the route to start at the hovering robot", 60)

    monkeypatch.setattr(planner_route, "no_landing", lambda grid: np.zeros(grid.state.shape[:2], dtype=bool))
    res = s.add_goal(GOAL)
    assert res.ok, res.message
    s.register()
    why = s.build_refusal()
    assert why is not None and why.startswith("cannot build the mission: cannot land at ("), why

    page, _ = open_tab(browser, app, 1440, 900, style=HIDE_NOTICES)
    try:
        hint = _wait_build(page, True, re.escape(f"Build mission is off: {why}"))
        assert "has not been seen" in hint, hint
        wait_for(lambda: _page_says(page, "Build mission is refused for this path: cannot build the mission: "
                                          "cannot land at ("), "the mission panel to say the refusal", LONG_MS / 1000)
        monkeypatch.undo()  # the planner with the landing rule: the goal planned again builds
        s.clear_route()
        res = s.add_goal(GOAL)
        assert res.ok, res.message
        s.register()
        assert s.build_refusal() is None
        hint = _wait_build(page, False, r"^Split the green path into walk / take-off / fly / land segments$")
        wait_for(lambda: not _page_says(page, "is refused for this path"), "the refusal to leave the panel",
                 LONG_MS / 1000)
    finally:
        page.close()
