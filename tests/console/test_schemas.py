"""The published JSON Schemas: committed files equal the generated ones, and files the product writes validate."""

from __future__ import annotations

import json
import math
import sys
from pathlib import Path

import pytest
from jsonschema import Draft202012Validator

from console import schemas
from console.link.world import paper_room
from console.session import session_store
from console.session.session import Session
from pipeline.camera import camera_file
from pipeline.camera.geometry import CameraMount, Intrinsics
from pipeline.mapping.map_fusion import fuse
from pipeline.scene import Capture, Scene, SceneObject, Source, save_scene
from pipeline.schema_check import schema_errors
from planner import mission as mission_module

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover - Python 3.10 only
    import tomli as tomllib

REPO = Path(__file__).resolve().parents[2]


def _valid(name: str, data: object) -> None:
    errors = schema_errors(schemas.SCHEMAS[name], data)
    assert errors == [], errors


def test_committed_schemas_equal_the_generated_ones() -> None:
    assert schemas.stale(REPO / "docs" / "schemas") == []
    assert sorted(p.name for p in (REPO / "docs" / "schemas").glob("*.json")) == sorted(
        f"{n}.schema.json" for n in schemas.SCHEMAS)
    assert schemas.main(["--check"]) == 0


def test_the_writer_and_check_find_a_stale_file(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert schemas.main(["--out", str(tmp_path / "s"), "--check"]) == 1
    assert schemas.main(["--out", str(tmp_path / "s")]) == 0
    assert schemas.main(["--out", str(tmp_path / "s"), "--check"]) == 0
    (tmp_path / "s" / "scene.schema.json").write_text("{}")
    assert schemas.main(["--out", str(tmp_path / "s"), "--check"]) == 1
    assert "out of date: " in capsys.readouterr().err


@pytest.mark.parametrize("name", sorted(schemas.SCHEMAS))
def test_each_schema_is_valid_draft_2020_12(name: str) -> None:
    Draft202012Validator.check_schema(schemas.SCHEMAS[name])


def test_versions_agree_with_the_code() -> None:
    from pipeline.camera.camera_schema import MAX_SIDE
    from pipeline.scene import SCENE_VERSION
    from planner.mission_schema import MISSION_VERSION

    from console.session.session_schema import SESSION_VERSION

    assert MISSION_VERSION == mission_module.MISSION_VERSION
    assert SESSION_VERSION == session_store.SESSION_VERSION
    assert MAX_SIDE == camera_file.MAX_SIDE
    assert schemas.SCHEMAS["scene"]["properties"]["version"]["maximum"] == SCENE_VERSION


def test_the_size_and_quaternion_orders_are_in_the_descriptions() -> None:
    text = json.dumps(schemas.SCHEMAS["scene"])
    assert "[w, h, l]" in text and "[x, y, z, w]" in text
    assert "positive looks DOWN" in json.dumps(schemas.SCHEMAS["camera"])


def _rich_scene() -> Scene:
    """Every optional field set: a mapped object with sources, a fused one with history and flags."""
    mapped = Scene(
        objects=(SceneObject("desk-1", "desk", (1.2, 2.95, 0.375), (0.7, 0.75, 1.4), yaw=0.3, score=0.9,
                             size_known=False,
                             source=Source(capture="c1", method="fused", bbox=(10, 20, 200, 180), mask_area=5000,
                                           distances={"geometric": 2.1, "depth": None, "fused": 2.14},
                                           positions={"camera": (0.1, 0.2, 2.14)})),),
        captures=(Capture("c1", 12.5, "c1.jpg", {"fx": 500.0, "fy": 500.0, "cx": 320.0, "cy": 240.0},
                          {"x": 1.0, "y": 0.5, "z": 0.0, "yaw": 1.57}, (1.0, 0.5, 0.3), (0.0, 0.0, 0.0, 1.0),
                          {"detect": 0.1}, {"detector": "yolox_nano"}),),
    )
    fused = fuse(Scene(), mapped).scene if hasattr(fuse(Scene(), mapped), "scene") else mapped
    return Scene(objects=(*fused.objects, SceneObject("pin", "chair", (3, 3, 0.4), (0.5, 0.8, 0.5), pinned=True,
                                                       flags=("set on the floor",), sigma=0.1, cut=("left",))),
                 captures=mapped.captures)


def test_scene_files_written_by_the_product_validate(tmp_path: Path) -> None:
    for scene in (_rich_scene(), paper_room(), Scene()):
        path = save_scene(scene, tmp_path / "scene.json")
        _valid("scene", json.loads(path.read_text()))


def test_a_bad_scene_is_named_by_field() -> None:
    data = json.loads(json.dumps({"version": 1, "objects": [
        {"id": f"o{i}", "label": "box", "position": [0, 0, 0], "size": [1, 1, 1]} for i in range(4)]}))
    data["objects"][3]["size"][1] = -1
    assert schema_errors(schemas.SCHEMAS["scene"], data) == ["objects[3].size[1]: must be > 0, got -1"]
    del data["objects"][0]["label"]
    assert "objects[0].label: is required" in schema_errors(schemas.SCHEMAS["scene"], data)


def test_missions_and_sessions_written_by_the_product_validate(tmp_path: Path) -> None:
    session = Session(tmp_path / "session", start=(0.5, 0.5, 0.0))
    session.spawn(Scene(objects=paper_room().objects[:3]), origin="test")
    session.add_goal((4.0, 7.0, 0.0))
    session.register()
    mission = session.build_mission()
    _valid("mission", json.loads(mission.save(tmp_path / "mission.json").read_text()))
    turn = mission_module.Mission((mission_module.turn_segment((1.0, 1.0, 0.0), math.pi / 2),))
    _valid("mission", turn.to_dict())
    saved = session.save()
    _valid("session", json.loads(Path(saved).read_text()))
    bad = turn.to_dict()
    bad["segments"][0].pop("yaw")
    assert schema_errors(schemas.SCHEMAS["mission"], bad)  # a turn needs its heading


def test_camera_files_written_by_calibrate_validate(tmp_path: Path) -> None:
    intr = Intrinsics(525.0, 525.0, 319.5, 239.5, 640, 480, (0.1, -0.2, 0.0, 0.0, 0.05))
    for mount in (None, CameraMount((0.15, 0.0, 0.35), math.radians(10), 0.0, math.radians(-3))):
        path = camera_file.write_camera_toml(tmp_path / "camera.toml", intr, mount, {"rms_px": 0.4})
        _valid("camera", tomllib.loads(path.read_text()))
    bad = {"intrinsics": {"fx": 1, "fy": 1, "cx": 0, "cy": 0, "width": 10, "height": 10, "dist": [0.1, 0.2]}}
    assert schema_errors(schemas.SCHEMAS["camera"], bad)  # two coefficients is no OpenCV model


def test_validate_a_file_from_the_command_line(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    good = save_scene(paper_room(), tmp_path / "room.json")
    assert schemas.main(["--validate", "scene", str(good)]) == 0
    assert "a valid scene file" in capsys.readouterr().out
    data = json.loads(good.read_text())
    data["objects"][2]["size"][0] = 0
    bad = tmp_path / "bad.json"
    bad.write_text(json.dumps(data))
    assert schemas.main(["--validate", "scene", str(bad)]) == 1
    assert capsys.readouterr().err == f"{bad}: objects[2].size[0]: must be > 0, got 0\n"
    assert schemas.main(["--validate", "mission", str(tmp_path / "none.json")]) == 1
    assert "cannot read" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        schemas.main(["--validate", "nope", str(good)])
