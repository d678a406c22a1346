"""``history.json`` (the undo and redo history beside the session) against its schema: field-named reasons,
a bad file set aside (``history.json.unreadable-<time>``) and never a traceback, the good steps kept, and the
published schema matching what the console writes."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from console.session.history_file import HISTORY_FILE, read_history_file
from console.session.history_schema import HISTORY_SCHEMA, history_errors
from console.session.session import Session
from pipeline.scene import Scene, SceneObject

START = (2.5, 0.7, 0.0)


def _box(oid: str, x: float, y: float) -> SceneObject:
    return SceneObject(oid, "cardboard_box", (x, y, 0.3), (0.5, 0.5, 0.6))


@pytest.fixture()
def written(tmp_path: Path) -> Session:
    """A session with three undo steps and one redo step written to history.json."""
    s = Session(tmp_path / "s", start=START)
    s.spawn(Scene(objects=(_box("a", 1.0, 2.0), _box("b", 3.0, 2.0))), origin="file room.json")
    s.move_object("a", (1.5, 2.5, 0.3))
    s.delete_object("b")
    s.undo_edit()
    return s


def _aside(folder: Path) -> list[Path]:
    return sorted(folder.glob(f"{HISTORY_FILE}.unreadable-*"))


def test_what_the_console_writes_is_valid_against_the_published_schema(written: Session) -> None:
    data = json.loads((written.folder / HISTORY_FILE).read_text())
    assert history_errors(data) == []
    assert [e["label"] for e in data["undo"]] == ["spawn from file room.json", "move a"]
    assert [e["label"] for e in data["redo"]] == ["delete b"]
    published = Path(__file__).resolve().parents[3] / "docs" / "schemas" / "history.schema.json"
    assert json.loads(published.read_text()) == HISTORY_SCHEMA  # python -m console.schemas wrote it


@pytest.mark.parametrize("change, said", [
    (lambda d: d.update(undo={"label": "x"}), "is not a valid undo history: undo: must be an array"),
    (lambda d: d.update(version=7), "is not a MorphoNavi undo history (version 1)"),
    (lambda d: d.update(known_spaces=[1]), "is not a valid undo history: known_spaces: must be an object"),
    (lambda d: d.pop("redo"), "is not a valid undo history: redo: is required"),
])
def test_a_file_wrong_in_its_outline_is_set_aside_with_the_field_named(written: Session, change, said: str) -> None:
    path = written.folder / HISTORY_FILE
    data = json.loads(path.read_text())
    change(data)
    path.write_text(json.dumps(data))
    undo, redo, problems = read_history_file(path, written.workspace)
    assert undo == [] and redo == []
    assert len(problems) == 1 and said in problems[0], problems
    kept = _aside(written.folder)
    assert not path.exists() and len(kept) == 1 and f"kept aside as {kept[0].name}" in problems[0]
    assert json.loads(kept[0].read_text()) == data  # nothing lost: the operator can look at it


def test_a_bad_step_drops_it_and_the_older_ones_keeps_the_rest_and_a_copy(written: Session) -> None:
    path = written.folder / HISTORY_FILE
    data = json.loads(path.read_text())
    data["undo"][0]["label"] = ""
    data["undo"][1]["state"]["scene"]["objects"][0]["size"][1] = -1
    data["redo"][0]["state"]["workspace"]["resolution"] = 0
    path.write_text(json.dumps(data))
    undo, redo, problems = read_history_file(path, written.workspace)
    assert undo == [] and redo == []
    assert any("history.json: undo[0].label: must not be empty" in p for p in problems), problems
    assert any("history.json: undo[1]: scene.objects[0].size[1]: must be > 0" in p for p in problems), problems
    assert any("history.json: redo[0].state.workspace.resolution: must be > 0, got 0" in p
               and p.endswith("the redo history was dropped" + p[p.rindex(" ("):]) for p in problems), problems
    kept = _aside(written.folder)
    assert path.exists() and len(kept) == 1 and f"a copy kept as {kept[0].name}" in problems[-1]

    data = json.loads(kept[0].read_text())  # only the oldest step bad: the newer one is kept
    data["undo"][1]["state"]["scene"]["objects"][0]["size"][1] = 0.5
    data["redo"][0]["state"]["workspace"]["resolution"] = written.workspace.resolution
    path.write_text(json.dumps(data))
    undo, redo, problems = read_history_file(path, written.workspace)
    assert [s.label for s in undo] == ["move a"] and [s.label for s in redo] == ["delete b"]
    assert len(problems) == 1 and "undo[0].label: must not be empty: the undo history before it was dropped" in problems[0]


@pytest.mark.parametrize("text", ["not json", "\ud800", '{"kind": "morphonavi-history", "version": 1, "undo": ' * 3000])
def test_a_corrupt_file_is_reported_never_a_traceback_and_the_session_still_starts(tmp_path: Path, text: str) -> None:
    s = Session(tmp_path / "s", start=START)
    s.spawn(Scene(objects=(_box("a", 1.0, 2.0),)))
    (s.folder / HISTORY_FILE).write_text(text, encoding="utf-8", errors="surrogatepass")
    again = Session(tmp_path / "s", start=START)
    again.restore_last()
    assert len(again.scene.objects) == 1 and again.undo_label is None
    assert any(p.startswith("history.json could not be read") and "kept aside as history.json.unreadable-" in p
               for p in again.restore_problems), again.restore_problems
    again.move_object("a", (1.2, 2.0, 0.3))  # a new history is written over nothing the operator needs
    assert history_errors(json.loads((again.folder / HISTORY_FILE).read_text())) == []
