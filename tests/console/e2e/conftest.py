"""Fixtures shared by the browser tests: Debian's Chromium (one per test module) and the console on the
simulated robot in the paper's room after one Capture & map (one per test module; a fresh session in its own
folder). Pages are opened with :func:`tests.console.e2e.e2e_helpers.open_tab`; a test file that needs more
set-up (a mission) builds it on ``captured_console`` in its own fixture."""

from __future__ import annotations

from typing import Any, Iterator

import pytest

from tests.console.e2e.e2e_helpers import sim_console


@pytest.fixture(scope="module")
def browser() -> Iterator[Any]:
    """Headless Chromium (Playwright), closed after the module's tests."""
    from playwright.sync_api import sync_playwright

    from tests.console.e2e.test_console_e2e import BROWSER_ARGS, CHROMIUM

    with sync_playwright() as pw:
        b = pw.chromium.launch(executable_path=str(CHROMIUM), headless=True, args=BROWSER_ARGS)
        try:
            yield b
        finally:
            b.close()


@pytest.fixture(scope="module")
def captured_console(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Any]:
    """The console (:class:`console.app.ConsoleApp`) on the simulated robot (12x real time, not recorded) after
    one Capture & map, stopped after the module's tests."""
    with sim_console(tmp_path_factory.mktemp("console"), record=False) as app:
        yield app
