"""Undo and Redo never let an id be given twice: the scene put back keeps, per class, the highest id
number the map has given out (``Scene.last_ids``), the current map's included.

Driven through the session's own map update (:meth:`Session.spawn` of crafted captures, as the mapping
job spawns a capture): the two chairs of tests/pipeline/mapping/test_map_merge.py. World frame [m].
"""

from __future__ import annotations

from pathlib import Path

from console.session.session import Session
from tests.pipeline.mapping import test_map_merge as case


def _capture(name: str, cam: tuple[float, float, float], centre: tuple[float, float, float]):
    return case._capture(name, cam, case._chair("office_chair-1", centre, name, (250, 60, 420, 360)))


def test_undone_capture_keeps_its_id_numbers_taken(tmp_path: Path) -> None:
    s = Session(tmp_path / "s", start=(2.5, 0.7, 0.0), autosave=False)
    s.spawn(_capture("a", (1.2, -1.5, 0.35), (1.2, 2.55, 0.525)), origin="capture a")
    s.spawn(_capture("b", (1.8, -1.7, 0.35), (1.8, 2.3, 0.525)), origin="capture b")
    assert {o.id for o in s.scene.objects} == {"office_chair-1", "office_chair-2"}

    s.undo_edit()  # capture b and its office_chair-2 go
    assert [o.id for o in s.scene.objects] == ["office_chair-1"]
    assert s.scene.last_ids.get("office_chair") == 2, s.scene.last_ids

    # a capture mapping a second chair again: office_chair-2 was an undone capture's, it is not given again
    s.spawn(_capture("c", (1.8, -1.7, 0.35), (1.8, 2.3, 0.525)), origin="capture c")
    assert {o.id for o in s.scene.objects} == {"office_chair-1", "office_chair-3"}

    s.undo_edit()
    s.redo_edit()  # redo puts capture c's map back, numbers still kept
    assert {o.id for o in s.scene.objects} == {"office_chair-1", "office_chair-3"}
    assert s.scene.last_ids.get("office_chair") == 3, s.scene.last_ids
