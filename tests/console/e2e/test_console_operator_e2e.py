"""The operator stays in control, in a real headless browser (Playwright, Debian's Chromium).

Issue 8, items 1-4, on the simulated robot in a room with the paper's line of boxes (the operator's
map matches the hidden world, as after a perfect Capture & map):

- item 3: a walk paused early, then **Abort** on the ground: **Build mission** then starts at the robot;
- item 2: a paused walk whose remaining path an object is moved onto: **Resume** disappears (the
  retired mission is ended, in every tab) and the route is re-planned from the robot;
- item 1: **Abort** during the take-off climb: the robot holds in the air, **Land here** appears,
  puts the robot on the floor, and the route starts under it;
- item 4: a restart with a saved route far from the robot: Execute is off and says why, one
  **Re-plan from the robot** fixes it, and the mission runs.

Goals are added through the session (the goal clicks themselves are covered by
``tests/console/e2e/test_console_goals_e2e.py``); every operator action under test is a click in the page.
Every step waits on state (session, robot, the page's buttons), never on time. Skipped with the
reason when Chromium or Playwright is missing.
"""

from __future__ import annotations

import math
import tempfile
from pathlib import Path
from typing import Any, Callable

import numpy as np
import pytest

from console.app import ConsoleApp, ConsoleConfig, wait_until
from console.session.session import RobotSnapshot, Session
from pipeline.camera.geometry import Pose
from pipeline.scene import Scene, SceneObject
from tests.console.e2e.e2e_helpers import button, click_until
from tests.console.e2e.test_console_e2e import BROWSER_ARGS, CHROMIUM, VIEWPORT, needs_browser

TOLERANCE = 0.3  # [m] "starts at the robot" (console.session.operator_state.START_TOLERANCE)
LONG = 60_000  # [ms] generous waits for the page on a loaded machine
CATCH_UP = 240_000  # [ms] the page catching up with the robot after a climb (CI with two CPU hogs: over 60 s once)
HIDE_NOTICES = ".mantine-Notifications-root { display: none !important; }"


def _boxes() -> Scene:
    """The paper's line of 1.2 m boxes across the room at y = 4 m."""
    return Scene(objects=tuple(SceneObject(f"box-{n}", "cardboard_box", (0.25 + 0.5 * n, 4.0, 0.6), (0.5, 1.2, 0.5))
                               for n in range(10)))


CRATE = SceneObject("crate", "cardboard_box", (4.5, 7.5, 0.3), (0.5, 0.6, 0.5))


def _start_console(tmp_path: Path, fresh: bool, time_scale: float, walk: float = 0.15, climb: float = 0.3,
                   fly: float = 0.8) -> ConsoleApp:
    from console.link.sim import SimConfig, SimRobot

    # a slow walk and climb [m/s]: a page on a loaded 2-core machine can lag many seconds behind the
    # server, and its clicks must still land before the segment ends
    robot = SimRobot(world=_boxes(), config=SimConfig(time_scale=time_scale, walk_speed=walk, climb_rate=climb,
                                                        fly_speed=fly),
                     room=None)
    app = ConsoleApp(ConsoleConfig(robot="sim", session_dir=tmp_path / "session", scene_dir=tmp_path / "scenes",
                                   port=0, fresh=fresh), link=robot)
    return app.start()


def _near(a: Any, b: Any, tol: float = TOLERANCE) -> bool:
    return math.dist(tuple(a)[:3], tuple(b)[:3]) <= tol


def _robot_at(app: ConsoleApp) -> tuple[float, float, float]:
    return tuple(float(v) for v in app.link.latest_state().position)  # type: ignore[return-value]


def _floor_under(app: ConsoleApp) -> tuple[float, float, float]:
    x, y, _ = _robot_at(app)
    return (x, y, 0.0)


def _open(ctx: Any, app: ConsoleApp) -> Any:
    page = ctx.new_page()
    page.goto(app.url)
    page.get_by_role("button", name="Build mission").wait_for(timeout=LONG)
    page.add_style_tag(content=HIDE_NOTICES)  # pop-ups must not cover the buttons under test
    assert wait_until(lambda: len(app.server.get_clients()) >= 1, 30), "the page did not connect"
    return page


def _button(page: Any, name: str) -> Any:
    return page.get_by_role("button", name=name, exact=True)


def _wait(predicate: Callable[[], bool], what: str, timeout: float = 60.0) -> None:
    assert wait_until(predicate, timeout, 0.02), f"timed out waiting for {what}"


def _click(page: Any, name: str, done: Callable[[], bool], what: str) -> None:
    """Click the button ``name`` until the console's state says ``done`` (each try bounded by the time left:
    a loaded page may draw a frame every few seconds, and a button enabled by the latest state needs one)."""
    click_until(button(page, name), done, what)


