"""The benchmark: dataset loading, matching, metrics with known answers, the CLI, and the dev set."""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import cv2
import numpy as np
import pytest

from pipeline.bench.evaluate import (
    BenchError, format_report, load_dataset, match_greedy, mount_from_gravity, run_bench,
)
from pipeline.catalog import Catalog
from pipeline.camera.geometry import Pose, camera_pose_in_world
from pipeline.models.ground_truth import GroundTruthBundle, GroundTruthDepth, GroundTruthDetector, GroundTruthSegmenter
from pipeline.mapper import MapperConfig, gravity_in_camera
from tests.pipeline.test_mapper import CATALOG, INTR, OBJECTS, SCENE, WORLD_FROM_CAM

SHARED = Path(__file__).resolve().parents[3].parent / "shared"
DEV = SHARED / "bench" / "dev"


def write_dataset(root: Path) -> Path:
    """One rendered sample in the dev-set format, plus a labelled object the catalog does not know."""
    root.mkdir(parents=True, exist_ok=True)
    (root / "synth").mkdir()
    cv2.imwrite(str(root / "synth" / "0001.png"), SCENE["image"][:, :, ::-1])
    cam_from_world = WORLD_FROM_CAM.inverse()
    objects = [
        {"label": label, "label_raw": label.upper(), "center_cam": cam_from_world.apply(c).tolist(),
         "size": list(size), "bbox2d_proj": list(box)}
        for (label, c, size, _), box in zip(OBJECTS, SCENE["boxes"])
    ]
    objects.append({"label": "lamp", "label_raw": "lamp", "center_cam": [0.5, 0.0, 6.0], "size": [0.3, 0.5, 0.3],
                    "bbox2d_proj": [10, 10, 20, 30]})
    sample = {"image": "0001.png", "width": INTR.width, "height": INTR.height, "K": INTR.K.tolist(),
              "gravity_cam": gravity_in_camera(WORLD_FROM_CAM).tolist(), "objects": objects}
    (root / "synth" / "0001.json").write_text(json.dumps(sample))
    (root / "index.json").write_text(json.dumps([{"source": "synth", "json": "synth/0001.json",
                                                  "image": "synth/0001.png"}]))
    return root


def test_mount_from_gravity_puts_gravity_where_the_dataset_says() -> None:
    rng = np.random.default_rng(1)
    for _ in range(20):
        g = rng.normal(size=3) + [0.0, 2.0, 0.0]
        g /= np.linalg.norm(g)
        mount = mount_from_gravity(g)
        assert np.allclose(gravity_in_camera(camera_pose_in_world(Pose(), mount)), g, atol=1e-9)
    level = mount_from_gravity(None)
    assert np.allclose(gravity_in_camera(camera_pose_in_world(Pose(), level)), [0.0, 1.0, 0.0])


def test_matching_is_one_to_one_class_aware_and_best_first() -> None:
    gt = np.array([[0, 0, 10, 10], [20, 0, 30, 10], [40, 0, 50, 10]], float)
    det = np.array([[1, 0, 11, 10], [0, 0, 10, 10], [20, 0, 30, 10], [40, 0, 50, 10]], float)
    pairs = match_greedy(det, ["a", "a", "b", "a"], gt, ["a", "a", "b"], 0.5)
    assert sorted((i, j) for i, j, _ in pairs) == [(1, 0)]  # det 0 loses gt 0 to the exact det 1; b != a
    assert match_greedy(det[:1], ["a"], gt[:1], ["a"], 0.9) == []
    assert match_greedy(np.zeros((0, 4)), [], gt, ["a", "a", "b"], 0.5) == []


def test_bench_metrics_on_a_rendered_sample(tmp_path: Path) -> None:
    root = write_dataset(tmp_path / "data")
    samples = load_dataset(root, CATALOG)
    assert len(samples) == 1 and [o.cls for o in samples[0].objects] == ["crate", "barrel", "rock", None]

    # dataset boxes, no model at all: the rock (unknown size, no depth) cannot be placed
    report = run_bench(root, None, CATALOG, gt_boxes=True, progress=False)
    s = report.summary
    assert (s["gt_objects_catalog"], s["matched"]) == (3, 2)
    assert s["detection_ratio"] == pytest.approx(2 / 3)
    assert s["excluded_labels"] == {"lamp": 1}
    assert s["error_rel"]["median"] < 0.05
    assert report.samples[0]["missed"] == ["rock"]

    # with (ground-truth) depth the rock is placed from the depth map
    depth_models = GroundTruthBundle(GroundTruthDetector([], []), GroundTruthSegmenter(SCENE["masks"]),
                                     GroundTruthDepth(SCENE["depth"]))
    report = run_bench(root, depth_models, CATALOG, gt_boxes=True, progress=False)
    assert report.summary["detection_ratio"] == 1.0
    errors = {m["label"]: m["error_rel"] for m in report.samples[0]["matches"]}
    assert errors["crate"] < 0.05 and errors["barrel"] < 0.05 and errors["rock"] < 0.1


