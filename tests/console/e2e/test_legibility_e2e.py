"""The screen stays legible, round two, in a real headless browser (Playwright, Debian's Chromium), on the
simulated robot after a capture of the paper's room:

- **Add goal right after the page loads** (1440 x 900, 1280 x 720): the Goal fields are filled by their labels
  and Add goal pressed as soon as it is there; while the plan is held (as a first plan that waits for the
  planner's kernels: seconds, silently, before), the tab says "Planning a path to (…)"; then the candidate path
  comes;
- **every label in the declutter** (1440 x 900, 1280 x 720): with a mission (take-off, fly, land), the tab shows
  the mission's spot labels ("take-off", "land") and object labels, none overlapping each other nor the labels
  every tab shows (the robot's); from a view where an object's label would fall on the robot's, it is left out;
  after the robot flew and landed elsewhere, the labels chosen again leave its label free;
- **short capture notices** (1440 x 900, 1280 x 720, and a 390 x 844 phone): a capture's long report pops up as
  its summary ("… full text: Notices, under Capture & map"), a few lines, inside the window, over neither the
  robot and mission block nor its buttons (on the phone: above the control sheet); one click on *Notices: full
  text* shows every note.

Every step waits on the console's state or the page's, never on time; clicks are repeated when a redraw detached
the button. Screenshots go to the test's folder. Skipped with the reason when Chromium or Playwright is missing.
"""

from __future__ import annotations

import itertools
import math
import threading
import time
from pathlib import Path
from typing import Any, Callable

import numpy as np
import pytest

from console.app import ConsoleApp, wait_until
from console.views.client_notice import DETAILS_WHERE
from console.views.notice_details import FOLDER
from console.views.object_labels import choose, fixed_labels, label_rect, overlaps, project, px_per_css
from console.views.screen_layout import PHONE_SHEET_VH
from tests.console.e2e.e2e_helpers import open_tab
from tests.console.e2e.test_console_e2e import needs_browser

LONG = 90_000  # [ms] generous waits for the page on a loaded 2-core machine
GOAL = (2.6, 2.2)  # seen free floor after the first capture, between the robot and the line of boxes
MISSION_GOALS = ((2.6, 2.8, 1.2), (*GOAL, 0.0))  # up into the air, then down on floor the capture saw free
# ((3.0, 2.8, 1.2) is now refused: within the mapping margin the planner grows office_chair-2 by)
MAPPED = ("26 objects seen (2 new, 21 updated, 3 not used) in 4.1 s; not used: desk (0.4 m outside the workspace: "
          "not added); chair-2: seen in part along the viewing ray: its centre, a guess from the class size, not used; "
          "cardboard_box-7: buried 0.20 m below the floor (check the camera pose); office_chair-1: sigma grown: near "
          "(0.55 m), cut on 3 sides")
SEEN_TITLES = """
window.__mnSeen = [];
new MutationObserver(() => {
  document.querySelectorAll('.mantine-Notification-title').forEach((e) => {
    if (!e.__mnSeen) { e.__mnSeen = true; window.__mnSeen.push(e.textContent); }
  });
}).observe(document, {subtree: true, childList: true, characterData: true});
"""
"""Page init script: every notification title the page ever shows, in order (a notice replaced at once included)."""


@pytest.fixture(scope="module")
def console(captured_console: ConsoleApp) -> ConsoleApp:
    """The console after one capture (``conftest.py``)."""
    return captured_console


def _open(browser: Any, app: ConsoleApp, width: int, height: int) -> tuple[Any, Any]:
    """A new tab at ``width`` x ``height`` recording the notices it shows, as soon as Add goal is on it."""
    return open_tab(browser, app, width, height, ready="Add goal", init_script=SEEN_TITLES)


