"""Sanity check of the camera pose from where one photo's objects land against the floor.

Objects of known size stand on the floor (or on furniture): none can be under it, and a photo
whose every object floats clearly above it is unlikely. Both happen when the camera pose used for
the photo is wrong: a camera mounted higher, lower, or tilted differently from what the camera
file (``[mount]`` ``position`` z, ``pitch_deg``) or the photo's ``camera_height`` / ``gravity_cam``
says. :func:`floor_check` returns warnings naming that likely cause; it never changes the scene.

World frame, z up, the floor at ``floor_z`` [m] (the planner's ground, z = 0 by default).
"""

from __future__ import annotations

import math
import statistics
from typing import Sequence

import numpy as np
from scipy.spatial.transform import Rotation

from pipeline.scene import Capture, Scene, SceneObject

UNDER_LIMIT = 0.15
"""The photo's ground level this far [m] under the floor is reported (mapping noise stays within it)."""
FLOAT_LIMIT = 0.2
"""The photo's ground level this high [m] over the floor is reported."""
FEW = 4
"""With fewer known-size objects, the lowest one is the ground level (and must be clearly off)."""

CAUSE = ("the camera pose used for this photo is probably wrong: check the camera's mount height and pitch "
         "(camera.toml [mount] position z and pitch_deg, or the photo's camera_height and gravity_cam)")


RESTS_ON = 0.1
"""An object whose bottom is this close [m] to another's top, over its footprint, stands on it."""


def _bottoms(objects: Sequence[SceneObject], floor_z: float) -> list[tuple[str, float]]:
    return [(o.label, float(o.position[2]) - float(o.size[1]) / 2.0 - floor_z)
            for o in objects if o.frame == "world" and o.size_known]


def _rests_on_another(o: SceneObject, others: Sequence[SceneObject]) -> bool:
    """Whether ``o``'s bottom sits on the top of another object of the photo (a stacked box, a cup on a desk),
    or above one cut by the image's bottom border (whose top is then as uncertain as its bottom)."""
    bottom = float(o.position[2]) - float(o.size[1]) / 2.0
    for b in others:
        if b is o or b.frame != "world":
            continue
        top = float(b.position[2]) + float(b.size[1]) / 2.0
        reach = max(float(b.size[0]), float(b.size[2])) / 2.0  # footprint radius, any yaw
        if math.hypot(o.position[0] - b.position[0], o.position[1] - b.position[1]) > reach:
            continue
        # on its top, or above one whose lower part the image border hides (its top is uncertain too)
        if abs(bottom - top) <= RESTS_ON or ("bottom" in b.cut and bottom >= float(b.position[2])):
            return True
    return False


def _blocks(b: SceneObject, start: np.ndarray, end: np.ndarray) -> bool:
    """Whether the segment ``start -> end`` (world [m]) passes through ``b``'s box (slab test in the box's
    frame: ``l`` along its yaw, ``w`` across, ``h`` up; :func:`pipeline.mapping.map_support.footprint`)."""
    c, s = math.cos(b.yaw), math.sin(b.yaw)
    to_box = np.array([[c, s, 0.0], [-s, c, 0.0], [0.0, 0.0, 1.0]])
    p0 = to_box @ (start - np.asarray(b.position, dtype=np.float64))
    d = to_box @ (end - start)
    half = np.array([b.size[2], b.size[0], b.size[1]], dtype=np.float64) / 2.0
    lo, hi = 0.0, 1.0
    for k in range(3):
        if abs(d[k]) < 1e-12:
            if abs(p0[k]) > half[k]:
                return False
            continue
        t0, t1 = sorted(((-half[k] - p0[k]) / d[k], (half[k] - p0[k]) / d[k]))
        lo, hi = max(lo, t0), min(hi, t1)
        if lo > hi:
            return False
    return True


def _floor_in_view(o: SceneObject, captures: Sequence[Capture], floor_z: float,
                   others: Sequence[SceneObject] = ()) -> bool:
    """Whether the floor under ``o`` (its footprint centre at ``floor_z``) is seen by its capture: inside
    the image and not behind another of ``others`` (the photo's objects). When it is not (below the
    image's bottom border, or behind a desk in front, as for a camera in the air looking over the room),
    whatever carries ``o`` may be out of view, and its bottom proves nothing about the pose.
    ``True`` when the capture's pose or intrinsics are unknown (the object is then judged as before).

    The capture's camera pose is ``world <- camera`` (camera in the OpenCV optical frame, z forward).
    """
    cap = next((c for c in captures if c.id == o.source.capture), captures[0] if len(captures) == 1 else None)
    need = ("fx", "fy", "cx", "cy", "width", "height")
    if cap is None or cap.camera_position is None or cap.camera_quaternion is None \
            or not all(k in cap.intrinsics for k in need):
        return True
    floor = np.array([o.position[0], o.position[1], floor_z], dtype=np.float64)
    eye = np.asarray(cap.camera_position, dtype=np.float64)
    p = Rotation.from_quat(cap.camera_quaternion).as_matrix().T @ (floor - eye)
    if p[2] <= 1e-6:
        return False
    k = cap.intrinsics
    u, v = k["fx"] * p[0] / p[2] + k["cx"], k["fy"] * p[1] / p[2] + k["cy"]
    if not (0.0 <= u < k["width"] and 0.0 <= v < k["height"]):
        return False
    return not any(b is not o and b.frame == "world" and _blocks(b, eye, floor) for b in others)


