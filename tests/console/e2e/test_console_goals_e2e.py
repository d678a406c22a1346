"""Goals and legibility in a real headless browser (Playwright, Debian's Chromium), one session.

After the first Capture & map from the start, the operator (at 1440 x 900):
- sees the robot status and the mission's Execute button together;
- clicks the floor just behind the line of boxes from the default view, where the ray passes
  through a box: the goal lands on the floor there, no box is selected;
- in altitude mode clicks on an object: the goal lands on the altitude plane in front of it, the
  object is not selected;
- types a goal (x, y, z) and presses Add goal;
- presses Top view: the camera looks straight down, and a click there still lands on the floor;
- sees a red "disconnected" banner when the server stops, gone once a console is back on the port.

Every step waits on state (server-side session, the client's reported camera, computed styles),
never on time. Skipped with the reason when Chromium or Playwright is missing.
"""

from __future__ import annotations

import math
import re
import tempfile
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from console.app import ConsoleApp, ConsoleConfig, wait_until
from console.session.mapping_job import JOB_NAME
from console.views.objects_view import NONE_CHOICE
from console.views.picking import ray_plane, top_view
from tests.console.e2e.e2e_helpers import click_until
from tests.console.e2e.test_console_e2e import BROWSER_ARGS, CHROMIUM, VIEWPORT, _project, _ray_hits_box, console, needs_browser  # noqa: F401

BANNER_JS = "getComputedStyle(document.body, '::before').content"


def _rotation(wxyz: Any) -> np.ndarray:
    w, x, y, z = (float(v) for v in wxyz)
    return np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
        [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
        [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
    ])


def _inside(camera: Any, px: tuple[float, float] | None, border: float = 60.0) -> bool:
    return px is not None and border < px[0] < camera.image_width - border and border < px[1] < camera.image_height - border


def _free(app: ConsoleApp, p: np.ndarray) -> bool:
    """A cell a goal may be planned to: free, or dangerous only because it is unseen (planning into unknown)."""
    grid = app.session.grid
    cell = grid.workspace.cell_of(p)
    if cell is None:
        return False
    state = grid.state_at(cell).name
    unseen = getattr(grid, "unseen", None)
    return state == "FREE" or (state == "DANGEROUS" and unseen is not None and bool(unseen[tuple(cell)]))


def _refused_goal(notices: list[str]) -> tuple[float, float, float] | None:
    """The goal point a 'Goal not reachable' notice names ('... to (x, y, z): ...'), or ``None``."""
    for text in reversed(notices):
        m = re.search(r"to \((-?[\d.]+), (-?[\d.]+), (-?[\d.]+)\)", text) if "Goal not reachable" in text else None
        if m:
            return (float(m[1]), float(m[2]), float(m[3]))
    return None


def _floor_behind_a_box(app: ConsoleApp, camera: Any) -> tuple[np.ndarray, tuple[float, float], Any]:
    """A free floor point just behind the line of boxes whose view ray passes through a mapped box."""
    eye = np.asarray(camera.position, dtype=np.float64)
    for y in (4.6, 4.8, 5.0, 4.4, 5.2):
        for x in (2.5, 2.0, 3.0, 1.5, 3.5, 1.0, 4.0):
            target = np.array([x, y, 0.0])
            px = _project(camera, target)
            if not _inside(camera, px) or not _free(app, target):
                continue
            through = [o for o in app.session.scene.objects if _ray_hits_box(eye, target, o, pad=-0.05)]
            if through:
                return target, px, through[0]
    pytest.fail("no free floor point behind the boxes is seen through a box from the default view")


