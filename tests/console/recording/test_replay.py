"""``morphonavi replay``: a recorded short mission (simulated robot) shown again, read-only, at any time.

The recording is made by a real console run (:func:`test_recording.run_short_mission`); the replay
console's session and views must show the state the recording holds at the chosen time.
"""

from __future__ import annotations

import json
import math
import re
import shutil
from pathlib import Path
from typing import Any

import pytest
from mcap.reader import make_reader
from mcap.writer import Writer

from console.app import wait_until
from console.cli.errors import CliError
from console.cli.morphonavi import main
from console.recording.replay import Recording, ReplayError
from console.cli.replay_cmd import open_replay
from console.session.session import SessionError
from tests.console.recording.test_recording import read_all, run_short_mission


@pytest.fixture(scope="module")
def recorded(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Any]:
    path, _snaps, session = run_short_mission(tmp_path_factory.mktemp("replay"))
    return path, session


@pytest.fixture()
def replay(recorded: Any) -> Any:
    app = open_replay(recorded[0], port=0)
    try:
        yield app
    finally:
        app.stop()


def test_replay_restores_the_scene_at_a_captures_time(recorded: Any, replay: Any) -> None:
    path, live = recorded
    _, msgs = read_all(path)
    cap_time, cap = next((m[2], m[3]) for m in msgs if m[0] == "/morphonavi/capture")
    # the scene the capture made: the first map holding objects seen in it
    made_time, made = next((m[2], m[3]) for m in msgs if m[0] == "/morphonavi/scene" and m[2] >= cap_time
                           and any(o.get("source", {}).get("capture") == cap["id"] for o in m[3]["objects"]))
    session = replay.session

    replay.seek(0.0)  # before the capture: no photo, an empty map
    assert session.capture is None and session.scene.objects == ()

    replay.seek_time(made_time)
    assert session.capture is not None and session.capture.id == cap["id"]
    assert [o.id for o in session.scene.objects] == [o["id"] for o in made["objects"]]
    for obj, rec in zip(session.scene.objects, made["objects"]):
        assert obj.position == pytest.approx(tuple(rec["position"]), abs=1e-9)
    assert session.grid.counts()["occupied"] > 0  # the grid is rebuilt from the recorded map
    photo = session.capture.image
    assert photo.shape == (cap["intrinsics"]["height"], cap["intrinsics"]["width"], 3)
    # the views draw it: every object, the capture frustum, the robot twin
    assert wait_until(lambda: replay.views["objects"].drawn_ids() == sorted(o.id for o in session.scene.objects), 60)
    assert replay.views["capture"].has_frustum
    # the robot is where the recording had it then
    pose = [m for m in msgs if m[0] == "/robot/pose" and m[2] <= made_time][-1][3]
    assert session.robot is not None
    assert session.robot.pose.translation == pytest.approx((pose.pose.position.x, pose.pose.position.y,
                                                             pose.pose.position.z), abs=1e-9)

    replay.seek(replay.recording.duration)  # the end: the live session's last map, the mission done
    assert {o.id for o in session.scene.objects} == {o.id for o in live.scene.objects}
    assert session.run.state == "done"
    replay.seek(0.0)  # and back to the start: no photo, an empty map again
    assert session.capture is None and session.scene.objects == () and session.run.state == "idle"


def test_replay_plays_to_the_end(recorded: Any, replay: Any) -> None:
    path, _ = recorded
    _, msgs = read_all(path)
    replay.seek(0.0)
    replay.play(speed=30.0)
    assert wait_until(lambda: not replay.playing, 60), replay.time
    assert replay.time == pytest.approx(replay.recording.duration)
    t_pose, last_pose = [(m[2], m[3]) for m in msgs if m[0] == "/robot/pose"][-1]
    t_state, last_state = [(m[2], m[3]) for m in msgs if m[0] == "/robot/state"][-1]
    p = last_pose.pose.position  # the newer of the last pose and the last state (a change of mode)
    expected = (p.x, p.y, p.z) if t_pose >= t_state else tuple(last_state["translation"])
    robot = replay.session.robot
    assert robot is not None and math.dist(robot.pose.translation, expected) < 1e-9
    assert robot.mode == last_state["mode"]
    assert replay.session.route_snapshot().registered == ()  # the flown route was retired, as live
    assert replay.session.run.state == "done"


def test_replay_is_read_only(replay: Any) -> None:
    session = replay.session
    replay.seek(replay.recording.duration / 2)
    res = session.add_goal((2.5, 2.0, 0.0))
    assert not res.ok and "read-only" in res.message
    for call in (session.register, session.build_mission, session.clear_route, lambda: session.delete_object("x"),
                 lambda: session.save("snap"), session.undo_edit):
        with pytest.raises(SessionError, match="read-only"):
            call()


