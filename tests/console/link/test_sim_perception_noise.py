"""The simulator's perception-noise switch: box jitter, missed and false detections, one model for the
console (``--perception noisy``) and the tour benchmark."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from console.cli.morphonavi import build_parser, main
from console.link.sim import SimRobot
from console.link.sim_perception_noise import FALSE_LABELS, PerceptionNoise, noisy_bundle_for
from console.session.mapping_job import GROUND_TRUTH_LABEL, NOISY_LABEL, choose_perceiver


def _boxes(n: int) -> tuple[list[list[float]], list[str]]:
    return [[10.0 + k, 200.0, 60.0 + k, 260.0] for k in range(n)], ["cardboard_box"] * n


def test_noise_misses_about_a_tenth_jitters_boxes_and_adds_false_ones() -> None:
    boxes, labels = _boxes(2000)
    out_b, out_l, masks = PerceptionNoise().apply(boxes, labels, None, (640, 480), np.random.default_rng(3))
    assert masks is None
    kept = [b for b, lab in zip(out_b, out_l) if lab == "cardboard_box"]
    assert 0.07 < 1 - len(kept) / 2000 < 0.13  # 10 % missed
    shifts = np.array([np.asarray(b)[:2] - [10.0, 200.0] for b in kept])  # y1 moves by N(0, 2 px)
    assert 1.5 < float(np.std(shifts[:, 1])) < 2.5 and np.abs(shifts[:, 1]).max() < 15
    photos = [PerceptionNoise().apply([], [], None, (640, 480), np.random.default_rng(s))[1] for s in range(200)]
    false = [p for p in photos if p]
    assert 0.25 < len(false) / 200 < 0.55 and all(lab in FALSE_LABELS for p in false for lab in p)


def test_exact_settings_change_nothing_and_bad_settings_are_named() -> None:
    boxes, labels = _boxes(5)
    out_b, out_l, _ = PerceptionNoise(jitter_px=0.0, miss=0.0, false_rate=0.0).apply(
        boxes, labels, None, (640, 480), np.random.default_rng(0))
    assert out_l == labels and all(np.allclose(b[:2], a[:2]) for a, b in zip(boxes, out_b))
    with pytest.raises(ValueError, match="PerceptionNoise.miss"):
        PerceptionNoise(miss=1.5)
    with pytest.raises(ValueError, match="PerceptionNoise.jitter_px"):
        PerceptionNoise(jitter_px=math.nan)


def test_the_noisy_perceiver_maps_a_simulator_render_and_is_chosen_by_the_switch() -> None:
    robot = SimRobot(manual_clock=True)
    robot.connect()
    try:
        shot = robot.capture()
        assert choose_perceiver(robot, None).label == GROUND_TRUTH_LABEL
        assert choose_perceiver(robot, None, "noisy").label == NOISY_LABEL
    finally:
        robot.close()
    visible = len(shot.ground_truth.visible)
    counts = []
    for seed in range(4):
        bundle = noisy_bundle_for(PerceptionNoise(miss=0.5, false_rate=0.0), seed=seed)(shot)
        counts.append(len(bundle.detector.detect(shot.image, [("cardboard box", "cardboard_box")])))
    assert visible > 10 and all(c < visible for c in counts)  # half of them missed, differently per seed
    with pytest.raises(ValueError, match="no ground truth"):
        noisy_bundle_for()(type("Shot", (), {"ground_truth": None, "image": shot.image})())


def test_the_console_and_search_take_the_switch(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert build_parser().parse_args(["console", "--perception", "noisy"]).perception == "noisy"
    assert build_parser().parse_args(["console"]).perception == "exact"
    assert build_parser().parse_args(["search", "--target", "robot dog", "--perception", "noisy"]).perception == "noisy"
    with pytest.raises(SystemExit):
        build_parser().parse_args(["console", "--perception", "blurry"])
    code = main(["console", "--perception", "noisy", "--robot", "mavlink:udpin:127.0.0.1:14550",
                 "--session", str(tmp_path / "s")])
    assert code == 2 and "--perception noisy" in capsys.readouterr().err
