"""The agent's label and a replay's viewpoint label in the per-tab label declutter, in a real headless browser
(Playwright, Debian's Chromium) at 1440 x 900. The agent's, on the simulated robot after a capture of the paper's
room (``conftest.py``):

- the agent plans a candidate (its door's ``plan_to_point``): "proposed by the agent" is placed at its goal in the
  tab's own declutter (layer ``agent``), not as a label every tab shows;
- the tab's view is turned so that the robot's label and the agent's sit on one line of sight (the robot's nearer):
  the tab leaves the agent's out, and no two of the labels it draws overlap, the robot's included;
- the view turned to the side: the tab shows the agent's label again, clear of the robot's and of every other.

The replay's: a search recorded on the simulator (step mode, one approved move), replayed at its last chosen
viewpoint; from a view where "viewpoint N: gain ..., cost ..." would fall on the robot's label the tab leaves it
out, from another it shows it, and no two drawn labels overlap.

Label boxes are measured in the page's own picture: the tab's camera as the page reports it (pose, field of view,
the 3D canvas's size in pixels, checked against the canvas the page lays out), the labels that tab draws, and
viser's label layout (``console.views.object_labels.label_rect``); the boxes are drawn over the page for the
screenshots. Every step waits on the console's state or the page's, never on time. Screenshots go to the test's
folder. Skipped with the reason when Chromium or Playwright is missing.
"""

from __future__ import annotations

import itertools
import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from console.app import ConsoleApp
from console.views.approval_view import AGENT_LABEL
from console.views.object_labels import choose, fixed_labels, label_rect, overlaps, project, px_per_css
from tests.console.e2e.e2e_helpers import open_tab, wait_for
from tests.console.e2e.test_console_e2e import needs_browser

GOAL = (2.6, 2.2)  # seen free floor after the first capture, between the robot and the line of boxes
WIDTH, HEIGHT = 1440, 900
CANVAS_JS = ("() => { const c = Array.from(document.querySelectorAll('canvas')).map(e => e.getBoundingClientRect())"
             ".sort((a, b) => b.width * b.height - a.width * a.height)[0];"
             " return c ? {x: c.x, y: c.y, width: c.width, height: c.height, dpr: window.devicePixelRatio} : null; }")
"""The 3D view's canvas in the page (the largest one) [CSS px], and the page's device pixels per CSS pixel."""


def _boxes(app: ConsoleApp, client: Any) -> list[tuple[str, Any]]:
    """Every label the tab draws now with its box in the tab's picture [px]: the labels every tab shows (the
    robot's, the origin's) and the ones the tab's declutter chose."""
    cam = client.camera
    scale = px_per_css(cam.image_height)
    out = list(app.views["objects"].labels.shown(client.client_id))
    for f in fixed_labels(app.server):
        p = project(cam.wxyz, cam.position, float(cam.fov), cam.image_width, cam.image_height, f.position)
        if p is not None:
            out.append((f.text, label_rect(f.text, p[0], p[1], scale, f.anchor, f.font_scale)))
    return out


def _overlapping(boxes: list[tuple[str, Any]]) -> list[Any]:
    return [(a, b) for a, b in itertools.combinations(boxes, 2) if overlaps(a[1], b[1], gap=0.0)]


def _view(client: Any, labels: Any, reports: list[Any], eye: np.ndarray, target: np.ndarray) -> None:
    """Turn the tab's view, wait until the page reports it back (``reports``: the poses the page sent), and let the
    tab's declutter choose for the view the page reported (its own choice on that report runs on viser's pool)."""
    n = len(reports)
    with client.atomic():
        client.camera.position = tuple(float(v) for v in eye)
        client.camera.look_at = tuple(float(v) for v in target)
    want = np.asarray(client.camera.wxyz, dtype=np.float64)
    wait_for(lambda: any(math.dist(p, eye) < 1e-3 and abs(float(np.dot(q, want))) > 1 - 1e-6 for p, q in reports[n:]),
             f"the page to report the new view ({reports[n:][-3:]})", 60)
    labels.refresh(client.client_id)