def _click(page: Any, locator: Callable[[], Any], done: Callable[[], bool], what: str, timeout: float = 240.0) -> None:
    """Click until ``done`` (state) holds, each try bounded by the time left (a redraw may detach the element)."""
    from playwright.sync_api import Error

    deadline = time.monotonic() + timeout
    while not done():
        left = deadline - time.monotonic()
        assert left > 0, f"timed out clicking for {what}"
        try:
            target = locator()
            target.scroll_into_view_if_needed(timeout=min(LONG, left * 1000))
            target.click(timeout=min(LONG, left * 1000))
        except Error:  # detached or covered while redrawn: find it again
            pass
        wait_until(done, min(10.0, max(left, 0.1)), 0.05)


def _looks_down(camera: Any) -> bool:
    """Whether the tab's camera looks (nearly) straight down (its OpenCV z axis in the world frame)."""
    w, x, y, z = (float(v) for v in camera.wxyz)
    return 1 - 2 * (x * x + y * y) < -0.99


def _seen(page: Any) -> list[str]:
    return list(page.evaluate("window.__mnSeen || []"))


def _fixed_rects(app: ConsoleApp, camera: Any) -> list[tuple[str, Any]]:
    """The screen boxes [px] of the labels every tab shows (the robot's ...), for this tab's camera."""
    scale = px_per_css(camera.image_height)
    out = []
    for f in fixed_labels(app.server):
        p = project(camera.wxyz, camera.position, float(camera.fov), camera.image_width, camera.image_height, f.position)
        if p is not None:
            out.append((f.text, label_rect(f.text, p[0], p[1], scale, f.anchor, f.font_scale)))
    return out


def _robot_rect(app: ConsoleApp, camera: Any) -> Any:
    return next(r for t, r in _fixed_rects(app, camera) if t.startswith("robot"))


def _none_overlap(app: ConsoleApp, client: Any) -> tuple[bool, list[Any]]:
    shown = app.views["objects"].labels.shown(client.client_id)
    boxes = shown + _fixed_rects(app, client.camera)
    bad = [(a, b) for a, b in itertools.combinations(boxes, 2) if overlaps(a[1], b[1], gap=0.0)]
    return not bad, bad


def _notice_box(page: Any, title: str) -> dict[str, Any]:
    """The notification titled ``title`` once shown: its box and text (read in one go)."""
    js = ("t => { const n = Array.from(document.querySelectorAll('.mantine-Notification-root'))"
          ".find(e => (e.querySelector('.mantine-Notification-title') || {}).textContent === t);"
          " if (!n) return null; const b = n.getBoundingClientRect();"
          " return {x: b.x, y: b.y, width: b.width, height: b.height, text: n.innerText}; }")
    page.wait_for_function(f"({js})({title!r}) !== null", timeout=LONG)
    return page.evaluate(js, title)


def _rect_of(page: Any, locator: Any) -> dict[str, float]:
    locator.wait_for(state="visible", timeout=LONG)
    box = locator.bounding_box(timeout=LONG)
    assert box is not None
    return box


def _apart(a: dict[str, float], b: dict[str, float]) -> bool:
    return (a["x"] + a["width"] <= b["x"] or b["x"] + b["width"] <= a["x"]
            or a["y"] + a["height"] <= b["y"] or b["y"] + b["height"] <= a["y"])


def _pinned_block(page: Any) -> dict[str, float]:
    return page.evaluate("() => { const b = document.querySelector('[data-mn-pin]').closest('.mantine-Paper-root')"
                         ".getBoundingClientRect(); return {x: b.x, y: b.y, width: b.width, height: b.height}; }")


def _check_capture_notice(app: ConsoleApp, page: Any, width: int, height: int, tmp_path: Path, name: str) -> dict:
    """A capture's long report pops up short, inside the window, off the robot and mission block."""
    app.session.notify("Mapped", MAPPED, "warning")  # what the mapping job says after a capture (same path)
    box = _notice_box(page, "Mapped")
    page.screenshot(path=str(tmp_path / f"notice-{name}.png"))
    assert "26 objects seen (2 new, 21 updated, 3 not used) in 4.1 s" in box["text"], box
    assert DETAILS_WHERE in box["text"] and "buried" not in box["text"], box  # the summary, and where the rest is
    assert box["height"] <= 0.2 * height, box  # a few lines, not a wall of text over the 3D view
    assert box["x"] >= 0 and box["y"] >= 0 and box["x"] + box["width"] <= width and box["y"] + box["height"] <= height
    return box


