"""Scene model: round trip, validation messages naming the field, atomic writes."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from pipeline.scene import (Capture, Scene, SceneError, SceneObject, Source, load_scene, save_scene, scene_from_dict,
                            scene_to_dict, scene_to_json)


def _scene() -> Scene:
    return Scene(
        objects=(
            SceneObject("desk-1", "desk", (1.0, 2.0, 0.375), (0.7, 0.75, 1.4), yaw=0.3, score=0.9,
                        source=Source(capture="c1", method="fused", bbox=(10, 20, 200, 180), mask_area=5000,
                                      distances={"geometric": 2.1, "depth": 2.3, "fused": 2.14},
                                      positions={"camera": (0.1, 0.2, 2.14)})),
            SceneObject("dog", "robot_dog", (2.5, 6.0, 0.2), (0.28, 0.4, 0.645), size_known=False),
        ),
        captures=(Capture("c1", 12.5, "c1.jpg", {"fx": 500.0, "fy": 500.0, "cx": 320.0, "cy": 240.0},
                          {"x": 1.0, "y": 0.5, "z": 0.0, "yaw": 1.57}, (1.0, 0.5, 0.3), (0, 0, 0, 1),
                          {"detect": 0.1, "total": 0.5}, {"detector": "yolox_nano"}),),
    )


def test_round_trip(tmp_path: Path) -> None:
    s = _scene()
    p = save_scene(s, tmp_path / "scene.json")
    back = load_scene(p)
    assert back.objects[0].source.distances["fused"] == pytest.approx(2.14)
    assert back.objects[0].source.positions["camera"] == pytest.approx((0.1, 0.2, 2.14))
    assert back.objects[0].yaw == pytest.approx(0.3)
    assert back.objects[1].size_known is False
    assert back.captures[0].timings["total"] == pytest.approx(0.5)
    assert scene_to_dict(back) == scene_to_dict(s)


@pytest.mark.parametrize(
    "mutate, field",
    [
        (lambda d: d["objects"][0].__setitem__("size", [0.7, -1, 1.4]), "objects[0].size[1]"),
        (lambda d: d["objects"][1].__setitem__("position", [1, 2]), "objects[1].position"),
        (lambda d: d["objects"][0].pop("label"), "objects[0].label"),
        (lambda d: d["objects"][0].__setitem__("frame", "map"), "objects[0].frame"),
        (lambda d: d["objects"][0].__setitem__("score", 1.5), "objects[0].score"),
        (lambda d: d["objects"][1].__setitem__("id", "desk-1"), "objects[1].id"),
        (lambda d: d.__setitem__("version", 99), "version"),
        (lambda d: d["captures"][0].__setitem__("intrinsics", {"fx": "big"}), "captures[0].intrinsics.fx"),
        (lambda d: d["objects"][0]["source"].__setitem__("positions", {"moon": [1, 2, 3]}), "objects[0].source.positions.moon"),
        (lambda d: d["objects"][0].__setitem__("yaw", float("nan")), "objects[0].yaw"),
    ],
)
def test_malformed_fields_are_named(mutate, field: str) -> None:
    d = json.loads(scene_to_json(_scene()))
    mutate(d)
    with pytest.raises(SceneError) as err:
        scene_from_dict(d)
    assert err.value.field == field
    assert str(err.value).startswith(field)


def test_bad_json_and_missing_file(tmp_path: Path) -> None:
    p = tmp_path / "bad.json"
    p.write_text('{"version": 1, "objects": [', encoding="utf-8")
    with pytest.raises(SceneError, match="not valid JSON"):
        load_scene(p)
    with pytest.raises(SceneError, match="not found"):
        load_scene(tmp_path / "nope.json")


def test_failed_save_leaves_previous_file(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    p = save_scene(_scene(), tmp_path / "scene.json")
    before = p.read_text()
    import pipeline.scene as sc

    def boom(*a, **k):
        raise OSError("disk full")

    monkeypatch.setattr(sc.os, "replace", boom)
    with pytest.raises(OSError):
        save_scene(Scene(objects=()), p)
    assert p.read_text() == before
    assert [f.name for f in tmp_path.iterdir()] == ["scene.json"]


def test_duplicate_ids_rejected_in_constructor() -> None:
    o = _scene().objects[0]
    with pytest.raises(SceneError, match="duplicate"):
        Scene(objects=(o, o))
