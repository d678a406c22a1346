"""End to end in a real headless browser: the operator maps the demo room and plans a mission.

Starts the console (simulated robot, fresh session) on a free port, opens it in Debian's Chromium
through Playwright, clicks **Capture & map**, clicks a goal on the floor in the 3D view, registers
it and builds the mission, and checks on the server that the objects, the grid and the green path
exist. A screenshot is saved in the test's output folder (and copied to ``docs/console.png`` when
``MORPHONAVI_UPDATE_SCREENSHOT=1``).

The browser test is skipped, with the reason, when ``/usr/bin/chromium`` or the ``playwright``
package is missing (``make browser`` installs Chromium; ``pip install playwright`` brings the
driver; no browser is ever downloaded). The console's wiring without a browser (the watched scene
folder, restart, the loopback default) is tested too.
"""

from __future__ import annotations

import math
import os
import shutil
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np
import pytest

CHROMIUM = Path("/usr/bin/chromium")
REPO = Path(__file__).resolve().parents[3]

from console.app import ConsoleApp, ConsoleConfig, is_loopback, wait_until  # noqa: E402
from console.session.topics import RUN  # noqa: E402
from console.session.mapping_job import JOB_NAME  # noqa: E402
from pipeline.scene import Scene, SceneObject, save_scene  # noqa: E402


def _browser_missing() -> str | None:
    if not CHROMIUM.exists():
        return "Debian's chromium is not installed (/usr/bin/chromium); run `make browser`"
    try:
        import playwright.sync_api  # noqa: F401
    except ImportError:
        return "the playwright package is not installed (pip install playwright)"
    return None


needs_browser = pytest.mark.skipif(_browser_missing() is not None, reason=_browser_missing() or "")

BROWSER_ARGS = [
    "--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
    "--disable-background-networking", "--disable-component-update", "--disable-sync",
    "--use-angle=swiftshader", "--enable-unsafe-swiftshader",
]
VIEWPORT = {"width": 1440, "height": 900}


def _click_until(page: Any, name: str, done: Any, timeout: float = 300.0) -> None:
    """Click the button ``name`` until ``done()`` (the console's state) holds: on a loaded machine a click
    can time out, or land on a button a redraw detaches; each try is bounded by the time left."""
    from playwright.sync_api import Error

    deadline = time.monotonic() + timeout
    while not done():
        left = deadline - time.monotonic()
        assert left > 0, f"clicking {name!r} never took effect"
        try:
            page.get_by_role("button", name=name).first.click(timeout=max(1_000, min(60_000, left * 1000)))
        except Error:  # slow, or re-drawn mid-click: find it again
            pass
        wait_until(done, min(10.0, max(0.0, deadline - time.monotonic())))


def _project(camera: Any, point: np.ndarray) -> tuple[float, float] | None:
    """Canvas pixel (x right, y down) of a world point seen by a viser client camera, or None."""
    q = np.asarray(camera.wxyz, dtype=np.float64)  # world <- camera, OpenCV optical frame
    w, x, y, z = q
    R = np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
        [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
        [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
    ])
    p = R.T @ (np.asarray(point, dtype=np.float64) - np.asarray(camera.position))
    if p[2] <= 0:
        return None
    h, wpx = camera.image_height, camera.image_width
    f = (h / 2) / math.tan(camera.fov / 2)
    return (wpx / 2 + f * p[0] / p[2], h / 2 + f * p[1] / p[2])


def _ray_hits_box(origin: np.ndarray, target: np.ndarray, obj: Any, pad: float = 0.15) -> bool:
    """Whether the segment origin -> target passes through an object's (padded, upright) box."""
    w, h, l = obj.size
    half = max(w, l) / 2 + pad
    lo = np.array(obj.position) - (half, half, h / 2 + pad)
    hi = np.array(obj.position) + (half, half, h / 2 + pad)
    d = target - origin
    t0, t1 = 0.0, 1.0
    for a in range(3):
        if abs(d[a]) < 1e-12:
            if not lo[a] <= origin[a] <= hi[a]:
                return False
            continue
        ta, tb = sorted(((lo[a] - origin[a]) / d[a], (hi[a] - origin[a]) / d[a]))
        t0, t1 = max(t0, ta), min(t1, tb)
        if t0 > t1:
            return False
    return True