def test_bench_reports_each_cue_and_the_sigma_calibration(tmp_path: Path) -> None:
    """With the sample's camera height the floor contact places the rock too; every cue is scored and the
    fraction of errors within 1 and 2 sigma is reported (and printed)."""
    root = write_dataset(tmp_path / "data")
    meta_path = root / "synth" / "0001.json"
    meta = json.loads(meta_path.read_text())
    meta["camera_height"] = float(WORLD_FROM_CAM.translation[2])
    meta_path.write_text(json.dumps(meta))
    report = run_bench(root, None, CATALOG, gt_boxes=True, progress=False)
    s = report.summary
    assert s["matched"] == 3  # the rock (unknown size, no depth map) from its floor contact
    assert s["cues"]["ground_contact"]["n"] == 3 and s["cues"]["size_prior"]["n"] == 2
    assert s["cues"]["depth"]["n"] == 0 and s["cues"]["fused"]["n"] == 3
    matches = report.samples[0]["matches"]
    inside = sum(1 for m in matches if m["error_z"] <= m["sigma_z"])
    assert s["cues"]["fused"]["within_1_sigma"] == pytest.approx(inside / 3)
    assert 0 <= s["cues"]["fused"]["within_1_sigma"] <= s["cues"]["fused"]["within_2_sigma"] <= 1
    assert all(m["cut"] == [] and m["sigma_z"] > 0 for m in matches)
    text = format_report(report)
    assert "ground_contact" in text and "<=1 sigma" in text
    meta["camera_height"] = -1.0
    meta_path.write_text(json.dumps(meta))
    with pytest.raises(BenchError, match="camera_height"):
        load_dataset(root, CATALOG)


def test_bench_with_a_detector_counts_wrong_classes_as_unmatched(tmp_path: Path) -> None:
    root = write_dataset(tmp_path / "data")
    boxes = list(SCENE["boxes"]) + [SCENE["boxes"][0]]
    labels = ["crate", "crate", "rock", "barrel"]  # the barrel box called a crate; a barrel on the crate
    detector = GroundTruthDetector(boxes, labels, scores=[0.9, 0.8, 0.7, 0.6])
    models = GroundTruthBundle(detector, GroundTruthSegmenter(SCENE["masks"]), GroundTruthDepth(SCENE["depth"]))
    config = MapperConfig(segment="none", same_object_iou=None)  # keep the barrel called on the crate's box
    report = run_bench(root, models, CATALOG, config=config, progress=False)
    s = report.summary
    assert s["matched"] == 2  # crate and rock
    assert sorted(report.samples[0]["missed"]) == ["barrel"]
    assert s["unmatched_detections"] == 2
    assert s["detection_ratio_vocabulary"] == pytest.approx(2 / 3)
    assert set(s["mean_time_s"]) >= {"detect", "depth", "segment", "distance", "total"}
    # the sample is fully annotated: its two unmatched detections are false positives
    assert s["complete_annotation"] == {"images": 1, "detections": 4, "unmatched_detections": 2, "precision": 0.5}
    text = format_report(report)
    assert "detection ratio" in text and "66.7%" in text and "synth" in text
    assert "precision             50.0% of 4 detections" in text and "(2 unmatched)" in text
    saved = report.save(tmp_path / "out" / "report.json")
    assert json.loads(saved.read_text())["summary"]["matched"] == 2

    # partially annotated: an unmatched detection may be an unlabelled object, so no precision
    sample_json = root / "synth" / "0001.json"
    sample_json.write_text(json.dumps({**json.loads(sample_json.read_text()), "partial_annotation": True}))
    partial = run_bench(root, models, CATALOG, config=config, progress=False).summary
    assert partial["unmatched_detections"] == 2 and partial["matched"] == 2
    assert partial["complete_annotation"] == {"images": 0, "detections": 0, "unmatched_detections": 0,
                                              "precision": None}


def test_bad_datasets_get_specific_errors(tmp_path: Path) -> None:
    with pytest.raises(BenchError, match="not a folder"):
        load_dataset(tmp_path / "nowhere", CATALOG)
    (tmp_path / "index.json").write_text("{not json")
    with pytest.raises(BenchError, match=r"index\.json: not valid JSON \(line 1, column 2\): "):
        load_dataset(tmp_path, CATALOG)
    (tmp_path / "index.json").write_text(json.dumps([{"json": "a.json"}]))
    with pytest.raises(BenchError, match="a.json: no such file"):
        load_dataset(tmp_path, CATALOG)
    (tmp_path / "a.json").write_text(json.dumps({"image": "a.png", "width": 10, "height": 10}))
    with pytest.raises(BenchError, match="missing field 'K'"):
        load_dataset(tmp_path, CATALOG)
    with pytest.raises(BenchError, match="models are required"):
        run_bench(write_dataset(tmp_path / "d"), None, CATALOG)


