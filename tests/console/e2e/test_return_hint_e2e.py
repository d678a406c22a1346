"""Return's hover text names the spot Return really lands at, in a real headless browser (Playwright, Debian's
Chromium) at 1440 x 900, on the simulated robot in the paper's room after one Capture & map (its battery drains slowly).

The robot walks ahead, takes off and hovers (Return is shown); the operator moves a mapped box onto the
take-off spot below it. Return's hover text in the page then names the nearest spot the robot fits, how far from
the take-off spot and why (the box); a click on Return brings the robot to that very spot. Every step waits
on state (the session, the page), never on time. Skipped with the reason when Chromium or Playwright is missing.
"""

from __future__ import annotations

import math
import re
from pathlib import Path
from typing import Any, Iterator

import pytest

from console.app import ConsoleApp, ConsoleConfig, wait_until
from console.session import button_rules
from tests.console.e2e.e2e_helpers import LONG_MS, button, click_until, open_tab, wait_for
from tests.console.e2e.test_console_e2e import needs_browser

HIDE_NOTICES = ".mantine-Notifications-root { display: none !important; }"
AWAY = (2.5, 2.0, 1.2)  # hovering ahead, over floor the first capture saw (it takes off below)


def _title(page: Any, name: str, pattern: str) -> str:
    """The hover text (title) of button ``name`` once it matches ``pattern`` (read again: the panel redraws)."""
    seen: list[str] = []

    def matches() -> bool:
        try:
            seen.append(str(page.get_by_role("button", name=name, exact=True).first.get_attribute("title", timeout=5_000)))
        except Exception:  # redrawn meanwhile: read again
            return False
        return re.search(pattern, seen[-1]) is not None

    assert wait_until(matches, LONG_MS / 1000, 0.2), f"{name}: no hover text matching {pattern!r} (last: {seen[-1:]})"
    return seen[-1]


@pytest.fixture(scope="module")
def console(tmp_path_factory: pytest.TempPathFactory) -> Iterator[ConsoleApp]:
    """conftest's ``captured_console`` with a battery that lasts the test in the air on a loaded machine
    (the default drain at 12x real time reaches the critical charge in about 40 s of hovering)."""
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


def _at_rest(app: ConsoleApp) -> bool:
    s = app.session
    r = s.robot
    return r is not None and not s.run.active and r.mode in ("idle", "holding")


@needs_browser
def test_return_hover_text_names_the_spot_it_lands_at(browser: Any, console: ConsoleApp, tmp_path: Path) -> None:
    app, s = console, console.session
    assert (app.link.latest_state().battery or 0.0) > 0.9, "a full battery: no battery landing meanwhile"
    s.set_plan_unknown(True)  # the air above the floor ahead was not seen from the floor: the operator allows it
    res = s.add_goal(AWAY)
    assert res.ok, res.message
    s.register()
    app.runner.execute(s.build_mission())  # type: ignore[union-attr]
    wait_for(lambda: s.run.state == "done" and _at_rest(app), "the flight away from the take-off spot", 180)
    wait_for(lambda: s.operator_state().commands["return"].enabled, "Return on (hovering)", 60)
    launch = s.operator_state().launch  # where it last stood disarmed: where it took off, below it now
    assert launch is not None and math.dist(launch[:2], AWAY[:2]) < 0.3, launch

    box = min(s.scene.objects, key=lambda o: math.dist(o.position[:2], AWAY[:2]) if o.size[1] < 1.0 else 1e9)
    s.move_object(box.id, (launch[0], launch[1] + 0.1, box.position[2]))  # the operator puts it on the take-off spot
    target = button_rules.return_target(s.grid, launch)
    assert target.spot is not None and target.why, target
    spot = f"({target.spot[0]:.2f}, {target.spot[1]:.2f})"

    page, _ = open_tab(browser, app, 1440, 900, style=HIDE_NOTICES)
    try:
        assert s.operator_state().launch == launch, "still hovering: the take-off spot is where it was"
        hint = _title(page, "Return", re.escape(f"Return: lands at {spot}, "))
        assert hint == s.operator_state().return_hint, hint
        assert f"from the take-off spot ({launch[0]:.2f}, {launch[1]:.2f}), where the robot cannot land: " in hint
        assert f"'{box.id}'" in hint, hint  # why: the box now on the take-off spot
        page.screenshot(path=str(tmp_path / "return-hint-1440x900.png"))

        def landed_there() -> bool:
            r = s.robot
            return r is not None and r.landed and math.dist(r.pose.translation[:2], target.spot[:2]) < 0.2

        click_until(button(page, "Return"), lambda: s.run.active or landed_there(), "Return")  # the last run is done already
        wait_for(lambda: not s.run.active and landed_there(), f"Return landed at {spot} ({s.robot}, {s.run})", 180)
    finally:
        page.close()