def _clear_floor_pixel(app: ConsoleApp, camera: Any, candidates: list[tuple[float, float]]) -> tuple[np.ndarray, tuple[float, float]]:
    """The first candidate floor point whose pixel sees the floor past every mapped object."""
    eye = np.asarray(camera.position, dtype=np.float64)
    for x, y in candidates:
        target = np.array([x, y, 0.0])
        px = _project(camera, target)
        if px is None or not (40 < px[0] < camera.image_width - 40 and 40 < px[1] < camera.image_height - 40):
            continue
        if any(_ray_hits_box(eye, target, o) for o in app.session.scene.objects):
            continue
        cell = app.session.grid.workspace.cell_of(target)
        if cell is None or app.session.grid.state_at(cell).name != "FREE":
            continue
        return target, px
    pytest.fail("no candidate floor point is visible past the mapped objects")


def _clear_object_pixel(app: ConsoleApp, camera: Any) -> tuple[Any, tuple[float, float]]:
    """A mapped object in the room whose centre is not hidden behind another object, and its pixel."""
    eye = np.asarray(camera.position, dtype=np.float64)
    ws = app.session.workspace
    objs = sorted(app.session.scene.objects, key=lambda o: math.dist(o.position, eye))
    for obj in objs:
        c = np.asarray(obj.position, dtype=np.float64)
        if not ws.contains(c) or min(obj.size) < 0.3:
            continue
        px = _project(camera, c)
        if px is None or not (60 < px[0] < camera.image_width - 60 and 60 < px[1] < camera.image_height - 60):
            continue
        toward = eye + (c - eye) * (1 - 0.5 * min(obj.size) / np.linalg.norm(c - eye))  # just before its box
        if any(_ray_hits_box(eye, toward, o, pad=0.1) for o in objs if o.id != obj.id):
            continue
        return obj, px
    pytest.fail("no mapped object is in clear view")


@pytest.fixture()
def console(tmp_path: Path):
    from console.link.sim import SimConfig, SimRobot

    robot = SimRobot(config=SimConfig(time_scale=12.0))  # the default robot, 12x faster than real time
    app = ConsoleApp(ConsoleConfig(robot="sim", session_dir=tmp_path / "session", scene_dir=tmp_path / "scenes",
                                   port=0, fresh=True), link=robot)
    app.start()
    try:
        yield app
    finally:
        app.stop()


