"""Editing in a real headless browser (Playwright, Debian's Chromium), at 1440 x 900 and 1280 x 720, on the
simulated robot with two boxes in the operator's map:

- Delete an object, then Undo (the button names it) brings it back and Redo (beside Undo) takes it away
  again; Ctrl+Z and Ctrl+Shift+Z do the same;
- Save as over a named snapshot asks first ("Overwrite 'before-flight'?": Save over it / Cancel): Cancel
  leaves the file as it was, Save over it replaces it; Delete snapshot asks too and removes it;
- a goal typed at the robot's own position is refused with the reason, as the operator sees it, and no
  candidate appears;
- in Top view with goals at altitude, a click lands on the floor point under the cursor, at the altitude,
  and the Goal x / y / z fields show it.

Screenshots go to the test's folder. Every step waits on state (session, page), never on time. Skipped with
the reason when Chromium or Playwright is missing.
"""

from __future__ import annotations

import json
import math
import re
import tempfile
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from console.app import ConsoleApp, ConsoleConfig, wait_until
from pipeline.scene import Scene, SceneObject
from console.views.picking import top_view
from tests.console.e2e.test_console_e2e import BROWSER_ARGS, CHROMIUM, _project, needs_browser

LONG = 90_000  # [ms] generous waits for the page on a loaded 2-core machine
BOXES = (SceneObject("crate-a", "cardboard_box", (1.0, 3.0, 0.3), (0.5, 0.5, 0.6)),
         SceneObject("crate-b", "cardboard_box", (4.0, 3.0, 0.3), (0.5, 0.5, 0.6)))
FLOOR_SPOT = (0.8, 6.8)  # far from the top view's centre: an altitude-plane hit would land well off it
ALTITUDE = 1.5


def _wait(predicate: Any, what: str, timeout: float = 90.0) -> None:
    assert wait_until(predicate, timeout, 0.05), f"timed out waiting for {what}"


def _on_top(page: Any, locator: Any) -> bool:
    """Whether the element at the centre of ``locator`` is it (nothing, e.g. a notice, covers it)."""
    return bool(page.evaluate("el => { const r = el.getBoundingClientRect();"
                              " return el.contains(document.elementFromPoint(r.x + r.width / 2, r.y + r.height / 2)); }",
                              locator.element_handle()))


def _in_view(box: Any, viewport: tuple[int, int]) -> bool:
    return (box is not None and box["x"] >= 0 and box["y"] >= 0 and box["x"] + box["width"] <= viewport[0]
            and box["y"] + box["height"] <= viewport[1])