def _draw_boxes(page: Any, canvas: dict[str, float], boxes: list[tuple[str, Any]], scale: float) -> None:
    """Outline the measured label boxes over the page (for the screenshot; they take no clicks)."""
    rects = [{"x": canvas["x"] + r[0] / scale, "y": canvas["y"] + r[1] / scale, "w": (r[2] - r[0]) / scale,
              "h": (r[3] - r[1]) / scale, "agent": t == AGENT_LABEL} for t, r in boxes]
    page.evaluate("rs => { document.querySelectorAll('.mn-test-box').forEach(e => e.remove());"
                  " for (const r of rs) { const d = document.createElement('div'); d.className = 'mn-test-box';"
                  " d.style.cssText = `position:fixed;left:${r.x}px;top:${r.y}px;width:${r.w}px;height:${r.h}px;`"
                  " + `outline:2px solid ${r.agent ? '#e8590c' : '#1c7ed6'};pointer-events:none;z-index:9999`;"
                  " document.body.appendChild(d); } }", rects)


@needs_browser
def test_the_agents_label_gives_way_to_the_robots_in_the_tab_and_never_overlaps(
        captured_console: ConsoleApp, browser: Any, tmp_path: Path) -> None:
    app, s = captured_console, captured_console.session
    wait_for(lambda: not s.run.active, "no mission running", 300)
    s.clear_route()
    page, client = open_tab(browser, app, WIDTH, HEIGHT, ready="Add goal")
    labels = app.views["objects"].labels
    reports: list[Any] = []  # the views the page reports: (position, wxyz)
    client.camera.on_update(lambda cam: reports.append((tuple(float(v) for v in cam.position),
                                                        np.asarray(cam.wxyz, dtype=np.float64))))
    try:
        # the page's 3D canvas is the picture the tab's camera reports: boxes in it are boxes in the page
        wait_for(lambda: (c := page.evaluate(CANVAS_JS)) is not None
                 and abs(c["width"] * c["dpr"] - client.camera.image_width) <= 2
                 and abs(c["height"] * c["dpr"] - client.camera.image_height) <= 2,
                 f"the canvas to match the tab's camera ({page.evaluate(CANVAS_JS)} vs "
                 f"{client.camera.image_width} x {client.camera.image_height})", 60)
        canvas = page.evaluate(CANVAS_JS)
        scale = client.camera.image_height / canvas["height"]

        # --- the agent plans a candidate: its label in the tab's declutter, not one label for every tab -------
        app.agent.call("plan_to_point", {"x": GOAL[0], "y": GOAL[1], "why": "a look behind the boxes"},
                       allow_actions=True)
        wait_for(lambda: [sp.text for sp in labels.spots("agent")] == [AGENT_LABEL], "the agent's label", 60)
        assert app.views["approval"].labelled
        assert AGENT_LABEL not in [f.text for f in fixed_labels(app.server)]
        spot = labels.spots("agent")[0]

        # --- a view where it would fall on the robot's label: the two anchors on one line of sight ----------
        robot = next(f for f in fixed_labels(app.server) if f.text.startswith("robot"))
        r, a = np.asarray(robot.position, dtype=np.float64), np.asarray(spot.position, dtype=np.float64)
        away = (r - a) / np.linalg.norm(r - a)
        _view(client, labels, reports, r + 2.5 * away, a)
        cam = client.camera
        u, v, _ = project(cam.wxyz, cam.position, float(cam.fov), cam.image_width, cam.image_height, robot.position)
        robot_box = label_rect(robot.text, u, v, px_per_css(cam.image_height), robot.anchor, robot.font_scale)
        alone = choose([spot], cam)  # without the robot's label: where the agent's would be drawn
        assert alone and overlaps(alone[0][1], robot_box, gap=0.0), (alone, robot_box)
        wait_for(lambda: not labels.shown(client.client_id, layer="agent") and not _overlapping(_boxes(app, client)),
                 f"the tab to leave the agent's label out ({_overlapping(_boxes(app, client))})", 60)
        boxes = _boxes(app, client)
        assert any(t == robot.text for t, _ in boxes) and AGENT_LABEL not in [t for t, _ in boxes]
        assert all(0 <= b[0] and b[2] <= cam.image_width and 0 <= b[1] and b[3] <= cam.image_height
                   for t, b in boxes if t == robot.text)  # the robot's label is in the page's picture
        _draw_boxes(page, canvas, boxes, scale)
        page.screenshot(path=str(tmp_path / "agent-label-behind-robot.png"))

        # --- from the side: the agent's label is shown again, clear of the robot's and of every other -------
        mid = (r + a) / 2
        side = np.cross(away, (0.0, 0.0, 1.0))
        _view(client, labels, reports, mid + 3.0 * side / np.linalg.norm(side) + (0.0, 0.0, 1.0), mid)
        wait_for(lambda: [t for t, _ in labels.shown(client.client_id, layer="agent")] == [AGENT_LABEL]
                 and not _overlapping(_boxes(app, client)),
                 f"the tab to show the agent's label ({labels.shown(client.client_id)}, "
                 f"{_overlapping(_boxes(app, client))})", 60)
        boxes = _boxes(app, client)
        (_, agent_box), = [(t, b) for t, b in boxes if t == AGENT_LABEL]
        assert 0 <= agent_box[0] and agent_box[2] <= canvas["width"] * scale  # inside the page's 3D view
        assert 0 <= agent_box[1] and agent_box[3] <= canvas["height"] * scale
        _draw_boxes(page, canvas, boxes, scale)
        page.screenshot(path=str(tmp_path / "agent-label-beside-robot.png"))
    finally:
        page.close()
        s.clear_route()


