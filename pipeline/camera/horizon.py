"""Where the horizon falls in the photo for a camera mount, and a warning when it falls outside.

A mount whose pitch or roll puts the horizon outside the photo means every pixel looks below it (the
camera sees only the floor near the robot) or above it (no floor at all). That is right for a camera
pointing at the floor, and a typo otherwise (``pitch_deg = 89.9`` for 8.9): objects are then placed
where the floor would be under such a camera, all within a metre or two of the robot. The warning
gives the numbers: the angle of the photo's edge to the horizon and, looking down, the farthest floor
point the photo can show (at the mount's height).

Frames: camera OpenCV (x right, y down, z forward); robot x forward, y left, z up.
"""

from __future__ import annotations

import math

import numpy as np

from pipeline.camera.geometry import CameraMount, Intrinsics


def horizon_check(intr: Intrinsics, mount: CameraMount) -> str | None:
    """``None`` when the horizon crosses the photo, else the warning in words with the numbers."""
    R = mount.pose.rotation.as_matrix()  # robot <- camera
    w, h = intr.width, intr.height
    corners = np.array([[0, 0], [w, 0], [0, h], [w, h], [w / 2, 0], [w / 2, h]], dtype=np.float64)
    rays = np.stack([(corners[:, 0] - intr.cx) / intr.fx, (corners[:, 1] - intr.cy) / intr.fy,
                     np.ones(len(corners))], axis=1)
    up = (rays @ R.T)[:, 2] / np.linalg.norm(rays, axis=1)  # sine of each edge ray's elevation
    elev = np.degrees(np.arcsin(np.clip(up, -1.0, 1.0)))
    pitch, roll = math.degrees(mount.pitch), math.degrees(mount.roll)
    given = f"mount.pitch_deg = {pitch:g}, roll_deg = {roll:g}"
    if elev.max() < 0:
        height = float(mount.position[2])
        far = height / math.tan(math.radians(-elev.max())) if height > 0 else float("nan")
        reach = f"; the farthest floor it can show is {far:.1f} m away at the mount's {height:.2f} m height" \
            if math.isfinite(far) else ""
        return (f"{given} puts the horizon above the photo: its highest ray looks {-elev.max():.1f} deg below "
                f"the horizon, so every object is placed on the floor near the robot{reach}; if the photo shows "
                "walls or the horizon, the pitch or roll is wrong (pitch_deg positive looks down)")
    if elev.min() > 0:
        return (f"{given} puts the horizon below the photo: its lowest ray looks {elev.min():.1f} deg above "
                "the horizon, so the photo shows no floor and ground contact cannot place anything; if the photo "
                "shows the floor, the pitch or roll is wrong (pitch_deg positive looks down)")
    return None


__all__ = ["horizon_check"]
