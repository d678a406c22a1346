"""bench --drop-pose: every photo mapped without its camera pose, and the report's with / without pose lines."""

from __future__ import annotations

from pathlib import Path

from pipeline.bench.evaluate import format_report, run_bench
from tests.pipeline.bench.test_bench import write_dataset
from tests.pipeline.test_mapper import CATALOG


def test_drop_pose_maps_from_the_photo_and_reports_it_apart(tmp_path: Path) -> None:
    root = write_dataset(tmp_path / "data")
    given = run_bench(root, None, CATALOG, gt_boxes=True, progress=False)
    dropped = run_bench(root, None, CATALOG, gt_boxes=True, progress=False, drop_pose=True)
    assert [r["pose_given"] for r in given.samples] == [True]
    assert [r["pose_given"] for r in dropped.samples] == [False]
    assert "camera pose not given" in dropped.samples[0]["camera_pose"]
    bp = dropped.summary["by_pose"]
    assert bp["given"]["images"] == 0 and bp["not_given"]["images"] == 1
    assert bp["not_given"]["matched"] == dropped.summary["matched"] >= 2
    text = format_report(dropped)
    assert "camera pose from the photo   1 images" in text and "camera pose given" not in text
    assert "camera pose given" in format_report(given)
