"""The recording's JSON channels carry typed JSON Schemas; the payloads the recorder makes validate against them."""

from __future__ import annotations

import json

import pytest
from jsonschema import Draft202012Validator

from console.recording import recording_schemas as rs
from console.recording.channel_schemas import CHANNEL_SCHEMAS, schema_bytes
from console.session.session_types import RobotSnapshot, RunStatus
from pipeline.camera.geometry import Pose
from pipeline.scene import Scene, SceneObject, scene_to_dict


@pytest.mark.parametrize("topic", sorted(rs.JSON_TOPICS))
def test_every_json_topic_has_a_typed_schema(topic: str) -> None:
    schema = json.loads(schema_bytes(topic))
    Draft202012Validator.check_schema(schema)
    assert schema["properties"] and schema["title"] == rs.JSON_TOPICS[topic]


def _valid(topic: str, data: object) -> None:
    errors = [e.message for e in Draft202012Validator(CHANNEL_SCHEMAS[topic]).iter_errors(data)]
    assert errors == []


def test_payloads_validate() -> None:
    snap = RobotSnapshot(pose=Pose.from_xyz_yaw(1.0, 2.0, 0.0, 0.5), mode="GUIDED", armed=True, battery=87.0)
    _valid(rs.ROBOT_STATE, json.loads(rs.json_bytes(rs.robot_json(snap))))
    _valid(rs.PROGRESS, rs.run_json(RunStatus(state="running", segment=1, fraction=0.4, message="walking")))
    _valid(rs.SCENE_JSON, scene_to_dict(Scene((SceneObject("a", "chair", (1, 1, 0.4), (0.5, 0.8, 0.5)),))))
    bad = rs.run_json(RunStatus(state="running", segment=1, fraction=0.4, message="walking"))
    bad["fraction"] = "half"
    assert list(Draft202012Validator(CHANNEL_SCHEMAS[rs.PROGRESS]).iter_errors(bad))
