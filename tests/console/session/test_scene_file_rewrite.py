"""A watched scene file rewritten in place replaces the objects it added in the console (no ghost copies)."""

from __future__ import annotations

import json
import os
import time
from pathlib import Path

from pipeline.scene import SceneObject


def _age(path: Path, seconds: float = 2.0) -> None:
    t = time.time() - seconds
    os.utime(path, (t, t), follow_symlinks=False)


def _wait(pred, timeout: float = 30.0) -> bool:
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        if pred():
            return True
        time.sleep(0.05)
    return pred()


def test_the_console_moves_the_object_of_a_rewritten_file_instead_of_adding_a_ghost(tmp_path: Path) -> None:
    from console.app import ConsoleApp, ConsoleConfig

    app = ConsoleApp(ConsoleConfig(robot="sim", session_dir=tmp_path / "s", scene_dir=tmp_path / "scenes", port=0,
                                   fresh=True, record=False)).start()
    try:
        scenes = tmp_path / "scenes"

        def write(x: float) -> None:
            data = {"version": 1, "objects": [
                {"id": "box-1", "label": "cardboard_box", "position": [x, 5.0, 0.2], "size": [0.4, 0.4, 0.4],
                 "source": {"method": "ground_truth"}},
                {"id": "chair-1", "label": "chair", "position": [4.0, 2.0, 0.45], "size": [0.5, 0.9, 0.5],
                 "source": {"method": "ground_truth"}}]}
            tmp = scenes / ".drop.tmp"
            tmp.write_text(json.dumps(data))
            _age(tmp)
            os.replace(tmp, scenes / "drop.json")  # an atomic replace, as editors and exporters do

        def boxes() -> list[SceneObject]:
            return [o for o in app.session.scene.objects if o.label == "cardboard_box"]

        write(1.0)
        assert _wait(lambda: len(boxes()) == 1)
        write(2.0)  # box-1 moved 1 m
        assert _wait(lambda: boxes() and abs(boxes()[0].position[0] - 2.0) < 1e-6)
        time.sleep(1.5)  # one more poll: nothing else comes
        assert len(boxes()) == 1 and len(app.session.scene.objects) == 2
        assert [o.id for o in boxes()] == ["box-1"]
    finally:
        app.stop()