# --- a replay's viewpoint label -----------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def recorded_search(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A search recorded on the simulator in the paper's room: step mode, one approved move, then Stop."""
    from console.cli.search_cmd import HeadlessRig
    from console.link.world_file import paper_world
    from console.recording.recording import Recorder
    from console.session.search import SearchConfig

    tmp = tmp_path_factory.mktemp("search_rec")
    rig = HeadlessRig(paper_world(), tmp / "s", time_scale=8.0)
    rec = Recorder(rig.session, folder=tmp / "rec").start()
    try:
        rig.search.start(SearchConfig("robot dog", mode="step", max_captures=4, target_height=0.4))
        wait_for(lambda: rig.search.waiting_approval, "the first proposed move", 300)
        captures = rig.search.result.captures
        rig.search.approve()
        wait_for(lambda: rig.search.result.captures > captures or not rig.search.running, "the capture after it", 300)
        wait_for(lambda: rig.search.waiting_approval or not rig.search.running, "the second proposed move", 300)
        rig.search.stop()
        assert rig.search.wait(300)
    finally:
        rig.close()
        rec.close()
    assert rec.failed is None and rec.paths
    return rec.paths[0]


def _views_through(near: np.ndarray, far: np.ndarray) -> list[tuple[np.ndarray, np.ndarray]]:
    """Views ``(eye, look-at point)`` [m] from behind ``near``, looking at ``far`` past it: on the line through both
    and shifted off it by up to 0.3 m (sideways, up, down), 1.5 to 3 m behind ``near``; then views from the side."""
    back = (near - far) / np.linalg.norm(near - far)
    side = np.cross(back, (0.0, 0.0, 1.0))
    side = side / np.linalg.norm(side) if np.linalg.norm(side) > 1e-6 else np.array([1.0, 0.0, 0.0])
    out = []
    for d in (1.5, 2.2, 3.0):
        for dz in (0.0, 0.05, -0.05, 0.1, -0.1, 0.2, -0.2, 0.3, -0.3):
            for dx in (0.0, 0.05, -0.05, 0.1, -0.1, 0.2, -0.2):
                out.append((near + d * back + dx * side + (0.0, 0.0, dz), far))
    mid = (near + far) / 2
    for sign in (1.0, -1.0):
        for up in (0.5, 1.0, 2.0):
            out.append((mid + sign * 3.0 * side + (0.0, 0.0, up), mid))
    return out


