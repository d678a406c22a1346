"""Sessions (issue 8, items 10 and 11): one console per session folder, every restored value
checked like the scene, the valid parts of a partly bad session restored, autosave failures told
once, and a corrupt session in a read-only folder explained instead of a rename error."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from contextlib import contextmanager
from pathlib import Path
from typing import Iterator

import pytest

from console.cli.morphonavi import main as cli_main
from console.session.session import NOTICE, Session, SessionError
from console.session.session_lock import LOCK_FILE, SessionLock
from pipeline.scene import Scene, SceneObject

START = (2.5, 0.7, 0.0)
ROOT = Path(__file__).resolve().parents[3]


def _boxes() -> Scene:
    return Scene(objects=tuple(SceneObject(f"box-{n}", "cardboard_box", (0.25 + 0.5 * n, 4.0, 0.6), (0.5, 1.2, 0.5))
                               for n in range(10)))


def _saved_session(folder: Path) -> dict:
    """A session with the box line, a registered segment over it and its mission, saved; its JSON."""
    s = Session(folder, start=START)
    s.set_goal_mode("altitude", 2.0)
    s.set_goal_mode("ground")
    s.spawn(_boxes())
    assert s.add_goal((2.5, 6.0, 0.0)).ok
    s.register()
    s.build_mission()
    return json.loads((folder / "session.json").read_text())


def _write(folder: Path, data: dict) -> None:
    (folder / "session.json").write_text(json.dumps(data))  # json writes NaN as the bare word NaN


@contextmanager
def read_only(folder: Path) -> Iterator[None]:
    """Make ``folder`` read-only for this process (chmod; as root, the immutable attribute)."""
    if os.geteuid() != 0:
        os.chmod(folder, 0o555)
        undo = ["chmod", "755", str(folder)]
    else:
        if shutil.which("chattr") is None or subprocess.run(["chattr", "+i", str(folder)], capture_output=True).returncode:
            pytest.skip("cannot make a folder read-only here (root without chattr +i)")
        undo = ["chattr", "-i", str(folder)]
    try:
        try:
            (folder / ".probe").write_text("x")
        except OSError:
            pass
        else:
            (folder / ".probe").unlink()
            pytest.skip("the folder stayed writable")
        yield
    finally:
        subprocess.run(undo, check=True)


# --- the session lock (item 10) ------------------------------------------------------------------


def test_a_second_lock_on_the_folder_is_refused_naming_the_holder(tmp_path: Path) -> None:
    first = SessionLock(tmp_path / "s").acquire()
    with pytest.raises(SessionError, match=rf"in use by another console \(PID {os.getpid()}\).*--session"):
        SessionLock(tmp_path / "s").acquire()
    assert (tmp_path / "s" / LOCK_FILE).read_text().strip() == str(os.getpid())
    first.release()
    with SessionLock(tmp_path / "s") as again:
        assert again.held and again.previous_pid is None


def _holder(folder: Path) -> subprocess.Popen:
    """Another process holding the lock until its stdin closes."""
    code = ("import sys; from console.session.session_lock import SessionLock; SessionLock(sys.argv[1]).acquire(); "
            "print('held', flush=True); sys.stdin.read()")
    proc = subprocess.Popen([sys.executable, "-c", code, str(folder)], cwd=ROOT, stdin=subprocess.PIPE,
                            stdout=subprocess.PIPE, text=True)
    assert proc.stdout is not None and proc.stdout.readline().strip() == "held"
    return proc


def test_a_lock_held_by_another_process_is_refused_and_taken_over_once_it_is_gone(tmp_path: Path) -> None:
    proc = _holder(tmp_path / "s")
    try:
        with pytest.raises(SessionError, match=rf"PID {proc.pid}\)"):
            SessionLock(tmp_path / "s").acquire()
    finally:
        assert proc.stdin is not None
        proc.stdin.close()
        proc.wait(60)
    lock = SessionLock(tmp_path / "s").acquire()  # the holder died without releasing: stale, taken over
    assert lock.held and lock.previous_pid == proc.pid
    assert (tmp_path / "s" / LOCK_FILE).read_text().strip() == str(os.getpid())
    lock.release()


def test_a_stale_lock_file_of_a_dead_pid_is_taken_over(tmp_path: Path) -> None:
    dead = subprocess.Popen([sys.executable, "-c", "pass"])
    dead.wait(60)
    (tmp_path / "s").mkdir()
    (tmp_path / "s" / LOCK_FILE).write_text(f"{dead.pid}\n")
    lock = SessionLock(tmp_path / "s").acquire()
    assert lock.held and lock.previous_pid == dead.pid
    lock.release()


def test_a_second_console_on_the_same_session_folder_exits_naming_the_pid(tmp_path: Path, capsys) -> None:
    proc = _holder(tmp_path / "s")
    try:
        rc = cli_main(["console", "--session", str(tmp_path / "s"), "--scene", str(tmp_path / "scenes"), "--port", "0"])
    finally:
        assert proc.stdin is not None
        proc.stdin.close()
        proc.wait(60)
    err = capsys.readouterr().err
    assert rc == 2 and f"in use by another console (PID {proc.pid})" in err and "Traceback" not in err
    assert not (tmp_path / "s" / "session.json").exists()  # nothing was written over the other console's state


# --- restoring (item 11) --------------------------------------------------------------------------


def test_a_nan_route_start_is_refused_naming_the_field_and_the_scene_restored(tmp_path: Path) -> None:
    folder = tmp_path / "s"
    data = _saved_session(folder)
    data["route"]["start"] = [2.5, 0.7, float("nan")]
    _write(folder, data)
    b = Session(folder, start=START)
    notes = b.restore_last()
    assert notes is not None and any("route.start[2]: must be finite" in n for n in notes)
    assert len(b.scene.objects) == 10 and b.grid.counts()["occupied"] > 0  # the intact scene is back
    assert b.route_snapshot().registered == () and b.mission is None
    assert b.settings.altitude == 2.0
    problems = " ".join(b.restore_problems)
    assert "route.start[2]: must be finite" in problems and "kept as session.json.unreadable-" in problems
    kept = list(folder.glob("session.json.unreadable-*"))
    assert len(kept) == 1 and "NaN" in kept[0].read_text()
    assert "NaN" not in (folder / "session.json").read_text()  # not written back
    text, warn = b.status_text()
    assert warn and "route.start[2]" in text


def test_a_bad_mission_alone_keeps_the_scene_and_route(tmp_path: Path) -> None:
    folder = tmp_path / "s"
    data = _saved_session(folder)
    data["mission"]["segments"][0]["waypoints"][0] = ["x", 0, 0]
    _write(folder, data)
    b = Session(folder, start=START)
    b.restore_last()
    assert len(b.scene.objects) == 10 and len(b.route_snapshot().registered) == 1
    assert b.mission is None
    assert any("mission.segments[0].waypoints[0]" in p for p in b.restore_problems)


@pytest.mark.parametrize("edit, field", [
    (lambda d: d["settings"].__setitem__("altitude", float("inf")), "settings.altitude"),
    (lambda d: d["route"]["registered"][0].__setitem__(0, [1, -2, 0]), "route.registered[0][0]"),
    (lambda d: d["route"].__setitem__("candidate_goal", [1.0, float("nan"), 0.0]), "route.candidate_goal"),
    (lambda d: d.__setitem__("last_capture", {"id": "c", "camera_pose": {"translation": [0, float("nan"), 0]}}),
     "last_capture.camera_pose.translation[1]"),
])
def test_each_bad_part_is_named_and_dropped_alone(tmp_path: Path, edit, field: str) -> None:
    folder = tmp_path / "s"
    data = _saved_session(folder)
    edit(data)
    _write(folder, data)
    b = Session(folder, start=START)
    b.restore_last()
    assert len(b.scene.objects) == 10
    assert any(p.startswith(field) for p in b.restore_problems), b.restore_problems


def test_an_implausible_saved_scene_is_refused_whole_and_kept_aside(tmp_path: Path) -> None:
    folder = tmp_path / "s"
    data = _saved_session(folder)
    data["scene"]["objects"][3]["size"] = [1e9, 1e9, 1e9]
    _write(folder, data)
    b = Session(folder, start=START)
    assert b.restore_last() is None
    assert b.scene.objects == () and b.mission is None
    assert "scene.objects[3].size[0]: 1e+09 m is implausible" in b.restore_problems[0]
    assert not (folder / "session.json").exists() and len(list(folder.glob("session.json.unreadable-*"))) == 1
    with pytest.raises(SessionError, match=r"scene\.objects\[3\]\.size\[0\]"):  # a typed Load says the same
        (folder / "bad.json").write_text(json.dumps(data))
        b.load("bad")


def test_a_corrupt_session_in_a_read_only_folder_says_what_to_do(tmp_path: Path, capsys) -> None:
    folder = tmp_path / "s"
    folder.mkdir()
    (folder / "session.json").write_text('{"kind": "morphonavi-session", "version": 1, "scene": {"objects": 3}}')
    with read_only(folder):
        s = Session(folder, start=START)
        with pytest.raises(SessionError, match=r"corrupt .*--fresh.*--session DIR"):
            s.restore_last()
        rc = cli_main(["console", "--session", str(folder), "--scene", str(tmp_path / "scenes"), "--port", "0"])
        err = capsys.readouterr().err
        assert rc == 2 and "is corrupt" in err and "--fresh" in err and "Traceback" not in err
        assert (folder / "session.json").read_text().endswith('{"objects": 3}}')  # left as it was
        assert sorted(p.name for p in folder.iterdir()) == ["session.json"]


def test_autosave_failures_are_told_once_and_shown_until_saving_works_again(tmp_path: Path) -> None:
    s = Session(tmp_path / "s", start=START)
    told: list = []
    s.subscribe(lambda topic, payload: told.append(payload) if topic == NOTICE else None)
    assert s.save_error is None and not s.status_text()[1]
    with read_only(s.folder):
        s.spawn(_boxes())
        s.delete_object("box-1")
        s.delete_object("box-2")
        assert [n.title for n in told] == ["Changes are not being saved"] and told[0].level == "error"
        assert s.save_error is not None
        text, warn = s.status_text()
        assert warn and "NOT being saved" in text
    s.delete_object("box-3")
    assert [n.title for n in told] == ["Changes are not being saved", "Saving again"]
    assert s.save_error is None and not s.status_text()[1]
    assert len(json.loads((s.folder / "session.json").read_text())["scene"]["objects"]) == 7


def _paths(d, p=()):
    yield p
    if isinstance(d, dict):
        for k, v in d.items():
            yield from _paths(v, p + (k,))
    elif isinstance(d, list):
        for i, v in enumerate(d[:2]):
            yield from _paths(v, p + (i,))


def test_any_field_of_a_saved_session_replaced_by_nonsense_is_refused_or_dropped_never_raised(tmp_path: Path) -> None:
    """Every field (and sub-field) of a full session file swapped for a wrong type or a huge number:
    loading it either refuses with SessionError or restores with notes; never a raw exception."""
    from tests.console.session.test_session_safety import _capture

    folder = tmp_path / "s"
    _saved_session(folder)
    s = Session(folder, start=START)
    s.restore_last()
    s.set_capture(_capture("c1"))
    base = json.loads((folder / "session.json").read_text())
    cases = 0
    for path in list(_paths(base))[1:]:
        for bad in ("x", None, 1e308):
            data = json.loads(json.dumps(base))
            node = data
            for key in path[:-1]:
                node = node[key]
            node[path[-1]] = bad
            (folder / "fuzz.json").write_text(json.dumps(data))
            cases += 1
            try:
                s.load("fuzz")
            except SessionError:
                pass
    assert cases > 200


def test_the_console_restores_a_partly_bad_session_and_refuses_an_implausible_dropped_file(tmp_path: Path) -> None:
    """Through the real console wiring: the intact scene comes back with the reason kept for the page,
    and a 1e9 m object dropped in the watched folder is refused with a notice, changing nothing."""
    from console.app import ConsoleApp, ConsoleConfig, wait_until

    folder = tmp_path / "s"
    data = _saved_session(folder)
    data["route"]["start"] = [2.5, 0.7, float("nan")]
    _write(folder, data)
    app = ConsoleApp(ConsoleConfig(session_dir=folder, scene_dir=tmp_path / "scenes", port=0)).start()
    try:
        s = app.session
        assert s is not None and len(s.scene.objects) == 10
        text, warn = s.status_text()
        assert warn and "route.start[2]: must be finite" in text
        told: list = []
        s.subscribe(lambda topic, payload: told.append(payload) if topic == NOTICE else None)
        on_disk = (folder / "session.json").read_bytes()
        counts = s.grid.counts()
        (tmp_path / "scenes" / "huge.json").write_text(json.dumps({"version": 1, "objects": [
            {"id": "huge", "label": "box", "position": [2.5, 4.0, 0.5], "size": [1e9, 1e9, 1e9]}]}))
        assert wait_until(lambda: any(n.title == "Scene file ignored" for n in told), 60.0)
        body = next(n.body for n in told if n.title == "Scene file ignored")
        assert "huge.json" in body and "objects[0].size[0]: 1e+09 m is implausible" in body
        assert len(s.scene.objects) == 10 and s.grid.counts() == counts
        assert (folder / "session.json").read_bytes() == on_disk
    finally:
        app.stop()