def _open_details(page: Any) -> None:
    """One click on the expander shows the whole report."""
    note = page.get_by_text("cardboard_box-7: buried 0.20 m below the floor (check the camera pose)", exact=True).first
    _click(page, lambda: page.get_by_text(FOLDER, exact=True).first, lambda: note.is_visible(), "the notice details")
    assert page.get_by_text("not used: desk (0.4 m outside the workspace: not added)", exact=True).first.is_visible()


@needs_browser
@pytest.mark.parametrize("width, height", [(1440, 900), (1280, 720)], ids=["1440x900", "1280x720"])
def test_add_goal_at_once_labels_never_overlap_and_capture_notices_stay_short(
        console: ConsoleApp, browser: Any, tmp_path: Path, monkeypatch: pytest.MonkeyPatch, width: int, height: int) -> None:
    app, s = console, console.session
    if s.run.active:
        assert wait_until(lambda: not s.run.active, 300), s.run
    s.clear_route()
    page, client = _open(browser, app, width, height)
    try:
        # --- Add goal right after the page loads: an answer at once, then the candidate ---------------------
        # (the plan is held until the page shows the answer: as a first plan waiting for the planner's kernels)
        gate, plan = threading.Event(), s.add_goal
        monkeypatch.setattr(s, "add_goal", lambda *a, **k: gate.wait(300) and plan(*a, **k))
        for axis, value in zip("xyz", (*GOAL, 0.0)):
            page.get_by_label(f"Goal {axis} [m]", exact=True).fill(f"{value:.2f}")
        _click(page, lambda: page.get_by_role("button", name="Add goal", exact=True),
               lambda: "Planning" in _seen(page), "the answer to Add goal")
        assert page.get_by_text(f"a path to ({GOAL[0]:.2f}, {GOAL[1]:.2f}, 0.00) m…").is_visible()
        gate.set()
        assert wait_until(lambda: s.route_snapshot().candidate_goal is not None, 60), _seen(page)
        goal = s.route_snapshot().candidate_goal
        assert math.dist(goal[:2], GOAL) < 0.3, (goal, _seen(page))
        page.wait_for_function("(window.__mnSeen || []).includes('Candidate path')", timeout=LONG)
        monkeypatch.undo()
        s.discard()

        # --- a mission: its spot labels and the objects', none overlapping, the robot's left free ----------
        s.set_plan_unknown(True)  # the air above the floor is not seen by the level camera at 0.35 m
        for g in MISSION_GOALS:
            res = s.add_goal(g)
            assert res.ok, res.message
            s.register()
        assert "takeoff" in s.build_mission().kinds()
        labels = app.views["objects"].labels
        _click(page, lambda: page.get_by_role("button", name="Top view", exact=True),  # the take-off spot clear of
               lambda: _looks_down(client.camera), "the Top view")  # the robot's label (from behind it, it hides it)
        assert wait_until(lambda: labels.shown(client.client_id, layer="paths")
                          and labels.shown(client.client_id, layer="objects"), 60), labels.shown(client.client_id)
        assert any("take-off" in t for t, _ in labels.shown(client.client_id, layer="paths"))
        ok, bad = _none_overlap(app, client)
        assert ok, bad
        page.add_style_tag(content=".mantine-Notifications-root { display: none !important; }")
        page.screenshot(path=str(tmp_path / f"labels-{width}x{height}.png"))

        # a view where an object's label would fall on the robot's: it is left out (the camera looks at an
        # object's label past the robot's, both anchors on one line of sight)
        robot = np.asarray(s.robot.pose.translation, dtype=np.float64) + (0.0, 0.0, 0.55)  # type: ignore[union-attr]
        spots = sorted(labels.spots(), key=lambda sp: math.dist(sp.position[:2], robot[:2]))
        conflict = None
        for spot in [sp for sp in spots if math.dist(sp.position[:2], robot[:2]) > 0.8][:6]:
            away = robot - np.asarray(spot.position)  # the two labels' anchors on one line of sight
            eye = robot + 2.5 * away / np.linalg.norm(away)
            with client.atomic():
                client.camera.position = tuple(eye)
                client.camera.look_at = tuple(spot.position)
            if not wait_until(lambda: math.dist(client.camera.position, eye) < 1e-3, 30):
                print("the tab did not take the view", eye, client.camera.position)
                continue
            rr = _robot_rect(app, client.camera)
            if any(overlaps(r, rr, gap=0.0) for _, r in choose(spots, client.camera)):  # without the robot's label
                conflict = spot.text
                break
        assert conflict is not None, "no view found where an object label would fall on the robot's"
        assert wait_until(lambda: labels.shown(client.client_id, layer="objects") and _none_overlap(app, client)[0], 30), \
            _none_overlap(app, client)[1]
        page.screenshot(path=str(tmp_path / f"labels-robot-{width}x{height}.png"))
        page.evaluate("document.querySelectorAll('style').forEach(s => { if (s.textContent.includes("
                      "'.mantine-Notifications-root { display: none')) s.remove(); })")

        # --- a capture's long report: short, inside the window, off the mission block; details one click away --
        box = _check_capture_notice(app, page, width, height, tmp_path, f"{width}x{height}")
        for what in (_pinned_block(page), _rect_of(page, page.get_by_role("button", name="Execute", exact=True)),
                     _rect_of(page, page.get_by_role("button", name="Build mission", exact=True))):
            assert _apart(box, what), (box, what)
        _open_details(page)
        page.screenshot(path=str(tmp_path / f"notice-details-{width}x{height}.png"))
    finally:
        page.close()


