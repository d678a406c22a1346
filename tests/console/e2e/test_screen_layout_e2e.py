"""The screen stays legible, in a real headless browser (Playwright, Debian's Chromium), on the
simulated robot after a capture of the paper's room and a five-segment mission (walk, take-off, fly,
land, walk):

- at 1440 x 900 and 1280 x 720: the robot status line and the mission buttons are inside the window
  and stay there (not covered) while the panel scrolls to the Plan section, whose buttons are then
  in sight and not under the pinned block; the mission table's "take-off" is on one line; the default
  view and the Top view show all eight corners of the flight volume; free cells are not drawn until
  the Free cells box under Layers is ticked; the object labels shown do not overlap (they are drawn by
  WebGL, so their boxes are the server's projection for that tab's camera) and fewer are shown than
  there are objects' labels;
- the frame rate while the view orbits is measured (requestAnimationFrame count) and printed; only
  that frames are drawn is asserted;
- at 390 x 844 (a phone): the wider-screen line shows, the status line and the Execute button are in
  the sheet, the camera panel is reachable at the sheet's end and opens with its photo, and the whole
  room and the robot are in the 3D view above the sheet.

Every step waits on state (the session, the page), never on time. Skipped with the reason when
Chromium or Playwright is missing. Screenshots for people are saved in the test's output folder.
"""

from __future__ import annotations

import itertools
import math
import threading
import time
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from console.app import ConsoleApp, wait_until
from console.views.object_labels import overlaps
from console.views.screen_layout import PHONE_SHEET_VH, WIDER_SCREEN_TEXT
from tests.console.e2e.e2e_helpers import open_tab
from tests.console.e2e.test_console_e2e import _project, needs_browser

LONG = 90_000  # [ms] generous waits for the page on a loaded machine
HIDE_NOTICES = ".mantine-Notifications-root { display: none !important; }"
MISSION_GOALS = ((2.5, 5.5, 1.5), (2.0, 1.5, 0.0))  # over the line of boxes, then back to land in front of it
# (after one capture no floor behind the line is seen free to land on; a second goal at (2.0, 7.0) was once
# reached only by walking 0.12 m from the wall x = 0, where the line's unmapped end box stands)


@pytest.fixture(scope="module")
def console(captured_console: ConsoleApp) -> ConsoleApp:
    """The console after one capture (``conftest.py``), with a five-segment mission built."""
    s = captured_console.session
    s.set_plan_unknown(True)  # the first goal hovers behind the line, not seen from the start
    for goal in MISSION_GOALS:
        res = s.add_goal(goal)
        assert res.ok, res.message
        s.register()
    mission = s.build_mission()
    assert "takeoff" in mission.kinds()
    return captured_console


def _open(browser: Any, app: ConsoleApp, width: int, height: int) -> tuple[Any, Any]:
    """A new tab at ``width`` x ``height``, connected, and its client on the server."""
    return open_tab(browser, app, width, height, style=HIDE_NOTICES)


def _box(page: Any, locator: Any) -> dict[str, float]:
    locator.wait_for(state="visible", timeout=LONG)
    box = locator.bounding_box(timeout=LONG)
    assert box is not None
    return box


STATUS_JS = """() => { const all = Array.from(document.querySelectorAll('small'))
    .filter(e => e.textContent.startsWith('robot sim'));
  if (!all.length) return null; const b = all[0].getBoundingClientRect();
  const t = document.elementFromPoint(b.x + Math.min(20, b.width / 2), b.y + b.height / 2);
  return {x: b.x, y: b.y, width: b.width, height: b.height, onTop: !!t && (all[0].contains(t) || t.contains(all[0]))}; }"""


def _status(page: Any) -> dict[str, Any]:
    """The robot status line's box, and whether it is what the page shows there (read in one go: the
    line is redrawn with every robot state)."""
    page.wait_for_function(f"({STATUS_JS})() !== null", timeout=LONG)
    return page.evaluate(STATUS_JS)


def _in_window(box: dict[str, float], width: int, height: int) -> bool:
    return box["x"] >= 0 and box["y"] >= 0 and box["x"] + box["width"] <= width and box["y"] + box["height"] <= height


def _on_top(page: Any, locator: Any) -> bool:
    """Whether the element is what the page shows at its centre (not covered by another)."""
    return bool(locator.evaluate(
        "e => { const b = e.getBoundingClientRect(); const t = document.elementFromPoint(b.x + b.width / 2, "
        "b.y + b.height / 2); return !!t && (e === t || e.contains(t) || t.contains(e)); }", timeout=LONG))


def _corners(app: ConsoleApp) -> list[tuple[float, float, float]]:
    ws = app.session.workspace
    return list(itertools.product((ws.min[0], ws.max[0]), (ws.min[1], ws.max[1]), (ws.min[2], ws.max[2])))


