"""The bench's per-class table: gt / found / precision on fully annotated photos / unmatched elsewhere."""

from __future__ import annotations

import json
from pathlib import Path

from pipeline.bench.evaluate import format_report, run_bench
from pipeline.models.ground_truth import GroundTruthBundle, GroundTruthDepth, GroundTruthDetector, GroundTruthSegmenter
from pipeline.mapper import MapperConfig
from tests.pipeline.bench.test_bench import write_dataset
from tests.pipeline.test_mapper import CATALOG, SCENE


def test_per_class_precision_counts_each_class_own_detections(tmp_path: Path) -> None:
    root = write_dataset(tmp_path / "data")
    # crate found; barrel box called a crate (a false crate); rock found; a barrel on the crate's box (false)
    boxes = list(SCENE["boxes"]) + [SCENE["boxes"][0]]
    detector = GroundTruthDetector(boxes, ["crate", "crate", "rock", "barrel"], scores=[0.9, 0.8, 0.7, 0.6])
    models = GroundTruthBundle(detector, GroundTruthSegmenter(SCENE["masks"]), GroundTruthDepth(SCENE["depth"]))
    config = MapperConfig(segment="none", same_object_iou=None)
    s = run_bench(root, models, CATALOG, config=config, progress=False)
    by = s.summary["by_class"]
    assert (by["crate"]["gt"], by["crate"]["matched"], by["crate"]["detections_complete"]) == (1, 1, 2)
    assert by["crate"]["precision"] == 0.5 and by["rock"]["precision"] == 1.0
    assert (by["barrel"]["gt"], by["barrel"]["matched"], by["barrel"]["precision"]) == (1, 0, 0.0)
    assert all(b["unmatched_partial"] == 0 for b in by.values())
    text = format_report(s)
    assert any(line.split()[:3] == ["crate", "1", "1"] and "50% of 2" in line for line in text.splitlines())

    # partially annotated: no precision, the unmatched detections are counted apart, per class
    sample_json = root / "synth" / "0001.json"
    sample_json.write_text(json.dumps({**json.loads(sample_json.read_text()), "partial_annotation": True}))
    by = run_bench(root, models, CATALOG, config=config, progress=False).summary["by_class"]
    assert by["crate"]["precision"] is None and by["crate"]["detections_complete"] == 0
    assert (by["crate"]["unmatched_partial"], by["barrel"]["unmatched_partial"], by["rock"]["unmatched_partial"]) == (1, 1, 0)
