"""JSON Schema (draft 2020-12) of the scene file, version :data:`pipeline.scene_model.SCENE_VERSION`.

The scene file is what :func:`pipeline.scene.save_scene` writes (``morphonavi map --out``, the console's
watched folder). Published as ``docs/schemas/scene.schema.json`` (``python -m console.schemas``). Readers
accept what this schema describes; unknown keys are allowed (newer writers may add some).
"""

from __future__ import annotations

from typing import Any

from pipeline.scene_model import FRAMES, SCENE_VERSION

_NUM = {"type": "number"}


def _vec(n: int, description: str, item: dict[str, Any] | None = None) -> dict[str, Any]:
    return {"type": "array", "items": item or _NUM, "minItems": n, "maxItems": n, "description": description}


def _nullable(schema: dict[str, Any]) -> dict[str, Any]:
    return {"anyOf": [schema, {"type": "null"}], **({"description": schema["description"]}
                                                     if "description" in schema else {})}


SIZE_DESCRIPTION = ("full extents [w, h, l] of the object's box [m], each > 0: h the vertical extent, l the extent "
                    "along the heading (yaw), w the remaining horizontal extent")
YAW_DESCRIPTION = ("heading of the box's length axis [rad], counter-clockwise about the frame's vertical axis "
                   "(world / robot: +z; camera: -y) from its x axis")
QUATERNION_DESCRIPTION = ("camera-to-world rotation as a unit quaternion in the order [x, y, z, w] (scalar last, "
                          "as scipy and ROS); camera frame OpenCV: x right, y down, z forward")

_SOURCE = {
    "type": "object",
    "description": "where the object came from and how its position was estimated",
    "properties": {
        "capture": _nullable({"type": "string", "minLength": 1, "description": "id of the capture it was mapped from"}),
        "method": {"type": "string", "minLength": 1,
                   "description": "fused, geometric, depth, manual, ground_truth or demo (default manual)"},
        "bbox": _vec(4, "2D box [x1, y1, x2, y2] [px] in the capture's image"),
        "mask_area": {"type": "number", "minimum": 0, "description": "segmentation mask area [px]"},
        "distances": {"type": "object", "additionalProperties": {"type": ["number", "null"]},
                      "description": "distance estimates along the optical axis [m] by cue "
                                     "(geometric, depth, fused, ground_contact ...)"},
        "positions": {"type": "object", "propertyNames": {"enum": list(FRAMES)},
                      "additionalProperties": _vec(3, "centre in that frame [m]"),
                      "description": "the object's centre in the other frames [m]"},
        "down_weighted": {
            "type": "array",
            "description": "why distance cues were trusted less than usual for this object (absent: none was)",
            "items": {"type": "object", "required": ["cue", "why"], "properties": {
                "cue": {"type": "string", "minLength": 1,
                        "description": "size_prior, ground_contact, depth, or fused (the fused sigma itself)"},
                "why": {"type": "string", "description": "a short phrase, e.g. 'box 1.40x wider for its height "
                                                         "than the class can look'"},
            }},
        },
    },
}

_SIGHTING = {
    "type": "object",
    "description": "one observation fused into the object (world frame)",
    "required": ["position", "yaw", "size", "sigma"],
    "properties": {
        "capture": {"type": ["string", "null"]},
        "position": _vec(3, "box centre [m]"),
        "yaw": {"type": "number", "description": YAW_DESCRIPTION},
        "size": _vec(3, SIZE_DESCRIPTION),
        "sigma": _vec(3, "1-sigma errors [along the camera ray [m], across it [m], yaw [rad]]"),
        "camera": _nullable(_vec(3, "camera centre at capture [m]")),
        "distance": {"type": ["number", "null"], "description": "camera-to-centre distance [m]"},
        "used": {"type": "boolean"},
        "note": {"type": "string"},
    },
}

