"""Go look in a real headless browser (Playwright, Debian's Chromium): a goal behind the paper's line
of boxes, refused as not seen yet, becomes plannable after the suggested looks, and the robot lands there.

Fresh session, the simulated robot in the paper's room (hidden; ground-truth perception). Capture & map;
a click on the floor behind the line (2.5, 5.0) is refused with a viewpoint or Look around, naming Go
look; **Go look** (clicked, as many times as the console offers a next look, at most four) goes to each
look as a mission (walk, take-off, fly), faces the goal, captures and maps, and plans the goal again;
then the route to the goal lands behind the line; Register, Build mission, Execute (clicked) run to the
end with no refusal and no contact from the simulator, and the robot stands within 0.5 m of the goal.

The whole journey from the start is walk, take-off, fly (the looks hover over and behind the line: a
level camera sees the floor only beyond ``h / tan(24.5°)``, so the floor behind the 1.2 m line shows
only from a low hover behind it, facing back), then the final route flies on and lands.

Every step waits on state (session, page), never on time. Skipped with the reason when Chromium or
Playwright is missing.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import pytest

from console.app import ConsoleApp, ConsoleConfig
from console.session.go_look import GO_LOOK, looked_from
from console.session.session import NOTICE, RUN
from tests.console.e2e.test_console_e2e import needs_browser
from tests.console.e2e.test_look_known_space_e2e import LONG, _capture, _click_goal, _page, _wait

GOAL = (2.5, 5.0)
MAX_LOOKS = 4


@pytest.fixture()
def console(tmp_path: Path):
    """The known-space browser test's console, with no battery drain in flight: at time x8 each hover
    capture's mapping (tens of seconds of wall time on a loaded machine) is eight times longer in the air,
    so the battery would decide the test, not the looks (the battery rules have their own tests)."""
    from console.link.sim import SimConfig, SimRobot

    robot = SimRobot(config=SimConfig(time_scale=8.0, drain_fly=0.0))  # the paper's room, hidden
    app = ConsoleApp(ConsoleConfig(robot="sim", session_dir=tmp_path / "session", scene_dir=tmp_path / "scenes",
                                   port=0, fresh=True, record=False), link=robot)
    app.start()
    try:
        yield app
    finally:
        app.stop()


@needs_browser
def test_go_look_opens_a_goal_behind_the_line_and_execute_lands_there(console: ConsoleApp, tmp_path: Path) -> None:
    from playwright.sync_api import expect

    app = console
    s = app.session
    assert app.go_look is not None
    notices: list[str] = []
    s.subscribe(lambda t, p: notices.append(p.body) if t == NOTICE else None)
    pw, ctx, page = _page(app, tmp_path)
    try:
        page.add_style_tag(content=".mantine-Notifications-root { max-height: 40vh; overflow: hidden; }")
        _capture(app, page)
        _click_goal(app, page, GOAL)
        refusal = page.locator(".mantine-Notification-root", has_text="not seen yet").first  # the toast
        refusal.wait_for(timeout=LONG)  # refused, with what to do
        text = refusal.inner_text()
        assert ("look from (" in text or "Look around" in text) and "Go look" in text, text
        assert s.route_snapshot().candidate_goal is None
        kinds: list[str] = []
        for n in range(MAX_LOOKS):
            page.get_by_role("button", name="Go look").click(timeout=LONG)
            # this click's look, not the last one's end: each look taken counts, an error ends it
            _wait(lambda: not app.go_look.running and (app.go_look.outcome.looks > n or s.job.error is not None),
                  f"Go look {n + 1} to end", 900)
            out = app.go_look.outcome
            assert s.job.error is None, s.job.error
            page.get_by_text(out.message[:40]).last.wait_for(timeout=LONG)  # the page says what it found
            if out.planned:
                break
            assert "is still" in out.message and "next look from (" in out.message, out.message
        out = app.go_look.outcome
        assert out.planned, out.message
        kinds += out.kinds
        assert kinds[0].startswith("walk-takeoff-fly"), kinds  # the first look goes up over the start
        # never twice from the same spot and heading
        poses = looked_from(s)
        for i, (a, ya) in enumerate(poses):
            for b, yb in poses[i + 1:]:
                assert not (math.dist(a, b) < 0.3 and abs((ya - yb + math.pi) % (2 * math.pi) - math.pi) < 0.2)
        cand = s.route_snapshot().candidate_goal
        assert cand is not None and math.dist(cand[:2], GOAL) < 0.3
        page.get_by_role("button", name="Register").click(timeout=LONG)
        _wait(lambda: len(s.route_snapshot().registered) == 1, "registered")
        page.get_by_role("button", name="Build mission").click(timeout=LONG)
        _wait(lambda: s.mission is not None, "the mission")
        final = s.mission.kinds()
        assert final[-1] in ("land", "walk") and "land" in final, final
        land = next(seg for seg in s.mission.segments if seg.kind.value == "land")
        assert land.waypoints[-1][1] > 4.3, land.waypoints  # lands behind the line (y = 3.8 .. 4.2 m)
        kinds.append("-".join(dict.fromkeys(final)))
        journey = "-".join(kinds).split("-")
        assert journey[:3] == ["walk", "takeoff", "fly"] and journey.count("land") == 1, journey
        expect(page.get_by_role("button", name="Execute")).to_be_enabled(timeout=LONG)
        states: list[str] = []  # the last look's move ended "done" too: this mission's states only
        s.subscribe(lambda t, p: states.append(p.state) if t == RUN else None)
        page.get_by_role("button", name="Execute").click(timeout=LONG)
        _wait(lambda: "running" in states and states[-1] in ("done", "paused", "aborted", "failed"),
              "the mission to end", 600)
        assert s.run.state == "done", (s.run, notices[-5:])
        assert not any("contact with an unmapped obstacle" in m or "refused" in m for m in notices), notices
        here = app.link.latest_state().position
        assert here[2] < 0.05 and here[1] > 4.3 and math.dist(here[:2], GOAL) < 0.5, here
        page.screenshot(path=str(tmp_path / "go_look.png"))
    finally:
        ctx.close()
        pw.stop()

