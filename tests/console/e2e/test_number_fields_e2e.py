"""Typed numbers in a real headless browser (Playwright, Debian's Chromium, 1440 x 900), on the simulated robot:
the objects panel's Centre x [m] field is text the console checks, so what the operator types is what is checked.

- a move onto the robot is refused and the fields show the desk's real pose again;
- ``abc`` typed as Centre x, Move: refused naming ``centre.x``; the desk stays where it is (before, the browser
  sent nothing and the desk took x from the refused move);
- ``1e308``: refused as far outside the workspace, not moved to 1308 (a number input dropped the ``e``).

Every step waits on state (the console's field values, the session, the page's field), never on time. Skipped
with the reason when Chromium or Playwright is missing.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any, Iterator

import pytest

from console.views import objects_view
from pipeline.scene import Scene, SceneObject
from tests.console.e2e.e2e_helpers import LONG_MS, button, click_until, open_tab, sim_console, wait_for
from tests.console.e2e.test_console_e2e import needs_browser

DESK = SceneObject("desk-1", "desk", (1.3, 2.98, 0.375), (1.4, 0.75, 0.7))
REAL = ("1.300", "2.980", "0.375", "0.0")  # the desk's pose as the fields show it


@pytest.fixture(scope="module")
def console(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Any]:
    """The console on the simulated robot with one desk in the map (no capture), the desk selected."""
    with sim_console(tmp_path_factory.mktemp("console"), capture=False, record=False) as app:
        app.session.spawn(Scene(objects=(DESK,)), origin="the operator's map")
        app.session.select("desk-1")
        yield app


@needs_browser
def test_junk_or_a_huge_centre_x_is_refused_named_and_moves_nothing(
        browser: Any, console: Any, monkeypatch: pytest.MonkeyPatch) -> None:
    from playwright.sync_api import expect

    app, s = console, console.session
    told: list[tuple[str, str]] = []
    shown = objects_view.tell
    monkeypatch.setattr(objects_view, "tell", lambda client, title, body, *a, **k: (
        told.append((title, body)), shown(client, title, body, *a, **k)))
    fields = app.views["objects"]._pose
    handles = (*fields.centre, fields.yaw)
    page, _client = open_tab(browser, app, 1440, 900)
    try:
        def server_has(texts: tuple[str, ...]) -> bool:
            return tuple(str(h.value) for h in handles) == texts

        def type_and_move(texts: tuple[str, ...], what: str) -> None:
            """Type ``texts`` into Centre x / y / z and Yaw in the page, wait for the console to have them, press Move
            until the refusal puts the real pose back (the refusal is the state that shows the click took)."""
            for label, text in zip(("Centre x [m]", "Centre y [m]", "Centre z [m]", "Yaw [deg]"), texts):
                field = page.get_by_label(label, exact=True)
                field.scroll_into_view_if_needed(timeout=LONG_MS)
                field.fill(text, timeout=LONG_MS)
            wait_for(lambda: server_has(texts), f"the typed {what} to reach the console", 120)
            before = len(told)
            click_until(button(page, "Move"), lambda: len(told) > before and server_has(REAL), f"Move ({what})")

        wait_for(lambda: server_has(REAL), "the desk's pose in the fields", 60)
        rx, ry, _rz = (float(v) for v in s.robot.pose.translation)  # type: ignore[union-attr]

        # --- a move onto the robot: refused, and the fields show the real pose again ----------------------------
        type_and_move((f"{rx:.2f}", f"{ry:.2f}", "0.375", "0"), "move onto the robot")
        assert told[-1][0] == "Cannot move" and "would overlap the robot" in told[-1][1], told
        expect(page.get_by_label("Centre x [m]", exact=True)).to_have_value("1.300", timeout=LONG_MS)

        # --- 'abc' as Centre x: refused naming centre.x, the desk stays ------------------------------------------
        type_and_move(("abc", "2.98", "0.375", "0"), "'abc'")
        assert told[-1] == ("Cannot move", "centre.x: must be a number [m], got 'abc'"), told
        assert s.scene.object("desk-1").position == DESK.position
        expect(page.get_by_label("Centre x [m]", exact=True)).to_have_value("1.300", timeout=LONG_MS)

        # --- 1e308: refused as it is, not rewritten to 1308 --------------------------------------------------------
        type_and_move(("1e308", "2.98", "0.375", "0"), "1e308")
        lo, hi = s.workspace.min[0] - 1.0, s.workspace.max[0] + 1.0
        assert told[-1] == ("Cannot move", f"centre.x: 1e+308 m is far outside the workspace ({lo:.2f} to {hi:.2f} m)"), told
        assert s.scene.object("desk-1").position == DESK.position
    finally:
        page.close()
