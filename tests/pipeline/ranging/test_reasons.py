"""The scene file says which distance cue was down-weighted and why (``source.down_weighted``)."""

from __future__ import annotations

import json
from types import SimpleNamespace

import jsonschema
import numpy as np
import pytest

from pipeline.camera.geometry import CameraMount, Intrinsics, Pose
from pipeline.catalog import default_catalog
from pipeline.mapper import Mapper
from pipeline.models.ground_truth import ground_truth_bundle
from pipeline.ranging.distance import Truncation
from pipeline.ranging.fusion import Cue, Fused
from pipeline.ranging.reasons import down_weight_reasons
from pipeline.scene import load_scene, save_scene
from pipeline.scene_json import scene_from_dict, scene_to_dict
from pipeline.scene_model import SceneError
from pipeline.scene_schema import SCENE_SCHEMA

INTR = Intrinsics(525.0, 525.0, 319.5, 239.5, 640, 480)
MOUNT = CameraMount(position=(0.0, 0.0, 1.5))  # a level camera 1.5 m up


def _map(boxes: list[tuple[float, float, float, float]], labels: list[str]):
    image = np.full((480, 640, 3), 90, dtype=np.uint8)
    with Mapper(ground_truth_bundle(boxes, labels), default_catalog()) as mapper:
        return mapper.run(image, INTR, MOUNT, Pose(), capture_id="c1")


def _reasons(scene, label: str) -> list[tuple[str, str]]:
    (obj,) = [o for o in scene.objects if o.label == label]
    return list(obj.source.down_weighted)


def test_a_box_too_wide_and_a_box_cut_by_the_bottom_border_say_so_in_the_scene(tmp_path) -> None:
    # a person 5 m away (1.75 m over 184 px, standing on the floor 1.5 m below the camera), a person box far
    # too wide for its height (crouching / two people), a chair whose legs the bottom border cuts
    res = _map([(250, 213, 318, 397), (380, 213, 630, 397), (20, 300, 150, 480)], ["person", "person", "chair"])
    by_x = sorted(res.scene.objects, key=lambda o: o.source.bbox[0])
    chair, plain, wide = by_x
    assert plain.label == wide.label == "person" and chair.label == "chair"
    assert not [r for r in plain.source.down_weighted if r[0] == "size_prior"]
    (why,) = [w for c, w in wide.source.down_weighted if c == "size_prior"]
    assert why.startswith("box ") and "wider for its height than the class can look" in why
    k = float(why.split("box ")[1].split("x")[0])
    assert 1.3 < k < 2.0
    cues = dict(chair.source.down_weighted)
    assert "bottom cut by the image border" in cues["size_prior"]
    assert [w for c, w in chair.source.down_weighted if c == "ground_contact" and "only bounds the distance" in w]
    # saved and read back, valid against the published schema
    path = save_scene(res.scene, tmp_path / "scene.json")
    data = json.loads(path.read_text())
    jsonschema.validate(data, SCENE_SCHEMA)
    entry = next(o for o in data["objects"] if o["id"] == wide.id)
    assert {"cue": "size_prior", "why": why} in entry["source"]["down_weighted"]
    assert "down_weighted" not in next(o for o in data["objects"] if o["id"] == plain.id)["source"]
    back = load_scene(path)
    assert next(o for o in back.objects if o.id == wide.id).source.down_weighted == wide.source.down_weighted


def test_bad_reasons_in_a_file_are_named() -> None:
    data = scene_to_dict(_map([(250, 213, 318, 397)], ["person"]).scene)
    data["objects"][0]["source"]["down_weighted"] = [{"cue": "size_prior"}]
    with pytest.raises(SceneError, match=r"objects\[0\]\.source\.down_weighted\[0\]"):
        scene_from_dict(data)


def test_a_floor_at_odds_an_outlier_a_hidden_contact_and_a_wide_scatter_are_each_named() -> None:
    obj = SimpleNamespace(
        cues=[Cue("size_prior", 5.0, 0.4), Cue("ground_contact", 6.5, 0.5, "",
                                               "the photo's floor disagrees with the given camera pose by 4.1 sigma")],
        bound=None, truncation=Truncation(), contact_hidden_by="car",
        fusion=Fused(5.1, 0.6, ("size_prior", "ground_contact"),
                     (("depth", "9.00 m disagrees with the other cues by 5.2 sigma"),), False, 1.6))
    reasons = down_weight_reasons(obj)
    assert reasons[0] == ("ground_contact", "the photo's floor disagrees with the given camera pose by 4.1 sigma")
    assert ("ground_contact", "its bottom edge may be hidden by the car: read as an upper bound only") in reasons
    assert ("depth", "not used: 9.00 m disagrees with the other cues by 5.2 sigma") in reasons
    assert ("fused", "the cues scatter more than their sigmas allow: sigma x1.6") in reasons
    calm = SimpleNamespace(cues=[Cue("size_prior", 5.0, 0.4)], bound=None, truncation=Truncation(),
                           contact_hidden_by=None, fusion=Fused(5.0, 0.4, ("size_prior",)))
    assert down_weight_reasons(calm) == ()