@needs_browser
def test_labels_follow_the_robot_when_it_moves(console: ConsoleApp, browser: Any, tmp_path: Path) -> None:
    app, s = console, console.session
    if s.mission is None:
        s.clear_route()
        s.set_plan_unknown(True)
        for g in MISSION_GOALS:
            assert s.add_goal(g).ok
            s.register()
        s.build_mission()
    page, client = _open(browser, app, 1280, 720)
    try:
        page.add_style_tag(content=".mantine-Notifications-root { display: none !important; }")
        end = MISSION_GOALS[-1]
        eye = (end[0] + 0.3, end[1] - 3.0, 1.3)
        with client.atomic():  # a low view from behind where the robot lands, the boxes beyond it
            client.camera.position = eye
            client.camera.look_at = (end[0], end[1] + 3.0, 0.3)
        assert wait_until(lambda: math.dist(client.camera.position, eye) < 1e-3, 30)
        _click(page, lambda: page.get_by_role("button", name="Execute", exact=True), lambda: s.run.state != "idle",
               "Execute")
        assert wait_until(lambda: s.run.state == "done", 300), s.run
        assert math.dist(s.robot.pose.translation[:2], end[:2]) < 0.5  # type: ignore[union-attr]
        labels = app.views["objects"].labels
        assert wait_until(lambda: labels.shown(client.client_id, layer="objects") and _none_overlap(app, client)[0], 30), \
            _none_overlap(app, client)[1]
        page.screenshot(path=str(tmp_path / "labels-after-the-flight-1280x720.png"))
    finally:
        page.close()


@needs_browser
def test_a_phone_gets_short_notices_above_the_sheet(console: ConsoleApp, browser: Any, tmp_path: Path) -> None:
    app = console
    width, height = 390, 844
    page, client = _open(browser, app, width, height)
    try:
        box = _check_capture_notice(app, page, width, height, tmp_path, "phone")
        sheet_top = height * (1 - PHONE_SHEET_VH / 100)
        assert box["y"] + box["height"] <= sheet_top + 2, (box, sheet_top)  # over the 3D view, not the controls
        # the labels are decluttered after each camera report: wait for the page's latest one
        assert wait_until(lambda: _none_overlap(app, client)[0], 60), _none_overlap(app, client)[1]
    finally:
        page.close()