def test_bad_files_are_refused_with_exit_code_2(recorded: Any, tmp_path: Path, capsys: Any) -> None:
    path, _ = recorded
    truncated = tmp_path / "truncated.mcap"
    truncated.write_bytes(path.read_bytes()[: path.stat().st_size // 2])
    not_mcap = tmp_path / "photo.mcap"
    not_mcap.write_bytes(b"\xff\xd8\xff\xe0 not an mcap file")
    foreign = tmp_path / "foreign.mcap"
    with open(foreign, "wb") as f:
        w = Writer(f)
        w.start("", "test")
        sid = w.register_schema("x", "jsonschema", b"{}")
        cid = w.register_channel("/other", "json", sid)
        w.add_message(cid, log_time=1, data=json.dumps({"a": 1}).encode(), publish_time=1)
        w.finish()
    bad_scene = tmp_path / "bad_scene.mcap"
    with open(bad_scene, "wb") as f:
        w = Writer(f)
        w.start("", "test")
        for n, (topic, value) in enumerate((
                ("/morphonavi/session", {"workspace": {"min": [0, 0, 0], "max": [5, 8, 3], "resolution": 0.25},
                                         "margin": 0.35, "start": [2.5, 0.7, 0.0]}),
                ("/morphonavi/scene", {"version": 1, "objects": [{"id": "a", "label": "box", "position": [1, 2],
                                                                 "size": [1, 1, 1]}]}))):
            sid = w.register_schema(topic, "jsonschema", b"{}")
            cid = w.register_channel(topic, "json", sid)
            w.add_message(cid, log_time=n + 1, data=json.dumps(value).encode(), publish_time=n + 1)
        w.finish()
    cases = {tmp_path / "missing.mcap": "no such file", truncated: "truncated", not_mcap: r"not an MCAP file|is a photo, not a recording \(MCAP\)",  # the command names what it is
             foreign: "not a MorphoNavi recording", tmp_path: "not a file|is a folder",
             bad_scene: "/morphonavi/scene at 2 ns: malformed .*position"}
    for bad, why in cases.items():
        assert main(["replay", str(bad), "--port", "0"]) == 2
        err = capsys.readouterr().err
        assert err.startswith("morphonavi replay: error: ") and re.search(why, err) and "Traceback" not in err, err
        with pytest.raises(ReplayError, match=why):
            Recording(bad)
        with pytest.raises(CliError):
            open_replay(bad, port=0)
    # a copy of the good file opens
    good = tmp_path / "good.mcap"
    shutil.copy(path, good)
    assert Recording(good).count("/morphonavi/capture") == 1
    with open(good, "rb") as f:
        assert make_reader(f).get_summary() is not None


CHROMIUM = Path("/usr/bin/chromium")
REPO = Path(__file__).resolve().parents[3]
BROWSER_ARGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
                "--disable-background-networking", "--disable-component-update", "--disable-sync",
                "--use-angle=swiftshader", "--enable-unsafe-swiftshader"]


def _browser_missing() -> str | None:
    if not CHROMIUM.exists():
        return "Debian's chromium is not installed (/usr/bin/chromium); run `make browser`"
    try:
        import playwright.sync_api  # noqa: F401
    except ImportError:
        return "the playwright package is not installed (pip install playwright)"
    return None


@pytest.mark.skipif(_browser_missing() is not None, reason=_browser_missing() or "")
def _click_until(page: Any, name: str, done: Any, what: str, timeout: float = 120.0) -> None:
    """Click the button ``name`` until ``done`` (the replay's state) holds: under load a click can land while
    the panel is re-drawn (the button detached) and do nothing, so it is found and clicked again."""
    import time

    from playwright.sync_api import Error

    deadline = time.monotonic() + timeout
    while not done():
        left = deadline - time.monotonic()
        assert left > 0, f"timed out clicking {name!r} for {what}"
        try:
            page.get_by_role("button", name=name, exact=True).first.click(timeout=max(1000, min(30_000, left * 1000)))
        except Error:  # detached or covered while re-drawn: find it again
            pass
        wait_until(done, min(10.0, max(0.1, deadline - time.monotonic())), 0.05)


def test_replay_in_the_browser_plays_and_pauses(recorded: Any, replay: Any, tmp_path: Path) -> None:
    """The page has the time slider and Play / Pause; a screenshot mid-mission goes to docs/replay.png
    when MORPHONAVI_UPDATE_SCREENSHOT=1."""
    import os
    import tempfile
    import time

    from playwright.sync_api import sync_playwright

    path, _ = recorded
    _, msgs = read_all(path)
    running = [m[2] for m in msgs if m[0] == "/mission/progress" and m[3]["state"] == "running"]
    done = [m[2] for m in msgs if m[0] == "/mission/progress" and m[3]["state"] == "done"]
    with sync_playwright() as pw:
        ctx = pw.chromium.launch_persistent_context(
            tempfile.mkdtemp(prefix="chromium-", dir=tmp_path), executable_path=str(CHROMIUM), headless=True,
            args=BROWSER_ARGS, viewport={"width": 1440, "height": 900})
        try:
            page = ctx.new_page()
            page.goto(replay.url)
            play = page.get_by_role("button", name="Play")
            play.wait_for(timeout=30_000)
            assert wait_until(lambda: len(replay.server.get_clients()) == 1, 60), "the page did not connect"
            page.get_by_text("Time [s]").first.wait_for(timeout=60_000)
            replay.seek(0.0)
            _click_until(page, "Play", lambda: replay.playing and replay.time > 0.0, "Play to start the replay")
            _click_until(page, "Pause", lambda: not replay.playing, "Pause to stop the replay")
            # mid-mission: the robot on its way, the mission path, the capture's photo
            replay.seek_time((running[0] + done[-1]) // 2)
            assert replay.session.run.state == "running" and replay.session.mission is not None
            page.get_by_text("s of").first.wait_for(timeout=60_000)
            page.add_style_tag(content=".mantine-Notifications-root { display: none !important; }")
            time.sleep(1.5)  # let the renderer settle
            shot = tmp_path / "replay.png"
            page.screenshot(path=str(shot))
            assert shot.stat().st_size > 10_000
            if os.environ.get("MORPHONAVI_UPDATE_SCREENSHOT") == "1":
                shutil.copy(shot, REPO / "docs" / "replay.png")
        finally:
            ctx.close()


def test_a_cut_recording_is_salvaged_on_request(recorded: Any, tmp_path: Path, capsys: Any) -> None:
    path, _ = recorded
    full = Recording(path)
    cut = tmp_path / "cut.mcap"
    data = path.read_bytes()
    cut.write_bytes(data[: int(len(data) * 0.8)])
    with pytest.raises(ReplayError, match="--salvage"):
        Recording(cut)
    part = Recording(cut, salvage=True)
    assert part.salvaged and not full.salvaged
    assert part.start == full.start and part.end <= full.end
    assert 0 < part.count("/robot/pose") <= full.count("/robot/pose")
    # what was salvaged is what the full file says at those times
    for t in (part.start, (part.start + part.end) // 2, part.end):
        a, b = part.state_at(t), full.state_at(t)
        assert [o.id for o in a.scene.objects] == [o.id for o in b.scene.objects]
        assert (a.robot is None) == (b.robot is None)
        if a.robot is not None:
            assert a.robot.pose == b.robot.pose
    app = open_replay(cut, port=0, salvage=True)
    try:
        app.seek(app.recording.duration)
        assert app.session.scene.objects == part.state_at(part.end).scene.objects
    finally:
        app.stop()
    tiny = tmp_path / "tiny.mcap"
    tiny.write_bytes(data[:40])
    assert main(["replay", str(tiny), "--salvage", "--port", "0"]) == 2
    assert "nothing to salvage" in capsys.readouterr().err


def test_a_killed_console_leaves_a_log_that_salvage_reads(tmp_path: Path) -> None:
    """The recorder ends its chunk every FLUSH_S: a copy of the file taken while it runs (what a kill leaves)
    already holds the map."""
    from console.recording.recording import FLUSH_S, Recorder
    from console.session.session import Session
    from pipeline.scene import Scene, SceneObject

    session = Session(tmp_path / "session", autosave=False)
    rec = Recorder(session, folder=tmp_path / "rec").start()
    try:
        session.spawn(Scene(objects=(SceneObject("a", "office_chair", (2.0, 3.0, 0.5), (0.6, 1.0, 0.6)),)), "test")
        copy = tmp_path / "killed.mcap"

        def salvaged_map() -> bool:
            if not rec.paths:
                return False
            shutil.copy(rec.paths[0], copy)
            try:
                return [o.id for o in Recording(copy, salvage=True).state_at(2**62).scene.objects] == ["a"]
            except ReplayError:
                return False

        assert wait_until(salvaged_map, 30 * FLUSH_S), "the map never reached the file"
    finally:
        rec.close()
