"""Session.spawn: the merge runs outside the session lock; ``replaces`` drops what a file's previous version added."""

from __future__ import annotations

import threading
from pathlib import Path

import pytest

from pipeline.scene import Scene, SceneObject, Source


def test_spawn_merges_outside_the_session_lock(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    from console.session import session as session_module
    from console.session.session import Session

    s = Session(tmp_path / "session", start=(2.5, 0.7, 0.0))
    started, release, held = threading.Event(), threading.Event(), []
    real = session_module.merge_report

    def slow_merge(scene: Scene, new: Scene):  # type: ignore[no-untyped-def]
        held.append(s._lock._is_owned() if hasattr(s._lock, "_is_owned") else None)
        started.set()
        release.wait(10)
        return real(scene, new)

    monkeypatch.setattr(session_module, "merge_report", slow_merge)
    obj = SceneObject("box-1", "cardboard_box", (1.0, 5.0, 0.2), (0.4, 0.4, 0.4), source=Source(method="ground_truth"))
    t = threading.Thread(target=s.spawn, args=(Scene(objects=(obj,)),), kwargs={"origin": "file a.json"})
    t.start()
    assert started.wait(10)
    got = s._lock.acquire(timeout=2.0)  # another caller (Save as, a click) gets the lock meanwhile
    assert got
    s._lock.release()
    release.set()
    t.join(10)
    assert held == [False] or held == [None]
    assert [o.id for o in s.scene.objects] == ["box-1"]


def test_spawn_replaces_the_objects_of_a_previous_version_but_keeps_pinned_ones(tmp_path: Path) -> None:
    from console.session.session import Session

    s = Session(tmp_path / "session", start=(2.5, 0.7, 0.0))
    gt = Source(method="ground_truth")
    first = s.spawn(Scene(objects=(SceneObject("box-1", "cardboard_box", (1.0, 5.0, 0.2), (0.4, 0.4, 0.4), source=gt),
                                   SceneObject("box-2", "cardboard_box", (3.0, 5.0, 0.2), (0.4, 0.4, 0.4), source=gt))),
                    origin="file a.json")
    assert sorted(first.added) == ["box-1", "box-2"]
    s.move_object("box-2", (3.5, 5.0, 0.2))  # the operator pins box-2
    moved = Scene(objects=(SceneObject("box-1", "cardboard_box", (2.0, 5.0, 0.2), (0.4, 0.4, 0.4), source=gt),))
    s.spawn(moved, origin="file a.json", replaces=first.added)
    boxes = {o.id: o.position[0] for o in s.scene.objects}
    assert boxes == {"box-1": 2.0, "box-2": 3.5}  # box-1 moved, no ghost; the pinned box-2 kept