@needs_browser
def test_operator_maps_the_room_and_builds_a_mission(console: ConsoleApp, tmp_path: Path) -> None:
    from playwright.sync_api import sync_playwright

    app = console
    session = app.session
    assert session is not None and app.server is not None
    assert app.config.host == "127.0.0.1" and app.url.startswith("http://127.0.0.1:")
    assert session.scene.objects == () and session.known_summary().rule == "nothing_seen"  # starts unmapped: unseen
    assert "known space: nothing seen yet" in app.views["known_space"].summary.content  # the Map folder says so

    with sync_playwright() as pw:
        ctx = pw.chromium.launch_persistent_context(
            tempfile.mkdtemp(prefix="chromium-", dir=tmp_path), executable_path=str(CHROMIUM), headless=True,
            args=BROWSER_ARGS, viewport=VIEWPORT,
        )
        try:
            page = ctx.new_page()
            page.goto(app.url)
            capture = page.get_by_role("button", name="Capture & map")
            capture.wait_for(timeout=30_000)
            assert wait_until(lambda: len(app.server.get_clients()) == 1, 15), "the page did not connect"

            # --- Capture & map (simulated robot, ground-truth perception) ---------------------------
            _click_until(page, "Capture & map", lambda: session.job is not None and session.job.name == JOB_NAME)
            assert wait_until(lambda: session.job.name == JOB_NAME and not session.job.running and session.job.fraction == 1.0, 180), session.job
            assert len(session.scene.objects) >= 10, "the first photo should show the obstacles in front"
            counts = session.grid.counts()
            assert counts["occupied"] > 0 and counts["dangerous"] > 0
            assert session.capture is not None and session.capture.backend.startswith("ground truth")
            assert app.views["capture"].has_frustum
            assert wait_until(lambda: len(app.views["objects"].drawn_ids()) == len(session.scene.objects), 60)

            # --- click a goal on the floor in the 3D view --------------------------------------------
            client = next(iter(app.server.get_clients().values()))
            canvas = page.locator("canvas").first.bounding_box()
            assert canvas is not None
            # a floor point the photo saw free (behind the line nothing is seen yet: refused, see
            # tests/console/e2e/test_look_known_space_e2e.py)
            seen = [(x, y) for y in (2.6, 2.2, 2.0, 1.8) for x in (2.6, 2.4, 2.8)]
            target, px = _clear_floor_pixel(app, client.camera, seen)
            sx = canvas["width"] / client.camera.image_width
            sy = canvas["height"] / client.camera.image_height
            page.mouse.click(canvas["x"] + px[0] * sx, canvas["y"] + px[1] * sy)
            assert wait_until(lambda: session.route_snapshot().candidate_goal is not None, 60), \
                "the click on the floor did not make a candidate path"
            goal = session.route_snapshot().candidate_goal
            assert goal[2] == 0.0 and math.dist(goal[:2], target[:2]) < 0.3  # the ray hit the floor there
            assert wait_until(lambda: "candidate" in app.views["paths"].drawn(), 60)

            # --- register, build the mission -----------------------------------------------------------
            _click_until(page, "Register", lambda: len(session.route_snapshot().registered) == 1)
            _click_until(page, "Build mission", lambda: session.mission is not None)
            mission = session.mission
            assert math.dist(mission.segments[0].start[:2], session.route_snapshot().start[:2]) < 0.2
            assert math.dist(mission.segments[-1].end[:2], goal[:2]) < 0.25
            assert wait_until(lambda: all(f"mission_{k}" in app.views["paths"].drawn() for k in mission.kinds()), 60)
            drawn = app.views["paths"].drawn()
            assert "registered" in drawn and "candidate" not in drawn
            first = {"walk": "walk", "takeoff": "take-off", "fly": "fly", "land": "land"}[mission.kinds()[0]]
            page.get_by_role("cell", name=first).first.wait_for(timeout=60_000)  # the segment list in the panel

            # --- screenshot for people ---------------------------------------------------------------------
            page.add_style_tag(content=".mantine-Notifications-root { display: none !important; }")
            time.sleep(1.5)  # let the renderer settle
            shot = tmp_path / "console.png"
            page.screenshot(path=str(shot))

            # --- click an object: its details; delete it -----------------------------------------------------
            obj, opx = _clear_object_pixel(app, client.camera)
            page.keyboard.down("Shift")  # in goal mode a plain click goes through objects; Shift selects
            page.mouse.click(canvas["x"] + opx[0] * sx, canvas["y"] + opx[1] * sy)
            page.keyboard.up("Shift")
            assert wait_until(lambda: session.selected is not None, 60), "clicking the object did not select it"
            assert session.selected.id == obj.id
            time.sleep(0.5)
            assert session.route_snapshot().candidate_goal is None  # the click was not taken as a goal
            page.get_by_text("source capture").first.wait_for(timeout=60_000)  # the details table (a loaded machine)
            page.get_by_role("button", name="Delete", exact=True).click(timeout=60_000)
            _click_until(page, "Delete object", lambda: obj.id not in {o.id for o in session.scene.objects})  # the question
            assert wait_until(lambda: obj.id not in app.views["objects"].drawn_ids(), 60)

            # --- a short walk in the mapped area, executed over the robot link ---------------------------
            # (the route behind the line may cross boxes the first photo did not see: that is what the
            # next Capture & map is for; the simulator would stop the robot there)
            _click_until(page, "Clear", lambda: session.route_snapshot().registered == () and session.mission is None)
            near = [(x, y) for y in (2.2, 2.0, 1.8, 2.4) for x in (2.5, 2.3, 2.7)]
            target, px = _clear_floor_pixel(app, client.camera, near)
            page.mouse.click(canvas["x"] + px[0] * sx, canvas["y"] + px[1] * sy)
            assert wait_until(lambda: session.route_snapshot().candidate_goal is not None, 60)
            goal = session.route_snapshot().candidate_goal
            _click_until(page, "Register", lambda: len(session.route_snapshot().registered) == 1)
            _click_until(page, "Build mission", lambda: session.mission is not None)
            kinds_id = session.mission.id
            first_capture = session.capture.id
            runs: list[Any] = []  # every run status the session published (a short walk can end between polls)
            session.subscribe(lambda t, p: runs.append(p) if t == RUN else None)
            _click_until(page, "Execute", lambda: bool(runs) or session.run.state != "idle")
            assert wait_until(lambda: session.run.state == "done", 180), session.run
            assert any(r.state == "running" for r in runs), runs  # it went through the robot link, with progress
            assert kinds_id in session.run.message
            robot = session.robot
            assert robot is not None and math.dist(robot.pose.translation[:2], goal[:2]) < 0.3
            assert session.route_snapshot().registered == () and session.mission is None  # retired
            # next goals start here (the route start follows the robot's next state after the run ends)
            assert wait_until(lambda: math.dist(session.route_snapshot().start[:2], goal[:2]) < 0.3, 60), \
                session.route_snapshot().start
            page.screenshot(path=str(tmp_path / "after_mission.png"))

            # --- a second tab sees the same state and can act ------------------------------------------
            other = ctx.new_page()
            other.set_viewport_size({"width": 1000, "height": 700})
            other.goto(app.url)
            other.get_by_text(f"mission {kinds_id} done").first.wait_for(timeout=90_000)
            assert wait_until(lambda: len(app.server.get_clients()) == 2, 60)
            n_before = len(session.scene.objects)
            _click_until(other, "Capture & map", lambda: session.job.running or session.capture.id != first_capture)
            assert wait_until(lambda: not session.job.running and session.capture.id != first_capture, 180)
            assert len(session.scene.objects) >= n_before
            page.get_by_text(session.capture.id).first.wait_for(timeout=60_000)  # shown in the first tab too
        finally:
            ctx.close()
    assert shot.stat().st_size > 20_000
    if os.environ.get("MORPHONAVI_UPDATE_SCREENSHOT") == "1":
        (REPO / "docs").mkdir(exist_ok=True)
        shutil.copyfile(shot, REPO / "docs" / "console.png")
    # the session survived on disk: a restart restores it
    assert (session.folder / "session.json").exists()


