"""What a new operator sees, in a real headless browser (Playwright, Debian's Chromium) at 1440 x 900 and
1280 x 720, on the simulated robot after one capture of the paper's room (``conftest.py``'s console):

- **the Find panel's refusal is short**: *Find* "unicorn", *Start search*: the notice says why in one line
  (at most 150 characters, inside the window) and the classes the perception can name are one click away,
  in *Notices: full text*;
- **unseen space is not yellow**: ticking *Plan into unknown space* (found by its label) leaves the yellow
  (dangerous) cells drawn within 25 % of their count with it off, where they were ~4x as many;
- **every column of the mission table in sight**: with a walk / take-off / fly / land mission built, each
  header and cell of the table shows its whole text (``scrollWidth <= clientWidth``) and the table needs no
  sideways scroll;
- **the search's viewpoint label in the declutter**: a search in step mode shows its next viewpoint's label
  in the tab, and from a view where it would fall on the robot's label it is left out (the robot's wins);
  no two labels the tab shows overlap (the objects', the mission's spots, the search's, the robot's).

Every step waits on the console's state or the page's, never on time; clicks are retried while a redraw
detaches the element (:mod:`tests.console.e2e.e2e_helpers`). Screenshots go to the test's folder. Skipped
with the reason when Chromium or Playwright is missing.
"""

from __future__ import annotations

import itertools
import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from console.app import ConsoleApp
from console.views.client_notice import DETAILS_WHERE, SHORT_CHARS
from console.views.grid_view import layer_mask
from console.views.notice_details import FOLDER
from console.views.object_labels import GAP_PX, fixed_labels, label_rect, overlaps, project, px_per_css
from tests.console.e2e.e2e_helpers import LONG_MS, button, click_until, open_tab, wait_for
from tests.console.e2e.test_console_e2e import needs_browser

MISSION_GOALS = ((2.5, 5.5, 1.5), (2.0, 1.5, 0.0))  # over the line of boxes, then back to land in front of it
HIDE_NOTICES = ".mantine-Notifications-root { display: none !important; }"
SEEN = """
window.__mnSeen = [];
new MutationObserver(() => {
  document.querySelectorAll('.mantine-Notification-root').forEach((e) => {
    const t = e.querySelector('.mantine-Notification-title'), d = e.querySelector('.mantine-Notification-description');
    if (t && d && !e.__mnSeen) { e.__mnSeen = true; const b = e.getBoundingClientRect();
      window.__mnSeen.push({title: t.textContent, body: d.textContent, x: b.x, y: b.y, width: b.width, height: b.height}); }
  });
}).observe(document, {subtree: true, childList: true, characterData: true});
"""
"""Page init script: every notification the page shows (title, body, box when first drawn), in order."""
TABLE_JS = """() => {
  const m = document.querySelector('[data-mn-pin]'); if (!m) return null;
  const t = Array.from(m.closest('.mantine-Paper-root').querySelectorAll('table'))
    .find(e => e.textContent.includes('length'));
  if (!t || t.querySelectorAll('td').length === 0) return null;
  const tb = t.getBoundingClientRect();
  return {scrollWidth: t.scrollWidth, clientWidth: t.clientWidth, left: tb.left, right: tb.right,
    cells: Array.from(t.querySelectorAll('th, td')).map(c => { const b = c.getBoundingClientRect();
      return {text: c.textContent, scrollWidth: c.scrollWidth, clientWidth: c.clientWidth, left: b.left, right: b.right}; })};
}"""
"""The mission table's and each of its cells' widths [CSS px], or null while there is no table."""


def _notices(page: Any, title: str) -> list[dict[str, Any]]:
    return [n for n in page.evaluate("window.__mnSeen || []") if n["title"] == title]


def _label_boxes(app: ConsoleApp, client: Any) -> list[tuple[str, Any]]:
    """What the tab shows now: its decluttered labels and the labels every tab shows, with their boxes [px]."""
    cam = client.camera
    scale = px_per_css(cam.image_height)
    boxes = list(app.views["objects"].labels.shown(client.client_id))
    for f in fixed_labels(app.server):
        p = project(cam.wxyz, cam.position, float(cam.fov), cam.image_width, cam.image_height, f.position)
        if p is not None:
            boxes.append((f.text, label_rect(f.text, p[0], p[1], scale, f.anchor, f.font_scale)))
    return boxes