def _floor_evidence(objects: Sequence[SceneObject], captures: Sequence[Capture] = (),
                    floor_z: float = 0.0) -> list[SceneObject]:
    """The objects whose box bottom can show a floating photo: whole in the image (a box cut by the
    border is placed from part of itself), standing on nothing else of the photo (the upper boxes
    of a stack seen from the air float rightly) and with the floor under them seen (from the air the
    floor near the robot is under the image, or behind the furniture in front: a box on a hidden
    support floats there rightly)."""
    world = [o for o in objects if o.frame == "world"]
    return [o for o in world if not o.cut and not _rests_on_another(o, world)
            and (not captures or _floor_in_view(o, captures, floor_z, world))]


def floor_check(scene: Scene, floor_z: float = 0.0, *, under_limit: float = UNDER_LIMIT,
                float_limit: float = FLOAT_LIMIT) -> list[str]:
    """Warnings (empty when plausible) when the photo's objects stand under the floor or float over it.

    The photo's *ground level* is the lower quartile of its known-size objects' box bottoms (the
    lowest objects of a room stand on the floor; single objects cut by the image border or hidden
    behind others land off it by up to ~0.2 m even with the right pose, and a misdetection of the
    wrong class (a 1.8 m "refrigerator" on a small purple toy) lands wherever its wrong size puts it,
    so one object proves nothing); with fewer than :data:`FEW` objects it is the second lowest bottom
    (a photo of one object is not judged), with 1.5x the limits.
    Floating is judged only on objects the image border does not cut, that stand on no other
    object of the photo and whose floor (the floor point under the footprint centre) is seen at the
    capture's own camera pose (inside the image, behind no other object of the photo), so a photo from the air of the upper boxes of a stack (their lower
    boxes hidden, the floor under them below the image) is not flagged.

    A capture whose given camera pose the mapper found at odds with the photo's floor (its
    ``models["camera_pose_warning"]``, naming the fitted and given pitch and height) gives that warning first.

    Args:
        scene: One photo's objects in the world frame (known-size objects are judged).
        floor_z: Height of the floor in the world frame [m].
        under_limit: Ground level this far under the floor [m] is reported.
        float_limit: Ground level this far over the floor [m] is reported (two or more objects).
    """
    # the mapper's own check of a given pose against the photo's floor (pipeline.ranging.photo_floor)
    fitted = [str(c.models["camera_pose_warning"]) for c in scene.captures if c.models.get("camera_pose_warning")]
    return fitted + _landing_check(scene, floor_z, under_limit, float_limit)


def _landing_check(scene: Scene, floor_z: float, under_limit: float, float_limit: float) -> list[str]:
    bottoms = _bottoms(scene.objects, floor_z)
    if not bottoms:
        return []
    values = sorted(b for _, b in bottoms)
    if len(values) >= FEW:
        ground = float(statistics.quantiles(values, n=4, method="inclusive")[0])
        what = "the lower quartile of the box bottoms"
        under_at, float_at = under_limit, float_limit
    else:  # the second lowest: one object alone (a misdetection's wrong size) proves nothing
        ground = values[1] if len(values) >= 2 else 0.0
        what = "the second lowest box bottom"
        under_at, float_at = 1.5 * under_limit, 1.5 * float_limit
    if ground < -under_at:
        under = sorted((b, label) for label, b in bottoms if b < -under_at)
        named = ", ".join(f"{label} {b:+.2f} m" for b, label in under[:4])
        return [f"objects land under the floor ({what} is {-ground:.2f} m under it; {named}): {CAUSE}"]
    evidence = sorted(b for _, b in _bottoms(_floor_evidence(scene.objects, scene.captures, floor_z), floor_z))
    if len(evidence) >= FEW:
        ground = float(statistics.quantiles(evidence, n=4, method="inclusive")[0])
        what, float_at = "the lower quartile of the box bottoms", float_limit
    elif evidence:
        ground, what, float_at = evidence[0], "the lowest box bottom", 1.5 * float_limit
    if len(evidence) >= 2 and ground > float_at:
        return [f"objects float over the floor ({what} is {ground:.2f} m over it, none stands on it): {CAUSE}"]
    return []


__all__ = ["CAUSE", "floor_check"]
