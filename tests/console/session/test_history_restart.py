"""Undo and Redo after a console restart, for every way the console starts: the default session folder,
``--session DIR``, ``--world FILE`` and a map spawned from a watched scene file.

The session reads ``history.json`` back in :meth:`~console.session.session.Session.restore_last`, which the
console calls at start-up before its panels exist. The panels' Undo and Redo buttons must show the restored
steps at once (``Undo move desk-1``, enabled): before the fix the Undo button was drawn as a bare, disabled
"Undo" until the next map change, although the session could undo (the restore's events went out before
the panel subscribed). Undo then puts back the map as it was before the last step and Redo the step itself.

No browser: the server-side GUI handles of the running console (the browser test is
``tests/console/e2e/test_restart_undo_e2e.py``).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest

from console.app import ConsoleApp, ConsoleConfig, wait_until
from console.cli.cli_args import DEFAULT_SESSION
from console.session.history_file import HISTORY_FILE
from console.session.session import Session
from pipeline.scene import Scene, SceneObject, scene_to_dict, write_text_atomic

EXAMPLES = Path(__file__).resolve().parents[3] / "examples" / "worlds"
CRATE = SceneObject("crate-a", "cardboard_box", (1.0, 3.0, 0.3), (0.5, 0.5, 0.6))


def _start(session_dir: Path, scene_dir: Path, world: Any = None) -> ConsoleApp:
    """The console as ``morphonavi console`` starts it (not ``--fresh``): the simulated robot, no recording."""
    return ConsoleApp(ConsoleConfig(robot="sim", session_dir=session_dir, scene_dir=scene_dir, port=0,
                                    record=False, world=world)).start()


def _buttons(app: ConsoleApp) -> tuple[tuple[str, bool], tuple[str, bool]]:
    """(label, disabled) of the objects panel's Undo and of Redo, as the page draws them."""
    undo, redo = app.views["objects"]._undo, app.views["redo"].button
    return (undo.label, bool(undo.disabled)), (redo.label, bool(redo.disabled))


def _positions(scene: Scene) -> dict[str, tuple[float, ...]]:
    return {o.id: tuple(o.position) for o in scene.objects}


def _same(a: dict[str, tuple[float, ...]], b: dict[str, tuple[float, ...]]) -> bool:
    """The same objects at the same places within 1 mm (session.json keeps 0.1 mm)."""
    return a.keys() == b.keys() and all(max(abs(x - y) for x, y in zip(a[k], b[k])) < 1e-3 for k in a)


def _capture_then_move(app: ConsoleApp) -> str:
    """Capture & map, then move the first mapped object 0.3 m along x; returns the object's id."""
    s = app.session
    assert s is not None and wait_until(lambda: s.robot is not None, 120, 0.05), "no robot state"
    assert app.mapping is not None and app.mapping.run(), s.job
    assert s.scene.objects, "the capture mapped nothing"
    obj = s.scene.objects[0]
    s.move_object(obj.id, (obj.position[0] + 0.3, obj.position[1], obj.position[2]))
    return obj.id


def _spawn_then_move(app: ConsoleApp) -> str:
    s = app.session
    assert s is not None
    s.spawn(Scene(objects=(CRATE,)), origin="file room.json")
    s.move_object(CRATE.id, (1.5, 3.0, 0.3))
    return CRATE.id


def _scene_file_then_move(app: ConsoleApp) -> str:
    """A scene file dropped in the watched folder is spawned; then its object is moved."""
    s = app.session
    assert s is not None and app.watcher is not None
    write_text_atomic(app.watcher.folder / "room.json", __import__("json").dumps(scene_to_dict(Scene(objects=(CRATE,)))))
    assert wait_until(lambda: any(o.id == CRATE.id for o in s.scene.objects), 120, 0.05), "the scene file was not spawned"
    s.move_object(CRATE.id, (1.5, 3.0, 0.3))
    return CRATE.id


WAYS = {
    "default-session-folder": (None, _capture_then_move),
    "session-dir": ("s", _spawn_then_move),
    "world": ("s", _capture_then_move),
    "scene-file": ("s", _scene_file_then_move),
}


@pytest.mark.parametrize("way", list(WAYS))
def test_undo_and_redo_after_a_restart_show_their_step_and_put_the_map_back(
        way: str, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    folder, edit = WAYS[way]
    monkeypatch.chdir(tmp_path)  # the default session folder is relative: .morphonavi/session here
    session_dir = DEFAULT_SESSION if folder is None else tmp_path / folder
    world = EXAMPLES / "gap_line.world.json" if way == "world" else None
    scenes = tmp_path / "scenes"

    app = _start(session_dir, scenes, world)
    try:
        moved = edit(app)
        s = app.session
        assert s is not None and s.undo_label == f"move {moved}"
        before_move = s.undo_label
        after = _positions(s.scene)
        s.undo_edit()  # and back: the history holds a redo step too, until the next edit
        before = _positions(s.scene)
        s.redo_edit()
        assert _same(_positions(s.scene), after) and s.undo_label == before_move and s.redo_label is None
        steps = s.undo_label
    finally:
        app.stop()
    assert (Path(session_dir) / HISTORY_FILE).exists()

    again = _start(session_dir, scenes, world)  # the same folder: the session and its history come back
    try:
        s2 = again.session
        assert s2 is not None and s2.restore_problems == (), s2.restore_problems
        assert _same(_positions(s2.scene), after) and s2.undo_label == steps
        assert _buttons(again) == ((f"Undo {steps}", False), ("Redo", True))  # bare "Undo", disabled, before the fix
        assert s2.undo_edit() == f"undone: {steps}"
        assert _same(_positions(s2.scene), before) and not _same(before, after)  # the map as it was before the last step
        assert _buttons(again)[1] == (f"Redo {steps}", False)
        assert s2.redo_edit() == f"redone: {steps}"
        assert _same(_positions(s2.scene), after) and _buttons(again)[0] == (f"Undo {steps}", False)
    finally:
        again.stop()


def test_a_session_is_restored_by_restore_last_which_the_console_calls_unless_fresh(tmp_path: Path) -> None:
    """A new :class:`Session` on a folder starts empty; the saved map and its history come back with
    ``restore_last`` (what ``morphonavi console`` does at start, and ``--fresh`` skips)."""
    first = Session(tmp_path / "s", empty_is_unseen=True)
    first.spawn(Scene(objects=(CRATE,)), origin="file room.json")
    first.move_object(CRATE.id, (1.5, 3.0, 0.3))
    again = Session(tmp_path / "s", empty_is_unseen=True)
    assert again.scene.objects == () and again.undo_label is None  # not restored yet
    assert again.restore_last() is not None
    assert again.undo_label == "move crate-a" and again.scene.object(CRATE.id).position == pytest.approx((1.5, 3.0, 0.3))
    assert again.undo_edit() == "undone: move crate-a"
    assert again.scene.object(CRATE.id).position == pytest.approx(CRATE.position)
    assert again.undo_label == "spawn from file room.json" and again.redo_label == "move crate-a"
