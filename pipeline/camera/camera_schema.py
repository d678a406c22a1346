"""JSON Schema (draft 2020-12) of the camera file ``camera.toml`` (the TOML document as parsed: tables are objects).

Published as ``docs/schemas/camera.schema.json`` (``python -m console.schemas``); TOML has no schema language
of its own, and Taplo / Even Better TOML read JSON Schemas. :mod:`pipeline.camera.camera_file` reads the file
and checks what a schema cannot (the principal point inside the image, the field of view a focal length gives).

Sign conventions of the mount (robot body frame: x forward, y left, z up; the camera's rotation is
yaw about z, then pitch about the new y, then roll about the optical axis, intrinsic, as
:class:`pipeline.camera.geometry.CameraMount`): ``pitch_deg`` > 0 tilts the optical axis DOWN;
``yaw_deg`` > 0 turns it to the LEFT; ``roll_deg`` > 0 rolls the camera clockwise as seen from behind it (its
right side goes down, so a level horizon rises towards the right of the photo).
"""

from __future__ import annotations

from typing import Any

MAX_SIDE = 8000  # as pipeline.camera.camera_file.MAX_SIDE (tests check they agree)

_SIDE = {"type": "integer", "minimum": 1, "maximum": MAX_SIDE}
_FOCAL = {"type": "number", "exclusiveMinimum": 0}

CAMERA_SCHEMA: dict[str, Any] = {
    "$schema": "https://json-schema.org/draft/2020-12/schema",
    "$id": "https://morphonavi.example/schemas/camera.schema.json",
    "title": "MorphoNavi camera file (camera.toml)",
    "description": "Pinhole intrinsics of the upright image (EXIF orientation applied) and, optionally, where the "
                   "camera sits on the robot. Pixels, metres, degrees.",
    "type": "object",
    "required": ["intrinsics"],
    "additionalProperties": False,
    "properties": {
        "intrinsics": {
            "type": "object",
            "required": ["fx", "fy", "cx", "cy", "width", "height"],
            "additionalProperties": False,
            "properties": {
                "fx": {**_FOCAL, "description": "focal length along x [px]"},
                "fy": {**_FOCAL, "description": "focal length along y [px]"},
                "cx": {"type": "number", "description": "principal point x [px], inside the image"},
                "cy": {"type": "number", "description": "principal point y [px], inside the image"},
                "width": {**_SIDE, "description": "image width the intrinsics are for [px]"},
                "height": {**_SIDE, "description": "image height the intrinsics are for [px]"},
                "dist": {"type": "array", "items": {"type": "number", "minimum": -1000, "maximum": 1000},
                         "enum_counts": [0, 4, 5, 8, 12, 14],
                         "description": "OpenCV distortion coefficients (k1, k2, p1, p2[, k3[, k4, k5, k6[, s1, s2, "
                                        "s3, s4[, tx, ty]]]]): 0, 4, 5, 8, 12 or 14 of them"},
            },
        },
        "mount": {
            "type": "object",
            "additionalProperties": False,
            "description": "the camera on the robot, in the robot body frame (x forward, y left, z up)",
            "properties": {
                "position": {"type": "array", "items": {"type": "number", "minimum": -10, "maximum": 10},
                             "minItems": 3, "maxItems": 3, "description": "camera centre [x, y, z] [m]"},
                "pitch_deg": {"type": "number", "minimum": -90, "maximum": 90,
                              "description": "tilt of the optical axis [deg]; positive looks DOWN"},
                "yaw_deg": {"type": "number", "minimum": -180, "maximum": 180,
                            "description": "heading of the optical axis [deg]; positive turns it LEFT"},
                "roll_deg": {"type": "number", "minimum": -180, "maximum": 180,
                             "description": "roll about the optical axis [deg]; positive rolls the camera clockwise "
                                            "seen from behind it (its right side goes down: a level horizon rises "
                                            "towards the right of the photo)"},
            },
        },
        "calibration": {"type": "object", "description": "informational, written by morphonavi calibrate"},
    },
}
"""The camera file's schema (the published ``docs/schemas/camera.schema.json``)."""

# "enum_counts" is not JSON Schema: the count rule is written as a oneOf of exact lengths instead.
_dist = CAMERA_SCHEMA["properties"]["intrinsics"]["properties"]["dist"]
_dist["oneOf"] = [{"minItems": n, "maxItems": n} for n in _dist.pop("enum_counts")]

__all__ = ["CAMERA_SCHEMA"]
