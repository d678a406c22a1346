"""Does a capture agree with the map at all? (another room, a wrong robot pose)

Pure functions: the map's objects a capture's camera should see (world frame [m]; the camera pose
of :class:`~pipeline.scene.Capture` is ``world <- camera``, camera in the OpenCV optical frame) and
the verdict of :func:`disagreement` on how many of the capture's observations found their object.
"""

from __future__ import annotations

from typing import Sequence

import numpy as np
from scipy.spatial.transform import Rotation

from pipeline.scene import Capture, SceneObject

MAX_VIEW_RANGE = 6.0
"""Map objects farther than this from the camera [m] are not expected to be seen."""

MIN_EXPECTED = 3
"""The check needs at least this many map objects in view and observations."""

MIN_AGREEING = 0.25
"""A capture where fewer than this fraction of the comparable objects agree is held back."""


def expected_in_view(objects: Sequence[SceneObject], capture: Capture, near: float = 0.3,
                     far: float = MAX_VIEW_RANGE) -> list[SceneObject]:
    """The map objects whose centre projects inside the capture's image at ``near..far`` [m]."""
    intr = capture.intrinsics
    need = ("fx", "fy", "cx", "cy", "width", "height")
    if capture.camera_position is None or capture.camera_quaternion is None or not all(k in intr for k in need):
        return []
    r_world_cam = Rotation.from_quat(capture.camera_quaternion).as_matrix()
    t = np.asarray(capture.camera_position, dtype=np.float64)
    out = []
    for o in objects:
        p = r_world_cam.T @ (np.asarray(o.position, dtype=np.float64) - t)
        if not near <= p[2] <= far:
            continue
        u = intr["fx"] * p[0] / p[2] + intr["cx"]
        v = intr["fy"] * p[1] / p[2] + intr["cy"]
        if 0 <= u < intr["width"] and 0 <= v < intr["height"]:
            out.append(o)
    return out


def disagreement(n_observations: int, n_expected: int, n_agreeing: int) -> str | None:
    """Why the capture should be held back (``None``: merge it).

    Args:
        n_observations: Usable observations of the capture.
        n_expected: Map objects its camera should see.
        n_agreeing: Observations associated with a map object.
    """
    if n_observations < MIN_EXPECTED or n_expected < MIN_EXPECTED:
        return None
    comparable = min(n_observations, n_expected)
    if n_agreeing >= MIN_AGREEING * comparable:
        return None
    return (f"only {n_agreeing} of its {n_observations} objects match the map, which expects {n_expected} objects "
            f"in this view: another room, or a wrong robot pose?")