def _all_in_picture(camera: Any, points: list[Any], top: float = 0.0, bottom: float = 1.0) -> bool:
    h, w = camera.image_height, camera.image_width
    for p in points:
        px = _project(camera, np.asarray(p, dtype=np.float64))
        if px is None or not (0 <= px[0] <= w and top * h <= px[1] <= bottom * h):
            return False
    return True


def _looks_down(camera: Any) -> bool:
    """Whether the camera's optical axis (OpenCV z, world frame) points (nearly) straight down."""
    w, x, y, z = (float(v) for v in camera.wxyz)
    forward_z = 1 - 2 * (x * x + y * y)  # third row, third column of the rotation
    return forward_z < -0.99


def _fps(page: Any, client: Any, app: ConsoleApp, seconds: float = 4.0) -> tuple[float, float]:
    """Frames per second and the longest frame [ms] while the server orbits the tab's view."""
    ws = app.session.workspace
    centre = np.array([(ws.min[0] + ws.max[0]) / 2, (ws.min[1] + ws.max[1]) / 2, 0.5])
    stop = threading.Event()

    def orbit() -> None:
        a = 0.0
        while not stop.wait(0.05):
            a += 0.05
            eye = centre + np.array([7.0 * math.sin(a), -7.0 * math.cos(a), 5.0])
            with client.atomic():
                client.camera.position = tuple(eye)
                client.camera.look_at = tuple(centre)

    t = threading.Thread(target=orbit, daemon=True)
    t.start()
    try:
        frames, longest = page.evaluate(
            "ms => new Promise(done => { let n = 0, last = performance.now(), worst = 0; const t0 = last;"
            " function tick(now) { n += 1; worst = Math.max(worst, now - last); last = now;"
            " if (now - t0 < ms) requestAnimationFrame(tick); else done([n, worst]); }"
            " requestAnimationFrame(tick); })", seconds * 1000)
    finally:
        stop.set()
        t.join(2.0)
    return frames / seconds, float(longest)