@needs_browser
@pytest.mark.parametrize("viewport", [(1440, 900), (1280, 720)], ids=["1440x900", "1280x720"])
def test_confirmations_redo_zero_length_goals_and_top_view_clicks(tmp_path: Path, viewport: tuple[int, int]) -> None:
    from playwright.sync_api import expect, sync_playwright

    from console.link.sim import SimConfig, SimRobot

    robot = SimRobot(config=SimConfig(time_scale=8.0))
    app = ConsoleApp(ConsoleConfig(robot="sim", session_dir=tmp_path / "session", scene_dir=tmp_path / "scenes",
                                   port=0, fresh=True), link=robot).start()
    shots = tmp_path / "shots"
    shots.mkdir()
    try:
        s = app.session
        assert s is not None and app.server is not None
        s.spawn(Scene(objects=BOXES), origin="file room.json")
        _wait(lambda: s.robot is not None, "the robot's first state")
        with sync_playwright() as pw:
            ctx = pw.chromium.launch_persistent_context(
                tempfile.mkdtemp(prefix="chromium-", dir=tmp_path), executable_path=str(CHROMIUM), headless=True,
                args=BROWSER_ARGS, viewport={"width": viewport[0], "height": viewport[1]})
            try:
                page = ctx.new_page()
                page.goto(app.url)
                page.get_by_role("button", name="Add goal").wait_for(timeout=LONG)
                _wait(lambda: len(app.server.get_clients()) == 1, "the page connected")

                # --- delete an object; Undo brings it back, Redo takes it away again -----------------------
                s.select("crate-b")
                page.get_by_role("button", name="Delete", exact=True).click(timeout=LONG)
                page.get_by_text("Delete crate-b?").wait_for(timeout=LONG)  # asks first
                assert "crate-b" in {o.id for o in s.scene.objects}
                page.get_by_role("button", name="Delete object").click(timeout=LONG)
                _wait(lambda: "crate-b" not in {o.id for o in s.scene.objects}, "crate-b deleted")
                undo = page.get_by_role("button", name="Undo delete crate-b")
                undo.click(timeout=LONG)
                _wait(lambda: "crate-b" in {o.id for o in s.scene.objects}, "the undo")
                redo = page.get_by_role("button", name="Redo delete crate-b")
                expect(redo).to_be_enabled(timeout=LONG)
                ub, rb = page.get_by_role("button", name=re.compile("^Undo ")).first.bounding_box(), redo.bounding_box()
                assert ub is not None and rb is not None and 0 < rb["y"] - ub["y"] < 3 * ub["height"], (ub, rb)  # beside
                page.screenshot(path=str(shots / f"redo-{viewport[0]}x{viewport[1]}.png"))
                redo.click()
                _wait(lambda: "crate-b" not in {o.id for o in s.scene.objects}, "the redo")
                expect(page.get_by_role("button", name="Redo", exact=True)).to_be_disabled(timeout=LONG)
                page.keyboard.press("Control+z")  # the keys do the same
                _wait(lambda: "crate-b" in {o.id for o in s.scene.objects}, "Ctrl+Z")
                page.keyboard.press("Control+Shift+z")
                _wait(lambda: "crate-b" not in {o.id for o in s.scene.objects}, "Ctrl+Shift+Z")

                # --- Save as over a snapshot asks; Cancel keeps it, Save over it replaces it -----------------
                page.get_by_text("Session", exact=True).first.click()  # open the folder
                name = page.get_by_label("Name", exact=True)
                name.scroll_into_view_if_needed(timeout=LONG)
                name.fill("before-flight")
                _wait(lambda: app.views["session_files"].name.value == "before-flight", "the name typed")
                save = page.get_by_role("button", name="Save as", exact=True)
                save.click()
                path = s.folder / "before-flight.json"
                _wait(path.exists, "the snapshot saved")
                first = path.read_text()
                s.move_object("crate-a", (1.5, 3.5, 0.3))
                save.click()
                dialog = page.get_by_role("dialog")
                expect(dialog.get_by_text("Overwrite 'before-flight'?")).to_be_visible(timeout=LONG)
                over, cancel = (dialog.get_by_role("button", name=n, exact=True) for n in ("Save over it", "Cancel"))
                assert _in_view(over.bounding_box(), viewport) and _in_view(cancel.bounding_box(), viewport)
                assert _on_top(page, over) and _on_top(page, cancel), "a notice covers the question's buttons"
                page.screenshot(path=str(shots / f"overwrite-{viewport[0]}x{viewport[1]}.png"))
                cancel.click()
                expect(dialog).to_have_count(0, timeout=LONG)
                assert path.read_text() == first
                save.click()
                dialog.get_by_role("button", name="Save over it", exact=True).click(timeout=LONG)
                _wait(lambda: [o["position"] for o in json.loads(path.read_text())["scene"]["objects"]
                               if o["id"] == "crate-a"] == [[1.5, 3.5, 0.3]], "the snapshot replaced")

                # --- Delete snapshot asks, then removes it ------------------------------------------------------
                page.get_by_role("button", name="Delete snapshot", exact=True).click()
                expect(dialog.get_by_text("Delete 'before-flight'?")).to_be_visible(timeout=LONG)
                assert "cannot be undone" in dialog.inner_text()
                page.screenshot(path=str(shots / f"delete-{viewport[0]}x{viewport[1]}.png"))
                dialog.get_by_role("button", name="Delete", exact=True).click()
                _wait(lambda: not path.exists(), "the snapshot deleted")
                expect(page.get_by_text("before-flight.json")).to_have_count(0, timeout=LONG)

                # --- a goal at the robot's own position is refused with the reason -----------------------------
                start = s.route_snapshot().start
                for axis, value in zip("xyz", (start[0] + 0.02, start[1], 0.0)):
                    field = page.get_by_label(f"Goal {axis} [m]", exact=True)
                    field.scroll_into_view_if_needed(timeout=LONG)
                    field.fill(f"{value:.2f}")
                    expect(field).to_have_value(f"{value:.2f}", timeout=LONG)
                page.get_by_role("button", name="Add goal", exact=True).click()
                note = page.get_by_text(re.compile(r"goal is where the robot already is \(0\.02 m\)"))
                note.first.wait_for(timeout=LONG)
                assert s.route_snapshot().candidate is None and s.mission is None
                page.screenshot(path=str(shots / f"zero-goal-{viewport[0]}x{viewport[1]}.png"))

                # --- Top view, goals at altitude: the click lands under the cursor and fills the fields --------
                s.set_goal_mode("altitude", ALTITUDE)
                page.get_by_role("button", name="Top view", exact=True).click()
                client = next(iter(app.server.get_clients().values()))
                cam = client.camera

                def looks_down() -> bool:  # the client reported the top view's camera for the canvas as it is now
                    box = page.locator("canvas").first.bounding_box()
                    if box is None or cam.image_height <= 0:
                        return False
                    above, _, _ = top_view(s.workspace, float(cam.fov), float(cam.aspect))
                    return (math.dist(cam.position, above) < 0.05
                            and abs(box["width"] / box["height"] - cam.image_width / cam.image_height) < 0.01)

                _wait(looks_down, "the top view")
                spot = np.array([*FLOOR_SPOT, 0.0])
                for _attempt in range(3):  # a click while the view still settles into the top view lands elsewhere
                    _wait(looks_down, "the top view")
                    px = _project(cam, spot)
                    assert px is not None and 20 < px[0] < cam.image_width - 20 and 20 < px[1] < cam.image_height - 20, px
                    canvas = page.locator("canvas").first.bounding_box()
                    assert canvas is not None
                    page.mouse.click(canvas["x"] + px[0] * canvas["width"] / cam.image_width,
                                     canvas["y"] + px[1] * canvas["height"] / cam.image_height)
                    if wait_until(lambda: s.route_snapshot().candidate_goal is not None, 30, 0.05):
                        if math.dist(s.route_snapshot().candidate_goal[:2], FLOOR_SPOT) < 0.1:
                            break
                        s.discard()  # landed while the view moved: the fields follow the next click too
                page.screenshot(path=str(shots / f"top-view-{viewport[0]}x{viewport[1]}.png"))
                _wait(lambda: s.route_snapshot().candidate_goal is not None, "the clicked goal's candidate")
                goal = s.route_snapshot().candidate_goal
                assert goal[2] == pytest.approx(ALTITUDE) and math.dist(goal[:2], FLOOR_SPOT) < 0.1, goal
                for axis, value in zip("xyz", goal):
                    expect(page.get_by_label(f"Goal {axis} [m]", exact=True)).to_have_value(f"{value:.2f}", timeout=LONG)
                page.screenshot(path=str(shots / f"top-view-click-{viewport[0]}x{viewport[1]}.png"))
            finally:
                ctx.close()
    finally:
        app.stop()