@needs_browser
def test_the_replays_viewpoint_label_gives_way_to_the_robots_in_the_tab(recorded_search: Path, browser: Any,
                                                                        tmp_path: Path) -> None:
    from console.cli.replay_cmd import open_replay
    from console.recording import recording_schemas as rs
    from tests.console.views.test_object_labels import look

    app = open_replay(recorded_search, port=0)
    try:
        rec = app.recording
        last = max(t for t in rec.times(rs.SEARCH_STEP)
                   if any(s.get("kind") == "viewpoint" for s in rec.state_at(t).search[-1:]))
        app.seek_time(last)  # the replay at its last chosen viewpoint
        view, labels = app.views["search"], app.views["objects"].labels
        wait_for(lambda: view.drawn["viewpoints"] >= 1, "the replay's viewpoint", 60)
        (spot,) = labels.spots("search")
        assert spot.text.startswith(f"viewpoint {view.drawn['viewpoints']}: gain ")
        assert spot.text not in [f.text for f in fixed_labels(app.server)]  # not one label for every tab
        page, client = open_tab(browser, app, WIDTH, HEIGHT, ready="Play")
        reports: list[Any] = []
        client.camera.on_update(lambda cam: reports.append((tuple(float(v) for v in cam.position),
                                                            np.asarray(cam.wxyz, dtype=np.float64))))
        try:
            canvas = page.evaluate(CANVAS_JS)
            scale = client.camera.image_height / canvas["height"]
            robot = next(f for f in fixed_labels(app.server) if f.text.startswith("robot"))
            size = {"fov": float(client.camera.fov), "image_width": client.camera.image_width,
                    "image_height": client.camera.image_height}

            def robot_box(cam: Any) -> Any:
                u, v, _ = project(cam.wxyz, cam.position, float(cam.fov), cam.image_width, cam.image_height,
                                  robot.position)
                return label_rect(robot.text, u, v, px_per_css(cam.image_height), robot.anchor, robot.font_scale)

            def falls_on_robot(cam: Any) -> bool:
                alone = choose([spot], cam)  # without the robot's label: where the viewpoint's would be drawn
                return bool(alone) and overlaps(alone[0][1], robot_box(cam), gap=0.0)

            # a view where the viewpoint's label would fall on the robot's (chosen on a camera like the tab's)
            views = _views_through(np.asarray(robot.position, dtype=np.float64),
                                   np.asarray(spot.position, dtype=np.float64))
            on = next((v for v in views if falls_on_robot(look(*v, **size))), None)  # type: ignore[arg-type]
            assert on is not None, ("no view where the viewpoint's label falls on the robot's", robot, spot)
            _view(client, labels, reports, *on)
            assert falls_on_robot(client.camera)  # as the page reports its view
            wait_for(lambda: not labels.shown(client.client_id, layer="search")
                     and not _overlapping(_boxes(app, client)),
                     f"the tab to leave the viewpoint's label out ({_overlapping(_boxes(app, client))})", 60)
            boxes = _boxes(app, client)
            assert any(t == robot.text for t, _ in boxes) and spot.text not in [t for t, _ in boxes]
            _draw_boxes(page, canvas, boxes, scale)
            page.screenshot(path=str(tmp_path / "replay-viewpoint-label-on-robot.png"))

            # a view where it is clear: the tab shows it, and nothing overlaps
            fixed = fixed_labels(app.server)  # the side views first; kept beside every label that wins
            clear = next((v for v in reversed(views) if choose([spot], look(*v, **size), reserved_spots=fixed)), None)
            assert clear is not None
            _view(client, labels, reports, *clear)
            wait_for(lambda: [t for t, _ in labels.shown(client.client_id, layer="search")] == [spot.text]
                     and not _overlapping(_boxes(app, client)),
                     f"the tab to show the viewpoint's label ({labels.shown(client.client_id)}, "
                     f"{_overlapping(_boxes(app, client))})", 60)
            _draw_boxes(page, canvas, _boxes(app, client), scale)
            page.screenshot(path=str(tmp_path / "replay-viewpoint-label-clear.png"))
        finally:
            page.close()
    finally:
        app.stop()