def _plan(app: ConsoleApp, page: Any, goal: tuple[float, float, float]) -> None:
    """Add a goal (session), Register and Build mission (clicks)."""
    s = app.session
    n = len(s.route_snapshot().registered)
    res = s.add_goal(goal)
    assert res.ok, res.message
    _click(page, "Register", lambda: len(s.route_snapshot().registered) == n + 1, "registered")
    _click(page, "Build mission", lambda: s.mission is not None, "mission built")


def _launch(ctx_dir: Path) -> tuple[Any, Any]:
    from playwright.sync_api import sync_playwright

    pw = sync_playwright().start()
    ctx = pw.chromium.launch_persistent_context(str(ctx_dir), executable_path=str(CHROMIUM), headless=True,
                                                args=BROWSER_ARGS, viewport=VIEWPORT)
    return pw, ctx


@needs_browser
def test_abort_edit_and_land_keep_the_operator_in_control(tmp_path: Path) -> None:
    from playwright.sync_api import expect

    app = _start_console(tmp_path, fresh=True, time_scale=1.0, walk=0.05, climb=0.03, fly=0.05)
    pw, ctx = _launch(Path(tempfile.mkdtemp(prefix="chromium-", dir=tmp_path)))
    try:
        s = app.session
        notices: list[Any] = []
        s.subscribe(lambda t, p: notices.append(p) if t == "notice" else None)
        s.spawn(Scene(objects=_boxes().objects + (CRATE,)), origin="the test's map")
        page = _open(ctx, app)
        _wait(lambda: s.robot is not None, "the robot's first state")

        # --- item 3: a walk stopped early, aborted on the ground; Build starts at the robot -------------
        _plan(app, page, (2.5, 3.1, 0.0))
        expect(_button(page, "Execute")).to_be_enabled(timeout=LONG)
        _click(page, "Execute", lambda: s.run.state == "running", "the walk under way")
        # clicks take seconds on a loaded machine: the walk is long and slow
        _click(page, "Pause", lambda: s.run.state == "paused", f"paused (run {s.run})")
        _click(page, "Abort", lambda: s.run.state == "aborted", "aborted")
        stopped = _floor_under(app)
        assert stopped[1] < 3.0, "the robot stopped early"
        _wait(lambda: _near(s.route_snapshot().start, stopped, 0.01), "the route start at the robot")
        assert s.mission is None  # the aborted mission is retired ...
        assert s.route_snapshot().goals[-1][:2] == pytest.approx((2.625, 3.125))  # ... its goal is kept
        expect(_button(page, "Resume")).to_be_hidden(timeout=LONG)
        _click(page, "Build mission", lambda: s.mission is not None, "mission rebuilt")
        assert _near(s.mission.segments[0].start, stopped)
        expect(_button(page, "Execute")).to_be_enabled(timeout=LONG)

        # --- item 2: a paused walk; an object moved onto the rest of it retires the mission everywhere -----
        _click(page, "Clear", lambda: s.route_snapshot().registered == () and s.mission is None, "cleared")
        _plan(app, page, (0.6, 3.1, 0.0))
        mission = s.mission
        _click(page, "Execute", lambda: s.run.state == "running", "the walk under way")
        _click(page, "Pause", lambda: s.run.state == "paused", f"paused (run {s.run})")
        expect(_button(page, "Resume")).to_be_visible(timeout=LONG)
        here = np.asarray(_floor_under(app))
        path = s.route_snapshot().registered[0]
        passed = int(np.argmin(np.linalg.norm(path[:, :2] - here[:2], axis=1)))
        # the crate (0.5 x 0.6 m, half-diagonal 0.39 m) must stay clear of the robot's 0.35 m radius: an object
        # moved onto the robot is refused, whichever way the path turns
        ahead = [p for p in path[passed:] if 0.8 < np.linalg.norm(p[:2] - here[:2])
                 and np.linalg.norm(p[:2] - path[-1][:2]) > 0.65]
        assert ahead, f"no room on the rest of the walk for the crate (robot at {here}, path {path.tolist()})"
        spot = ahead[0]
        s.move_object("crate", (float(spot[0]), float(spot[1]), 0.3))  # as the gizmo or another tab would
        assert s.mission is None or s.mission is not mission
        expect(_button(page, "Resume")).to_be_hidden(timeout=LONG)
        _wait(lambda: s.run.state == "aborted", "the retired run ended")
        expect(_button(page, "Execute")).to_be_visible(timeout=LONG)
        page.get_by_text("aborted").first.wait_for(timeout=LONG)  # the run line says so
        _wait(lambda: _near(s.route_snapshot().start, _floor_under(app), 0.01), "re-planned from the robot")
        assert s.route_snapshot().goals[-1][:2] == pytest.approx((0.625, 3.125))

        # --- item 1: abort in the air: the robot holds, armed; Land here puts it on the floor -------------
        # a goal 2.3 m straight above the robot (2.5 m would be nearer the 3 m top than the robot's 0.45 m
        # height): it climbs (slowly) over free floor whenever the click lands; the mission ends in the air,
        # which the panel says
        _click(page, "Clear", lambda: s.route_snapshot().registered == () and s.mission is None, "cleared")
        x, y, _ = _robot_at(app)
        _plan(app, page, (x, y, 2.3))
        goal = s.route_snapshot().goals[-1]
        assert s.mission.kinds()[-1] in ("takeoff", "fly")
        expect(_button(page, "Add landing")).to_be_visible(timeout=LONG)
        page.get_by_text("the mission ends hovering").first.wait_for(timeout=LONG)
        _click(page, "Execute", lambda: s.run.state == "running", "the climb under way")
        _wait(lambda: _robot_at(app)[2] > 0.3, "the robot climbing")
        _click(page, "Abort", lambda: s.run.state == "aborted", "aborted")
        st = app.link.latest_state()
        assert st.armed and not st.landed and st.position[2] > 0.25  # holding in the air
        page.get_by_text("aborted").first.wait_for(timeout=CATCH_UP)  # the page has the abort (the run line)
        expect(_button(page, "Land here")).to_be_enabled(timeout=CATCH_UP)
        expect(_button(page, "Hold")).to_be_visible(timeout=LONG)
        expect(_button(page, "Return")).to_be_visible(timeout=LONG)
        _wait(lambda: _near(s.route_snapshot().start, _robot_at(app)), "the route start at the hovering robot")
        _click(page, "Land here", lambda: s.run.state in ("running", "done"), "landing under way")
        _wait(lambda: app.link.latest_state().landed and not app.link.latest_state().armed and s.run.state == "done",
              f"landed and disarmed ({app.link.latest_state()}, run {s.run}, notices {notices[-4:]})")
        assert math.dist(_robot_at(app)[:2], st.position[:2]) < 0.1 and _robot_at(app)[2] == 0.0  # straight down
        _wait(lambda: _near(s.route_snapshot().start, _floor_under(app), 0.01), "the route start on the floor")
        goals = s.route_snapshot().goals
        assert goals and goals[-1] == pytest.approx(goal), (goals, st)  # the goal is kept
        expect(_button(page, "Land here")).to_be_hidden(timeout=LONG)
        expect(_button(page, "Execute")).to_be_visible(timeout=LONG)
    finally:
        ctx.close()
        pw.stop()
        app.stop()


