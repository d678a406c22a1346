"""A group keeps its name from capture to capture and across a restart of the console.

The session's map (world frame, z up [m]) gets a line of four boxes, then a capture that sees the line
again, a fifth box at its end and a new group whose first member sorts before the boxes (three benches);
then the console restarts from its session folder. Group ids used to be numbered in that order
(``group-1``, ``group-2``), so the new benches took the line's ``group-1``.
"""

from __future__ import annotations

from pathlib import Path

from console.mcp.state_read import scene_graph, summary
from console.session.session import Session
from pipeline.scene import Scene, SceneObject

START = (2.5, 0.7, 0.0)
BOX = (0.45, 0.4, 0.45)
BENCH = (0.4, 0.45, 1.2)


def _boxes(n: int, dx: float = 0.0) -> list[SceneObject]:
    return [SceneObject(f"cardboard_box-{k + 1}", "cardboard_box", (1.0 + 0.5 * k + dx, 4.0, 0.2), BOX)
            for k in range(n)]


def _benches() -> list[SceneObject]:
    return [SceneObject(f"bench-{k + 1}", "bench", (3.4 + 0.5 * k, 1.8, 0.225), BENCH) for k in range(3)]


def _groups(session: Session) -> dict[str, list[str]]:
    return {g["id"]: g["members"] for g in scene_graph(session)["groups"]}


def test_group_names_stay_across_captures_and_a_restart(tmp_path: Path) -> None:
    folder = tmp_path / "session"
    s = Session(folder, start=START)
    s.spawn(Scene(objects=tuple(_boxes(4))), origin="capture 0001")
    first = _groups(s)
    assert list(first) == ["group-cardboard_box-1"]
    line = "group-cardboard_box-1"

    s.spawn(Scene(objects=tuple(_boxes(5, dx=0.02) + _benches())), origin="capture 0002")
    second = _groups(s)
    assert set(second) == {"group-bench-1", line}  # the benches sort first; the line keeps its name
    assert second[line] == [f"cardboard_box-{k}" for k in range(1, 6)]
    assert f"({line}: cardboard_box-1" in summary(s)

    again = Session(folder, start=START)
    assert again.restore_last() is not None
    assert _groups(again) == second
