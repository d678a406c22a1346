"""The shipped Foxglove layout (docs/foxglove-layout.json) names panels that exist and topics / fields a recording has."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any, Iterator

from console.recording import recording_schemas as rs
from console.recording.channel_schemas import CHANNEL_SCHEMAS

LAYOUT = Path(__file__).resolve().parents[3] / "docs" / "foxglove-layout.json"


def _leaves(node: Any) -> Iterator[str]:
    if isinstance(node, str):
        yield node
    else:
        yield from _leaves(node["first"])
        yield from _leaves(node["second"])


def test_the_layout_shows_the_3d_scene_the_photo_and_plots() -> None:
    layout = json.loads(LAYOUT.read_text(encoding="utf-8"))
    panels = list(_leaves(layout["layout"]))
    assert sorted(panels) == sorted(layout["configById"])
    kinds = {p.split("!")[0] for p in panels}
    assert {"3D", "Image", "Plot"} <= kinds
    recorded = set(rs.FOXGLOVE_TYPES) | set(rs.JSON_TOPICS)
    config = layout["configById"]
    assert set(config["3D!morphonavi"]["topics"]) <= recorded
    assert config["Image!photo"]["imageMode"]["imageTopic"] == rs.IMAGE
    assert config["Image!photo"]["imageMode"]["calibrationTopic"] == rs.CALIBRATION
    for panel in (p for p in panels if p.startswith("Plot!")):
        for path in config[panel]["paths"]:
            topic, _, field = path["value"].partition(".")
            assert topic in recorded, path
            if topic in rs.JSON_TOPICS:  # a JSON channel: the field is typed in its schema, so Foxglove can plot it
                assert field in CHANNEL_SCHEMAS[topic]["properties"], path