@needs_browser
@pytest.mark.parametrize("width, height", [(1440, 900), (1280, 720)])
def test_status_and_mission_buttons_stay_in_sight_and_the_view_fits(console: ConsoleApp, browser: Any, tmp_path: Path,
                                                                    width: int, height: int) -> None:
    app = console
    page, client = _open(browser, app, width, height)
    try:
        execute = page.get_by_role("button", name="Execute", exact=True)
        build = page.get_by_role("button", name="Build mission", exact=True)
        for what in (execute, build):
            assert _in_window(_box(page, what), width, height), what
        assert _in_window(_status(page), width, height)
        page.screenshot(path=str(tmp_path / f"screen-{width}x{height}.png"))

        # the default view shows the whole flight volume between the panels
        assert _all_in_picture(client.camera, _corners(app)), "the default view cuts the room"

        # the mission table: "take-off" on one line
        cell = page.get_by_role("cell", name="take-off").first
        lines = cell.evaluate(  # the lines the cell's words sit on (text nodes only: the colour chip is no word)
            "e => { const tops = []; const w = document.createTreeWalker(e, NodeFilter.SHOW_TEXT); let n;"
            " while ((n = w.nextNode())) { if (!n.textContent.trim()) continue; const r = document.createRange();"
            " r.selectNodeContents(n); for (const q of r.getClientRects()) tops.push(q.top); }"
            " tops.sort((a, b) => a - b); let k = tops.length ? 1 : 0;"
            " for (let i = 1; i < tops.length; i++) if (tops[i] - tops[i - 1] > 4) k += 1; return k; }")
        assert lines == 1, f"the 'take-off' cell wraps over {lines} lines"

        # scroll the panel down to the Plan section: its buttons in sight, the pinned block still there
        register = page.get_by_role("button", name="Register", exact=True)
        register.scroll_into_view_if_needed(timeout=LONG)
        assert wait_until(lambda: _on_top(page, register) and _in_window(register.bounding_box(timeout=LONG), width, height), 20), \
            "Register is out of sight or under the pinned block"
        assert _in_window(_box(page, execute), width, height) and _on_top(page, execute)
        line = _status(page)
        assert _in_window(line, width, height) and line["onTop"], line
        page.screenshot(path=str(tmp_path / f"screen-{width}x{height}-plan.png"))

        # object labels: fewer than the groups, none overlapping (the tab's own choice for its view)
        labels = app.views["objects"].labels
        assert wait_until(lambda: len(labels.shown(client.client_id)) >= 3, 30), labels.shown(client.client_id)
        shown = labels.shown(client.client_id, layer="objects")
        assert len(shown) < len(labels.spots()), (len(shown), len(labels.spots()))  # some left out: declutter works
        for (ta, a), (tb, b) in itertools.combinations(shown, 2):
            assert not overlaps(a, b, gap=0.0), (ta, a, tb, b)
        print(f"\n{width}x{height}: {len(shown)} of {len(labels.spots())} object labels shown, none overlapping")

        # free cells: off, one tick under Layers shows them
        grid = app.views["grid"]
        assert "free" not in grid.drawn_counts()
        page.get_by_text("not drawn: tick", exact=False).first.wait_for(timeout=LONG)
        layers = page.get_by_text("Layers", exact=True).first
        layers.scroll_into_view_if_needed(timeout=LONG)
        layers.click(timeout=LONG)
        box = page.get_by_label("Free cells")
        box.check(timeout=LONG)
        assert wait_until(lambda: grid.drawn_counts().get("free", 0) > 0, 30), grid.drawn_counts()
        box.uncheck(timeout=LONG)
        assert wait_until(lambda: "free" not in grid.drawn_counts(), 30), grid.drawn_counts()

        # Top view: the whole flight volume (a robot hovering by a wall at 2.1 m is inside it)
        top = page.get_by_role("button", name="Top view", exact=True)
        top.scroll_into_view_if_needed(timeout=LONG)
        top.click(timeout=LONG)
        assert wait_until(lambda: _looks_down(client.camera), 30), "the Top view did not come"
        assert wait_until(lambda: _all_in_picture(client.camera, _corners(app)), 30), "the Top view cuts the volume"
        page.screenshot(path=str(tmp_path / f"screen-{width}x{height}-top.png"))

        # frame rate while the view orbits (printed: a figure for people, not a timing assertion)
        # (baseline in the same run: the same orbit with the cell layers off)
        drawn = grid.drawn_counts()
        fps, longest = _fps(page, client, app)
        on = {name: box.value for name, box in grid._checks.items()}
        for box in grid._checks.values():
            box.value = False
        try:
            assert wait_until(lambda: grid.drawn_counts() == {}, 30), grid.drawn_counts()
            bare, bare_longest = _fps(page, client, app)
        finally:
            for name, box in grid._checks.items():
                box.value = on[name]
        print(f"{width}x{height}: {fps:.1f} frames per second while orbiting with the cell layers drawn {drawn} "
              f"(longest frame {longest:.0f} ms); {bare:.1f} with no cells (longest {bare_longest:.0f} ms): "
              f"{fps / max(bare, 1e-9):.2f}x the bare scene's rate (headless Chromium, software WebGL)")
        assert fps > 0 and bare > 0  # frames are drawn; the rates are figures for people, not asserted
    finally:
        page.close()


@needs_browser
def test_a_phone_gets_the_controls_in_a_sheet_and_the_room_above_it(console: ConsoleApp, browser: Any,
                                                                     tmp_path: Path) -> None:
    app = console
    width, height = 390, 844
    page, client = _open(browser, app, width, height)
    try:
        line = page.evaluate("getComputedStyle(document.body, '::after').content")
        assert WIDER_SCREEN_TEXT in line
        assert _in_window(_status(page), width, height)
        sheet = page.evaluate("() => { const b = document.querySelector('[data-mn-pin]')"
                              ".closest('.mantine-Paper-root[style*=\"position: fixed\"]').getBoundingClientRect();"
                              " return [b.x, b.y, b.width, b.height]; }")
        assert sheet[2] >= width - 1 and sheet[3] <= height * PHONE_SHEET_VH / 100 + 2, sheet  # full width, not taller
        execute = page.get_by_role("button", name="Execute", exact=True)
        execute.scroll_into_view_if_needed(timeout=LONG)
        assert _in_window(_box(page, execute), width, height)

        # the whole room and the robot above the sheet
        robot = app.session.robot.pose.translation
        assert wait_until(lambda: _all_in_picture(client.camera, _corners(app) + [tuple(robot)],
                                                  bottom=1 - PHONE_SHEET_VH / 100), 30), "the room is not above the sheet"
        page.screenshot(path=str(tmp_path / "screen-phone.png"))

        # the camera panel: the sheet's last section, one tap opens it with the photo
        camera = page.get_by_text("Camera", exact=True).last
        camera.scroll_into_view_if_needed(timeout=LONG)
        camera.click(timeout=LONG)
        photo = page.get_by_text("Photo and detections", exact=True).first
        photo.scroll_into_view_if_needed(timeout=LONG)
        assert _in_window(_box(page, photo), width, height)
        page.screenshot(path=str(tmp_path / "screen-phone-camera.png"))
    finally:
        page.close()