def _object_over_free_air(app: ConsoleApp, camera: Any, z: float) -> tuple[Any, tuple[float, float], np.ndarray]:
    """A mapped object whose centre's pixel ray meets the plane at ``z`` in free air inside the workspace."""
    eye = np.asarray(camera.position, dtype=np.float64)
    ws = app.session.workspace
    for obj in sorted(app.session.scene.objects, key=lambda o: math.dist(o.position, eye)):
        c = np.asarray(obj.position, dtype=np.float64)
        px = _project(camera, c)
        if not ws.contains(c) or not _inside(camera, px):
            continue
        hit = ray_plane(eye, c - eye, z)
        if hit is None or not ws.contains(hit) or not _free(app, np.asarray(hit)):
            continue
        others = [o for o in app.session.scene.objects if o.id != obj.id]
        toward = eye + (c - eye) * (1 - 0.5 * min(obj.size) / np.linalg.norm(c - eye))
        if any(_ray_hits_box(eye, toward, o, pad=0.1) for o in others):
            continue  # another object in front: the click might land on it
        return obj, px, np.asarray(hit)
    pytest.fail(f"no mapped object is seen over free air at z = {z} m")


@needs_browser
def test_goals_go_through_objects_typed_goals_top_view_and_the_disconnected_banner(console: ConsoleApp, tmp_path: Path) -> None:
    from playwright.sync_api import sync_playwright

    app = console
    session = app.session
    assert session is not None and app.server is not None
    notices: list[str] = []
    seen_refusals: set[str] = set()  # every refusal shown so far (a queued notice can show up again later)
    port = app.server.get_port()
    again: ConsoleApp | None = None
    with sync_playwright() as pw:
        ctx = pw.chromium.launch_persistent_context(
            tempfile.mkdtemp(prefix="chromium-", dir=tmp_path), executable_path=str(CHROMIUM), headless=True,
            args=BROWSER_ARGS, viewport=VIEWPORT,
        )
        try:
            page = ctx.new_page()
            page.goto(app.url)
            capture = page.get_by_role("button", name="Capture & map")
            capture.wait_for(timeout=60_000)
            assert wait_until(lambda: len(app.server.get_clients()) == 1, 60), "the page did not connect"
            assert page.evaluate(BANNER_JS) == "none"  # connected: no banner

            click_until(lambda: page.get_by_role("button", name="Capture & map"),
                        lambda: session.job is not None and session.job.name == JOB_NAME, "Capture & map")
            assert wait_until(lambda: session.job.name == JOB_NAME and not session.job.running and session.job.fraction == 1.0, 120), session.job
            assert len(session.scene.objects) >= 10
            assert wait_until(lambda: len(app.views["objects"].drawn_ids()) == len(session.scene.objects), 30)
            # the floor behind the line is not seen from the start: the operator plans into unknown space
            # (this test is about where clicks land, not about the known-space rule)
            session.set_plan_unknown(True)
            client = next(iter(app.server.get_clients().values()))
            cam = client.camera

            def click(px: tuple[float, float]) -> None:  # a pixel of the client's camera image
                canvas = page.locator("canvas").first.bounding_box()  # measured now: panels can resize it
                assert canvas is not None
                sx, sy = canvas["width"] / cam.image_width, canvas["height"] / cam.image_height
                page.mouse.click(canvas["x"] + px[0] * sx, canvas["y"] + px[1] * sy)

            # --- the floor just behind the box line, through a box, from the default view ---------------
            target, px, box = _floor_behind_a_box(app, cam)
            click(px)
            # the goal lands on the floor behind the box: planned, or refused naming it (a flight over the line
            # lands only on floor a capture saw free, and nothing saw the floor behind the line yet)
            def refusals() -> list[str]:  # the clicking tab's notices (a refusal is told to the tab that clicked)
                try:
                    return page.locator(".mantine-Notification-root", has_text="Goal not reachable").all_inner_texts()
                except Exception:
                    return []

            def planned_or_refused() -> bool:
                if session.route_snapshot().candidate_goal is not None:
                    return True
                notices[:] = [" ".join(t.split()) for t in refusals()]
                seen_refusals.update(notices)
                return _refused_goal(notices) is not None

            assert wait_until(planned_or_refused, 60), \
                f"the click through {box.id} did not make a goal on the floor behind it: {notices[-3:]}"
            goal = session.route_snapshot().candidate_goal or _refused_goal(notices)
            assert goal is not None and goal[2] == 0.0 and math.dist(goal[:2], target[:2]) < 0.3, (goal, target, notices[-3:])
            assert session.selected is None, f"{session.selected.id} was selected instead"
            assert wait_until(lambda: "drops" not in app.views["paths"].drawn(), 60)  # a floor goal needs no drop line
            # notices sit at the bottom right of the 3D view, clear of its centre and upper left (an
            # error-like notice that stays, so the check does not race an auto-close)
            handle = client.add_notification("Layout check", "stays until closed", color="red", auto_close_seconds=None)
            note = page.locator(".mantine-Notification-root", has_text="Layout check").first
            note.wait_for(timeout=30_000)
            canvas = page.locator("canvas").first.bounding_box()
            assert canvas is not None

            def placed() -> bool:  # measured once its slide-in ends (a loaded page animates slowly)
                box = note.bounding_box()
                return box is not None and box["x"] > canvas["x"] + canvas["width"] / 2

            wait_until(placed, 30)
            nb = note.bounding_box()
            assert nb is not None
            assert nb["x"] > canvas["x"] + canvas["width"] / 2 and nb["y"] > canvas["y"] + canvas["height"] / 2, (nb, canvas)
            assert nb["x"] + nb["width"] <= canvas["x"] + canvas["width"] + 1, (nb, canvas)
            handle.remove()

            # --- altitude mode: a click on an object gives a goal in the air in front of it --------------
            session.set_goal_mode("altitude", 1.5)
            page.get_by_role("textbox", name="Goal on").or_(page.get_by_label("Goal on")).first.wait_for(timeout=60_000)
            obj, opx, hit = _object_over_free_air(app, cam, 1.5)
            click(opx)
            assert wait_until(lambda: (session.route_snapshot().candidate_goal or (0, 0, 0))[2] == pytest.approx(1.5), 60), \
                f"the altitude-mode click on {obj.id} made no goal at 1.5 m"
            goal = session.route_snapshot().candidate_goal
            assert math.dist(goal[:2], hit[:2]) < 0.3 and session.selected is None, (goal, hit, session.selected)
            assert wait_until(lambda: "drops" in app.views["paths"].drawn(), 60)  # the air goal's drop line
            session.set_goal_mode("ground")

            # --- Shift-click selects (highlighted, in the list); Deselect clears the list ------------------
            page.keyboard.down("Shift")
            click(opx)
            page.keyboard.up("Shift")
            assert wait_until(lambda: session.selected is not None and session.selected.id == obj.id, 30), session.selected
            objects = app.views["objects"]
            assert wait_until(lambda: objects.highlighted() == obj.id and objects.chooser_value() == obj.id, 60)
            chooser = page.get_by_label("Select object")
            page.wait_for_function("([el, v]) => el.value === v", arg=[chooser.element_handle(), obj.id], timeout=30_000)
            click_until(lambda: page.get_by_role("button", name="Deselect"), lambda: session.selected is None, "Deselect")
            assert wait_until(lambda: session.selected is None and objects.highlighted() is None, 30)
            page.wait_for_function("([el, v]) => el.value === v", arg=[chooser.element_handle(), NONE_CHOICE], timeout=30_000)

            # --- a typed goal ---------------------------------------------------------------------------
            typed = next(p for p in ((1.5, 2.5), (1.0, 2.5), (2.0, 2.25), (1.0, 1.5)) if _free(app, np.array([*p, 0.0])))
            want = (str(typed[0]), str(typed[1]), "0")
            for i, name in enumerate("xyz"):  # one field at a time: each reaches the server before the next
                label = page.get_by_text(f"Goal {name} [m]", exact=True)  # viser's text input has no label id
                label.locator("xpath=ancestor::*[.//input][1]//input").first.fill(want[i])
                assert wait_until(lambda: app.views["paths"].typed_values()[i] == want[i], 10), \
                    app.views["paths"].typed_values()
            click_until(lambda: page.get_by_role("button", name="Add goal"),
                        lambda: math.dist((session.route_snapshot().candidate_goal or (9, 9, 9))[:2], typed) < 0.2, "Add goal",
                        settle=60.0)

            # --- register, build: status and Execute in sight together at 1440 x 900 -----------------
            click_until(lambda: page.get_by_role("button", name="Register"),
                        lambda: len(session.route_snapshot().registered) == 1, "Register")
            assert len(session.route_snapshot().registered) == 1
            click_until(lambda: page.get_by_role("button", name="Build mission"), lambda: session.mission is not None,
                        "Build mission")
            execute = page.get_by_role("button", name="Execute")
            execute.wait_for(timeout=10_000)
            status = page.get_by_text("link ok").first
            status.wait_for(timeout=10_000)
            for what, loc in (("robot status", status), ("Execute", execute)):
                box_ = loc.bounding_box()
                assert box_ is not None and 0 <= box_["y"] and box_["y"] + box_["height"] <= VIEWPORT["height"], (what, box_)

            page.screenshot(path=str(tmp_path / "mission_built.png"))
            # --- top view: straight down; a click still lands on the floor ------------------------------
            above, _, _ = top_view(session.workspace, float(cam.fov), float(cam.aspect))

            def looks_down() -> bool:  # the client reports its camera there (after any transition)
                return (float(_rotation(cam.wxyz)[:, 2] @ np.array([0.0, 0.0, -1.0])) > 0.999
                        and math.dist(cam.position, above) < 0.05)

            click_until(lambda: page.get_by_role("button", name="Top view"), looks_down, "Top view")
            assert session.route_snapshot().candidate_goal is None  # registered: no candidate to discard
            discard = page.get_by_role("button", name="Discard", exact=True)
            page.wait_for_function("el => el.disabled", arg=discard.element_handle(), timeout=30_000)  # off: nothing to act on
            spot = next(np.array([x, y, 0.0]) for x, y in ((1.0, 2.0), (4.0, 2.0), (1.0, 6.5), (2.5, 6.5), (4.0, 6.5))
                        if _free(app, np.array([x, y, 0.0])))

            def camera_matches_canvas() -> bool:  # the client reported its camera for the canvas as it is now
                box_ = page.locator("canvas").first.bounding_box()
                return box_ is not None and cam.image_height > 0 and looks_down() and abs(
                    box_["width"] / box_["height"] - cam.image_width / cam.image_height) < 0.01

            # refusals from earlier clicks: still shown, or shown again later (viser queues notices beyond its limit)
            before = seen_refusals | {" ".join(t.split()) for t in refusals()}

            def top_goal() -> Any:
                """The goal the Top view click made: the candidate, or a new refusal naming a point near the spot.

                A refusal naming another point is not this click's (an earlier click's goal can be refused again
                once the route's start moves); the click's own goal follows it."""
                if session.route_snapshot().candidate_goal is not None:
                    return session.route_snapshot().candidate_goal
                notices[:] = [t for t in (" ".join(t.split()) for t in refusals()) if t not in before]
                named = [g for g in (_refused_goal([t]) for t in notices) if g is not None]
                return next((g for g in named if math.dist(g[:2], spot[:2]) < 0.2), None)

            everything = lambda: page.locator(".mantine-Notification-root").all_inner_texts()  # noqa: E731
            for _ in range(5):  # a loaded page can drop a click (each one lands on the same spot: the same goal)
                assert wait_until(camera_matches_canvas, 30), (cam.image_width, cam.image_height)
                click(_project(cam, spot))
                if wait_until(lambda: top_goal() is not None, 20):
                    break
            assert top_goal() is not None, (spot, session.route_snapshot().candidate_goal, notices[-3:], everything())
            top = top_goal()
            assert top is not None and math.dist(top[:2], spot[:2]) < 0.2, (top, spot, notices[-3:])  # under the cursor
            page.screenshot(path=str(tmp_path / "top_view.png"))  # for people: tests/ output folder

            # --- the server stops: a banner; a console back on the port: gone ---------------------------
            app.stop()
            page.wait_for_function(f"{BANNER_JS}.includes('Disconnected')", timeout=60_000)
            again = ConsoleApp(ConsoleConfig(session_dir=session.folder, scene_dir=tmp_path / "scenes", port=port)).start()
            page.wait_for_function(f"{BANNER_JS} === 'none'", timeout=90_000)
            assert wait_until(lambda: len(again.server.get_clients()) == 1, 30)
        finally:
            ctx.close()
            if again is not None:
                again.stop()