@needs_browser
def test_a_restart_with_the_robot_elsewhere_is_replanned_from_the_robot(tmp_path: Path) -> None:
    from playwright.sync_api import expect

    before = Session(tmp_path / "session", start=(2.5, 0.7, 0.0))  # the last run left the robot behind the line
    before.spawn(_boxes())
    before.set_robot(RobotSnapshot(Pose.from_xyz_yaw(2.62, 5.75, 0.0), mode="idle", landed=True))
    assert before.add_goal((1.0, 6.5, 0.0)).ok
    before.register()
    before.build_mission()
    del before

    app = _start_console(tmp_path, fresh=False, time_scale=4.0)  # the simulated robot is back at (2.5, 0.7)
    pw, ctx = _launch(Path(tempfile.mkdtemp(prefix="chromium-", dir=tmp_path)))
    try:
        s = app.session
        assert s.mission is not None and s.route_snapshot().start[:2] == pytest.approx((2.62, 5.75))
        page = _open(ctx, app)
        replan = _button(page, "Re-plan from the robot")
        expect(replan).to_be_visible(timeout=LONG)
        expect(_button(page, "Execute")).to_be_disabled(timeout=LONG)
        page.get_by_text("Execute is off").first.wait_for(timeout=LONG)  # and says why
        robot = _floor_under(app)
        _click(page, "Re-plan from the robot", lambda: _near(s.route_snapshot().start, robot, 0.01), "re-planned")
        _wait(lambda: _near(s.route_snapshot().start, robot, 0.01), "the route re-planned from the robot")
        _wait(lambda: s.mission is not None and _near(s.mission.segments[0].start, robot), "the mission rebuilt")
        expect(replan).to_be_hidden(timeout=LONG)
        expect(_button(page, "Execute")).to_be_enabled(timeout=LONG)
        _click(page, "Execute", lambda: s.run.state in ("running", "done"), "the mission under way")
        _wait(lambda: s.run.state == "done", f"the mission done (run {s.run})", timeout=300)
        assert math.dist(_robot_at(app)[:2], (1.125, 6.625)) < 0.3
    finally:
        ctx.close()
        pw.stop()
        app.stop()