def test_dropped_scene_files_spawn_and_a_restart_restores_the_session(tmp_path: Path) -> None:
    from console.session.session import NOTICE

    cfg = ConsoleConfig(session_dir=tmp_path / "session", scene_dir=tmp_path / "scenes", port=0, fresh=True)
    app = ConsoleApp(cfg).start()
    try:
        session = app.session
        assert is_loopback(cfg.host) and not is_loopback("0.0.0.0") and not is_loopback("192.168.1.4")
        notices = []
        session.subscribe(lambda t, p: notices.append(p) if t == NOTICE else None)
        # the robot's frame: 2 m ahead of the robot, which starts at (2.5, 0.7) facing +y
        ahead = Scene(objects=(SceneObject("crate", "cardboard_box", (2.0, 0.0, 0.3), (0.6, 0.6, 0.6), frame="robot"),))
        save_scene(ahead, tmp_path / "scenes" / "drop.json")
        assert wait_until(lambda: len(session.scene.objects) == 1, 10), notices
        crate = session.scene.object("crate")
        assert crate.frame == "world" and crate.position == pytest.approx((2.5, 2.7, 0.3), abs=1e-6)
        assert session.grid.counts()["occupied"] > 0 and session.grid.rule == "fully_known"  # a hand-made map
        assert wait_until(lambda: "the map from scene files is taken as fully known"
                          in app.views["known_space"].summary.content, 30), app.views["known_space"].summary.content
        (tmp_path / "scenes" / "broken.json").write_text('{"version": 1, "objects": [{"id": "x"}]}')
        assert wait_until(lambda: any(n.title == "Scene file ignored" and "broken.json" in n.body
                                      and "objects[0].label" in n.body for n in notices), 10), notices
        assert len(session.scene.objects) == 1
    finally:
        app.stop()
    again = ConsoleApp(ConsoleConfig(session_dir=tmp_path / "session", scene_dir=tmp_path / "scenes", port=0)).start()
    try:
        time.sleep(1.5)  # a watcher pass: files already spawned are not spawned again
        assert [o.id for o in again.session.scene.objects] == ["crate"]
        assert again.session.grid.counts()["occupied"] > 0
    finally:
        again.stop()


def test_an_unreadable_session_is_kept_aside_and_the_console_starts_empty(tmp_path: Path) -> None:
    folder = tmp_path / "session"
    folder.mkdir()
    (folder / "session.json").write_text('{"kind": "morphonavi-session", "version": 1, "scene": {"objects": 3}}')
    app = ConsoleApp(ConsoleConfig(session_dir=folder, scene_dir=tmp_path / "scenes", port=0)).start()
    try:
        assert app.session.scene.objects == ()
        kept = list(folder.glob("session.json.unreadable-*"))
        assert len(kept) == 1 and '"objects": 3' in kept[0].read_text()
    finally:
        app.stop()


def test_the_console_refuses_an_address_it_cannot_listen_on(tmp_path: Path) -> None:
    from console.app import check_listenable

    check_listenable("127.0.0.1")
    with pytest.raises(OSError, match="cannot listen on 'no.such.host.invalid'"):
        check_listenable("no.such.host.invalid")
