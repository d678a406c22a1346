"""The Map folder's buttons say what they do on hover and are off with the reason, in a real headless browser
(Playwright, Debian's Chromium) at 1440 x 900, on the simulated robot in the paper's room after one Capture & map.

A fresh tab: Capture & map, Look around, Look at goal, Go look, Undo and Redo each have a hover text (the
button's ``title``) saying what it does; Look at goal and Go look are off while the Goal fields hold the
robot's own position ("no goal yet: type or click a goal"), Redo with "nothing to redo". A goal behind the
boxes put in the Goal fields (as a floor click does) turns Look at goal and Go look on, their hover text
without the reason. Every step waits on the page's state, never on time. Skipped with the reason when
Chromium or Playwright is missing.
"""

from __future__ import annotations

import re
from typing import Any

from console.app import wait_until
from console.session.look_rules import NO_GOAL
from tests.console.e2e.e2e_helpers import LONG_MS, open_tab, wait_for
from tests.console.e2e.test_console_e2e import needs_browser


def _button(page: Any, name: str) -> Any:
    """The first button whose accessible name is ``name`` or starts with it (``Undo capture c1``)."""
    return page.get_by_role("button", name=re.compile("^" + re.escape(name))).first


def _title(page: Any, name: str, pattern: str) -> str:
    """Button ``name``'s hover text (title) once it matches ``pattern`` (read again: the panel redraws)."""
    seen: list[str] = []

    def matches() -> bool:
        try:
            seen.append(str(_button(page, name).get_attribute("title", timeout=5_000)))
        except Exception:  # redrawn meanwhile: read again
            return False
        return re.search(pattern, seen[-1]) is not None

    assert wait_until(matches, LONG_MS / 1000, 0.2), f"{name}: no hover text matching {pattern!r} (last: {seen[-1:]})"
    return seen[-1]


def _disabled(page: Any, name: str, want: bool) -> None:
    def now() -> bool:
        try:
            return bool(_button(page, name).is_disabled(timeout=5_000)) == want
        except Exception:  # redrawn meanwhile: read again
            return False

    wait_for(now, f"{name} {'off' if want else 'on'} in the page", LONG_MS / 1000)


@needs_browser
def test_map_buttons_say_what_they_do_and_why_they_are_off(browser: Any, captured_console: Any) -> None:
    app = captured_console
    page, _client = open_tab(browser, app, 1440, 900)
    try:
        assert _title(page, "Capture & map", r"^Ask the robot for a photo")
        assert _title(page, "Look around", r"^Turn in place through \d+ headings")
        for name in ("Look at goal", "Go look"):
            text = _title(page, name, re.escape(f"{name} is off: {NO_GOAL}"))
            assert text.split(" · ")[0], text  # what it does comes first
            _disabled(page, name, True)
        assert _title(page, "Undo", r"^Undo the last map edit")  # the first capture can be undone
        _title(page, "Redo", r"Redo is off: nothing to redo")
        _disabled(page, "Redo", True)

        fields = app.views["paths"].goal_fields  # a goal behind the boxes, as a floor click fills it
        fields[0].value, fields[1].value = "2.50", "5.00"
        for name in ("Look at goal", "Go look"):
            _disabled(page, name, False)
            assert "is off" not in _title(page, name, r"^(Turn to face|For the goal)[^·]*$")
    finally:
        page.close()