def test_cli_bench_writes_a_report(tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                   capsys: pytest.CaptureFixture[str]) -> None:
    import console.cli.map_bench_cmd as cc

    monkeypatch.setattr(cc, "_catalog", lambda args: CATALOG)
    root = write_dataset(tmp_path / "data")
    parser = argparse.ArgumentParser(prog="morphonavi")
    cc.add_bench_parser(parser.add_subparsers(dest="command", required=True))
    out = tmp_path / "report.json"
    args = parser.parse_args(["bench", str(root), "--gt-boxes", "--no-models", "--no-progress", "--out", str(out)])
    assert args.func(args) == 0
    printed = capsys.readouterr().out
    assert "3D centre error" in printed and "report written" in printed
    assert json.loads(out.read_text())["summary"]["matched"] == 2
    args = parser.parse_args(["bench", str(tmp_path / "missing"), "--gt-boxes", "--no-models", "--out", ""])
    assert args.func(args) == 2
    assert "not a folder" in capsys.readouterr().err


@pytest.mark.skipif(not DEV.is_dir(), reason="needs ../shared/bench/dev")
def test_dev_set_with_dataset_boxes() -> None:
    catalog = Catalog.load()
    report = run_bench(DEV, None, catalog, gt_boxes=True, sources=["sunrgbd", "kitti"], limit=3, progress=False)
    s = report.summary
    assert s["images"] == 3 and s["gt_objects_catalog"] > 0
    assert 0.5 <= s["detection_ratio"] <= 1.0
    assert s["error_rel"]["median"] < 0.5  # size priors, not ground-truth sizes: tens of percent at worst


@pytest.mark.skipif(not DEV.is_dir() or not (SHARED / "models" / "yolox_nano").is_dir(),
                    reason="needs ../shared/bench/dev and ../shared/models")
def test_dev_set_with_the_offline_models(tmp_path: Path) -> None:
    from pipeline.mapper import load_mapping_models

    catalog = Catalog.load()
    models = load_mapping_models("offline", SHARED / "models", catalog)
    report = run_bench(DEV, models, catalog, sources=["kitti"], limit=2, config=MapperConfig(segment="auto"),
                       progress=False)
    s = report.summary
    assert s["images"] == 2
    assert 0.0 <= s["detection_ratio"] <= 1.0 and s["gt_objects_in_vocabulary"] > 0
    assert s["matched"] >= 1  # YOLOX-Nano finds the near KITTI cars
    assert s["error_rel"]["median"] is not None and s["error_rel"]["median"] < 0.3
    assert s["mean_time_s"]["total"] > 0 and s["mean_time_s"]["detect"] > 0
    report.save(tmp_path / "r.json")
    # the offline set adds the Open Images SSD (class-aware merge) when its files are present
    expected = "yolox_nano+oidv4_ssd (class-aware)" if (SHARED / "models" / "oidv4_ssd").is_dir() else "yolox_nano"
    assert json.loads((tmp_path / "r.json").read_text())["models"]["detector"] == expected


def test_cli_mapping_options_reach_the_mapper_config() -> None:
    """`--paper` switches every step beyond the paper off; the single switches turn off one each."""
    import console.cli.map_bench_cmd as cc

    parser = argparse.ArgumentParser()
    cc.add_bench_parser(parser.add_subparsers())

    def config(*flags: str) -> MapperConfig:
        return cc._config(parser.parse_args(["bench", "data", *flags]))

    full = config()
    assert (full.placement, full.fusion, full.handle_truncation, full.fit_depth, full.yaw_from_depth) == \
        ("box_fit", "sigma", True, True, None)
    paper = config("--paper")
    assert (paper.placement, paper.fusion, paper.handle_truncation, paper.fit_depth, paper.yaw_from_depth) == \
        ("ray", "fixed", False, False, False)
    assert (paper.w_geometric, paper.w_depth) == (0.8, 0.2)
    one = config("--no-depth-fit")
    assert not one.fit_depth and one.handle_truncation and one.placement == "box_fit"
    assert not config("--no-uncut-sides").handle_truncation
    assert config().ground_contact and not config("--no-ground-contact").ground_contact
    assert config("--fusion", "adaptive").fusion == "adaptive"


@pytest.mark.skipif(not DEV.is_dir(), reason="needs ../shared/bench/dev")
def test_dev_set_reports_hidden_contacts_and_raised_heights() -> None:
    """SUN RGB-D 000001: the bed hides the nightstand's floor contact (its reading is only a bound);
    ScanNet: cabinets cut by the top border are mapped at least as tall as they show."""
    report = run_bench(DEV, None, Catalog.load(), gt_boxes=True, sources=["sunrgbd", "scannet"], progress=False)
    matches = [m for r in report.samples for m in r["matches"]]
    hidden = [m for m in matches if m["contact_hidden_by"]]
    assert ("nightstand", "bed") in [(m["label"], m["contact_hidden_by"]) for m in hidden]
    raised = [m for m in matches if m["height"] and m["height"]["how"] == "at_least_visible"]
    assert raised and all(m["height"]["m"] > Catalog.load().get(m["label"]).size[1] for m in raised)  # type: ignore[index]
    assert report.summary["hidden_contact"]["matched"] == len(hidden)
    assert report.summary["raised_height"]["matched"] == len(raised)
    text = format_report(report)
    assert f"used as an upper bound: {len(hidden)} matched" in text and f"at least the visible: {len(raised)} matched" in text