_OBJECT = {
    "type": "object",
    "description": "an oriented box with a label",
    "required": ["id", "label", "position", "size"],
    "properties": {
        "id": {"type": "string", "minLength": 1, "description": "unique within the scene"},
        "label": {"type": "string", "minLength": 1, "description": "catalog class, e.g. office_chair"},
        "score": {"type": "number", "minimum": 0, "maximum": 1, "description": "detector confidence (default 1)"},
        "frame": {"enum": list(FRAMES), "description": "frame of position and yaw (default world): camera = OpenCV "
                                                      "(x right, y down, z forward); robot = x forward, y left, z up; "
                                                      "world = the console's frame, z up"},
        "position": _vec(3, "centre of the box [m] in frame"),
        "size": _vec(3, SIZE_DESCRIPTION, {"type": "number", "exclusiveMinimum": 0}),
        "yaw": {"type": "number", "description": YAW_DESCRIPTION},
        "size_known": {"type": "boolean", "description": "size from the catalog (true) or measured / guessed"},
        "source": _SOURCE,
        "pinned": {"type": "boolean", "description": "placed or confirmed by the operator: never moved by mapping"},
        "flags": {"type": "array", "items": {"type": "string"}, "description": "corrections made by the map fusion"},
        "sigma": {"type": "number", "description": "1-sigma of the centre along the camera ray [m]"},
        "cut": {"type": "array", "items": {"enum": ["left", "top", "right", "bottom"]},
                "description": "sides of the 2D box the image border cuts"},
        "history": {"type": "array", "items": _SIGHTING, "description": "observations fused into it, oldest first"},
    },
}

_CAPTURE = {
    "type": "object",
    "description": "one photo the scene was mapped from",
    "required": ["id"],
    "properties": {
        "id": {"type": "string", "minLength": 1},
        "timestamp": {"type": "number", "description": "capture time [s since the Unix epoch]"},
        "image": {"type": ["string", "null"], "description": "image file name, relative to the scene file"},
        "intrinsics": {"type": "object", "additionalProperties": _NUM,
                       "description": "fx, fy, cx, cy [px], width, height [px] (and distortion coefficients)"},
        "robot_pose": {"type": "object", "additionalProperties": _NUM,
                       "description": "robot pose in the world frame at capture: x, y, z [m], yaw [rad]"},
        "camera_position": _nullable(_vec(3, "camera centre in the world frame [m]")),
        "camera_quaternion": _nullable(_vec(4, QUATERNION_DESCRIPTION)),
        "timings": {"type": "object", "additionalProperties": _NUM, "description": "per-stage wall time [s]"},
        "models": {"type": "object", "additionalProperties": {"type": "string"}, "description": "models by stage"},
    },
}

SCENE_SCHEMA: dict[str, Any] = {
    "$schema": "https://json-schema.org/draft/2020-12/schema",
    "$id": "https://morphonavi.example/schemas/scene.schema.json",
    "title": f"MorphoNavi scene, version {SCENE_VERSION}",
    "description": "Objects (oriented boxes) and the captures they were mapped from. Units: metres, radians, "
                   "seconds. Object size order [w, h, l]; quaternion order [x, y, z, w].",
    "type": "object",
    "required": ["version"],
    "properties": {
        "version": {"type": "integer", "minimum": 1, "maximum": SCENE_VERSION,
                    "description": "format version; newer files are refused"},
        "units": {"type": "string"},
        "objects": {"type": "array", "items": _OBJECT},
        "captures": {"type": "array", "items": _CAPTURE},
        "last_ids": {"type": "object", "additionalProperties": {"type": "integer", "minimum": 0},
                     "description": "highest number each class's ids have had (cardboard_box-7: 7), kept after "
                                    "the object is merged or removed: new objects are numbered above it"},
    },
}
"""The scene file's schema (the published ``docs/schemas/scene.schema.json``)."""

__all__ = ["QUATERNION_DESCRIPTION", "SCENE_SCHEMA", "SIZE_DESCRIPTION", "YAW_DESCRIPTION"]
