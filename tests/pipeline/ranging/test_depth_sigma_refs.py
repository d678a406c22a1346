"""Two reference objects already say how far a learned depth map is off: their disagreement widens its sigma."""

from __future__ import annotations

import re

import numpy as np

from pipeline.camera.geometry import Intrinsics
from pipeline.catalog import default_catalog
from pipeline.mapper_config import MapperConfig
from pipeline.models.base import DepthMap, Detection
from pipeline.ranging.ranger import Ranger

INTR = Intrinsics(525.0, 525.0, 319.5, 239.5, 640, 480)
GRAVITY = np.array([0.0, 1.0, 0.0])
BOXES = [(100.0, 150.0, 168.0, 334.0), (400.0, 150.0, 468.0, 334.0)]  # two people 5 m away (1.75 m over 184 px)


def _depth_note(depths: list[float]) -> str:
    """The fusion note of a photo whose depth map reads ``depths`` [m] over the two people (5 m each)."""
    values = np.full((480, 640), 20.0, dtype=np.float32)
    for (x1, y1, x2, y2), d in zip(BOXES, depths):
        values[int(y1):int(y2), int(x1):int(x2)] = d
    depth = DepthMap(values, "metric")
    ranger = Ranger(MapperConfig(ground_contact=False), default_catalog(), exact_depth=False)
    objects = [ranger.measure(Detection(b, 0.9, "person", "a person"), None, (480, 640, 3), INTR, GRAVITY, depth) for b in BOXES]
    scale = ranger.depth_scale(objects, depth)
    note, trusted = ranger.place_all(objects, scale, INTR)
    assert not trusted  # two references never make the map trusted
    return note


def _percent(note: str) -> float:
    return float(re.search(r"depth map (\d+)%", note).group(1)) / 100


def test_two_disagreeing_references_widen_the_depth_sigma_two_agreeing_keep_the_prior() -> None:
    agree = _depth_note([4.6, 4.65])  # the map reads both about 8 % short: one scale fits both
    disagree = _depth_note([4.6, 9.2])  # one reads twice as far as the other: no scale fits both
    assert "over 2 reference objects" in agree and "over 2 reference objects" in disagree
    assert 0.25 < _percent(agree) <= 0.31  # the 30 % prior, pooled with one degree of freedom
    assert _percent(disagree) > 0.35 and _percent(disagree) > _percent(agree) + 0.05  # spread 52 %, pooled