def _overlapping(app: ConsoleApp, client: Any) -> list[Any]:
    return [(a, b) for a, b in itertools.combinations(_label_boxes(app, client), 2) if overlaps(a[1], b[1], gap=0.0)]


def _mission(app: ConsoleApp) -> None:
    s = app.session
    s.clear_route()
    for g in MISSION_GOALS:
        res = s.add_goal(g)
        assert res.ok, res.message
        s.register()
    assert {"takeoff", "fly", "land"} <= set(s.build_mission().kinds())


@needs_browser
@pytest.mark.parametrize("width, height", [(1440, 900), (1280, 720)], ids=["1440x900", "1280x720"])
def test_what_a_new_operator_sees(captured_console: ConsoleApp, browser: Any, tmp_path: Path,
                                  width: int, height: int) -> None:
    app, s = captured_console, captured_console.session
    if s.plan_unknown == "allow":  # the other window size's run ticked it
        s.set_plan_unknown(False)
    s.clear_route()
    page, client = open_tab(browser, app, width, height, init_script=SEEN)
    grid_view = app.views["grid"]
    try:
        # --- Find "unicorn": a short refusal, the classes one click away ----------------------------------------
        target = lambda: page.get_by_label("Find", exact=True)  # noqa: E731
        click_until(lambda: page.get_by_text("Find", exact=True).first, lambda: target().is_visible(), "the Find folder")
        target().fill("unicorn")
        wait_for(lambda: str(app.views["search"].target.value) == "unicorn", "the Find field on the server")
        click_until(button(page, "Start search"), lambda: bool(_notices(page, "Not possible")), "the refusal")
        note = _notices(page, "Not possible")[-1]
        page.screenshot(path=str(tmp_path / f"find-refused-{width}x{height}.png"))
        assert note["body"].startswith("Find: 'unicorn' is not an object the perception can name"), note
        assert len(note["body"]) <= SHORT_CHARS and DETAILS_WHERE in note["body"], note
        assert note["x"] >= 0 and note["y"] >= 0 and note["x"] + note["width"] <= width, note
        assert note["y"] + note["height"] <= height and note["height"] <= 0.2 * height, note
        classes = page.get_by_text("robot dog, table, chair", exact=False).first
        click_until(lambda: page.get_by_text(FOLDER, exact=True).first, lambda: classes.is_visible(), "the full text")
        classes.scroll_into_view_if_needed()
        page.screenshot(path=str(tmp_path / f"find-refused-full-text-{width}x{height}.png"))
        assert not app.search.running
        page.add_style_tag(content=HIDE_NOTICES)

        # --- Plan into unknown space: unseen space stays grey, not yellow ---------------------------------------
        def yellow_drawn() -> bool:
            want = int(layer_mask(s.grid, "dangerous").sum())
            return grid_view.drawn_counts().get("dangerous", 0) == want

        wait_for(yellow_drawn, "the yellow cells drawn")
        closed = grid_view.drawn_counts()["dangerous"]
        box = lambda: page.get_by_label("Plan into unknown space", exact=True)  # noqa: E731
        click_until(box, lambda: box().is_checked(), "Plan into unknown space")  # (the page's state: a click that
        # took is never undone by a second one while the server is still rebuilding the grid)
        wait_for(lambda: s.plan_unknown == "allow" and s.grid.rule == "allow" and yellow_drawn(),
                 "the yellow cells drawn again")
        allowed = grid_view.drawn_counts()["dangerous"]
        unseen = int(s.grid.unseen.sum()) if s.grid.unseen is not None else 0
        print(f"yellow cells drawn at {width}x{height}: {closed} with unknown space closed, {allowed} planning into it "
              f"({unseen} unseen cells passable)")
        assert unseen > 1000 and abs(allowed - closed) <= 0.25 * closed, (closed, allowed, unseen)
        page.screenshot(path=str(tmp_path / f"plan-unknown-{width}x{height}.png"))

        # --- the mission table: every column in sight -------------------------------------------------------------
        _mission(app)
        page.wait_for_function(f"({TABLE_JS})() !== null && ({TABLE_JS})().cells.length >= 4 * 4", timeout=LONG_MS)
        table = page.evaluate(TABLE_JS)
        page.locator("[data-mn-pin]").first.evaluate("m => m.closest('.mantine-Paper-root').scrollIntoView()")
        page.screenshot(path=str(tmp_path / f"mission-table-{width}x{height}.png"))
        cut = [c for c in table["cells"] if c["scrollWidth"] > c["clientWidth"] + 1 or c["right"] > table["right"] + 1]
        assert not cut, (cut, table["right"])
        assert table["scrollWidth"] <= table["clientWidth"] + 1, table  # no sideways scroll hides a column
        assert table["right"] <= width and any("length" in c["text"] for c in table["cells"])

        # --- the search's viewpoint label: in this tab's declutter, the robot's wins ----------------------------------
        labels = app.views["objects"].labels
        mode = lambda: page.get_by_label("Search mode", exact=True)  # noqa: E731
        app.views["search"].mode.value = "step"  # each move waits for Approve step: the viewpoint stays chosen
        target().fill("robot dog")
        wait_for(lambda: str(app.views["search"].target.value) == "robot dog", "the Find field")
        assert mode().is_visible()
        click_until(button(page, "Start search"), lambda: app.search.running, "Start search")
        try:
            wait_for(lambda: app.search.waiting_approval and app.search.chosen is not None, "the first viewpoint", 300)
            vp = app.search.chosen
            text = f"next viewpoint: gain {vp.gain:.1f} m³, cost {vp.cost:.1f}"
            assert text not in [f.text for f in fixed_labels(app.server)]  # not one label for every tab
            robot = np.asarray(s.robot.pose.translation, dtype=np.float64) + (0.0, 0.0, 0.55)  # type: ignore[union-attr]
            spot = np.asarray(vp.eye, dtype=np.float64)
            apart = robot[:2] - spot[:2]
            side = np.array([-apart[1], apart[0]]) / np.linalg.norm(apart) if np.linalg.norm(apart) > 0.3 \
                else np.array([0.0, -1.0])
            # a view where the viewpoint's label would fall on the robot's (the first viewpoint is often where the
            # robot stands: a turn in place), then a low view from the side where it is clear of it
            if np.linalg.norm(robot - spot) > 0.3:  # the camera, the robot's label and the viewpoint on one line
                on_it = (robot + 2.0 * (robot - spot) / np.linalg.norm(robot - spot), spot)
            else:  # straight above the robot
                on_it = (robot + (0.0, 0.05, 2.5), robot)
            beside = (spot + np.array([*(2.5 * side), 0.1]), spot + (0.0, 0.0, 0.1))
            for name, (eye, at), falls_on_it in (("behind-robot", on_it, True), ("beside", beside, False)):
                with client.atomic():
                    client.camera.position = tuple(eye)
                    client.camera.look_at = tuple(at)
                wait_for(lambda: math.dist(client.camera.position, eye) < 1e-3, "the tab to take the view", 60)
                cam = client.camera
                scale = px_per_css(cam.image_height)
                vu, vv, _ = project(cam.wxyz, cam.position, float(cam.fov), cam.image_width, cam.image_height, spot)
                robot_box = next(r for t, r in _label_boxes(app, client) if t.startswith("robot"))
                would = overlaps(label_rect(text, vu, vv, scale, "top-left"), robot_box, GAP_PX * scale)
                assert would == falls_on_it, (name, would)  # the view is the one meant
                shows = lambda: any(t == text for t, _ in labels.shown(client.client_id, layer="search"))  # noqa: E731
                wait_for(lambda: shows() != falls_on_it and not _overlapping(app, client),
                         f"the viewpoint's label {'left out' if falls_on_it else 'shown'} ({name}): "
                         f"{_label_boxes(app, client)}", 60)
                page.screenshot(path=str(tmp_path / f"viewpoint-label-{name}-{width}x{height}.png"))
        finally:
            app.search.stop()
            wait_for(lambda: not app.search.running, "the search to stop", 300)
        wait_for(lambda: not labels.spots("search"), "the viewpoint's label to go", 60)
    finally:
        page.close()

