"""Pin / Unpin: the objects panel's one button says the action the selected object's state allows; Unpin
lets captures move the object again; both are undone and redone like a move."""

from __future__ import annotations

from pathlib import Path

import pytest
import viser

from console.session.pin_edit import UNPINNED_METHOD
from console.session.session import Session, SessionError
from pipeline.scene import Scene, SceneObject, Source

BOX = SceneObject("box-1", "cardboard_box", (2.5, 4.0, 0.3), (0.5, 0.6, 0.5))  # a scene file's object: pinned


def _seen(capture: str) -> Scene:
    """The box as a capture sees it, 0.2 m off where the map has it."""
    return Scene(objects=(SceneObject(f"cardboard_box-{capture}", "cardboard_box", (2.7, 4.1, 0.3), (0.5, 0.6, 0.5),
                                      source=Source(capture=capture, method="fused")),))


def _session(tmp_path: Path) -> Session:
    s = Session(tmp_path / "s", autosave=False)
    s.spawn(Scene(objects=(BOX,)), origin="file room.json")
    return s


def test_unpin_lets_a_capture_move_the_object_and_undo_pins_it_back(tmp_path: Path) -> None:
    s = _session(tmp_path)
    assert s.scene.object("box-1").is_pinned
    s.spawn(_seen("c1"), origin="capture c1")
    assert s.scene.object("box-1").position == BOX.position  # pinned: the capture does not move it
    s.set_pinned("box-1", False)
    box = s.scene.object("box-1")
    assert not box.is_pinned and box.source.method == UNPINNED_METHOD and box.position == BOX.position
    assert s.undo_label == "unpin box-1"
    s.undo_edit()
    assert s.scene.object("box-1").is_pinned and s.redo_label == "unpin box-1"
    s.redo_edit()
    assert not s.scene.object("box-1").is_pinned
    report = s.spawn(_seen("c2"), origin="capture c2")
    assert report.updated == ("box-1",) and s.scene.object("box-1").position != BOX.position  # corrected now
    s.set_pinned("box-1", True)
    assert s.scene.object("box-1").is_pinned and s.scene.object("box-1").pinned


def test_pin_and_unpin_refuse_what_they_cannot_do(tmp_path: Path) -> None:
    s = _session(tmp_path)
    with pytest.raises(SessionError, match="^box-1 is pinned already: nothing to pin$"):
        s.set_pinned("box-1", True)
    with pytest.raises(SessionError, match="no object 'box-9' in the map"):
        s.set_pinned("box-9", False)
    s.set_pinned("box-1", False)
    with pytest.raises(SessionError, match="^box-1 is not pinned already: nothing to unpin$"):
        s.set_pinned("box-1", False)
    assert s.undo_label == "unpin box-1"  # the refusals left no step behind


def test_the_pin_button_follows_the_selected_object_and_undo(tmp_path: Path) -> None:
    from console.views.objects_view import ObjectsView
    from console.views.redo_view import RedoView

    told: list[str] = []

    class Tab:
        def add_notification(self, title: str, body: str, **_kw: object) -> None:
            told.append(f"{title}: {body}")

    class Click:
        client = Tab()

    server = viser.ViserServer(host="127.0.0.1", port=0, verbose=False)
    try:
        s = _session(tmp_path)
        view = ObjectsView(server, s)
        keys = RedoView(server, s, view._undo)
        s.select("box-1")
        assert view._pin.label == "Unpin" and "captures" in view._pin.hint
        view._on_pin(Click())
        assert not s.scene.object("box-1").is_pinned and view._pin.label == "Pin"
        assert told[-1].startswith("Unpinned box-1: captures may correct its position again")
        assert view._undo.label == "Undo unpin box-1"
        keys.undo(Click.client)
        assert s.scene.object("box-1").is_pinned and view._pin.label == "Unpin"
        view._on_pin(Click())
        view._on_pin(Click())  # and pinned again with the same button
        assert s.scene.object("box-1").is_pinned and view._pin.label == "Unpin"
        assert told[-1].startswith("Pinned box-1: captures never move it")
    finally:
        server.stop()
