"""How much a size-prior distance owes to a gravity direction that is itself uncertain.

The 3D box fit (:func:`pipeline.ranging.placement.geometric_estimate`) stands the class's box upright
under the camera's gravity. When that gravity was fitted from the photo (no camera pose given, or a
given pose widened by its disagreement with the photo; :mod:`pipeline.ranging.photo_floor`), its pitch
and roll carry the floor fit's sigmas (:class:`pipeline.camera.floor_fit.FloorEstimate`), and a box fit
under a gravity a few degrees off puts the centre at another depth (most for boxes the border cuts and
boxes seen from above). :func:`gravity_sigma_z` refits the box under gravity tilted by plus and minus
one sigma of pitch and of roll and returns the resulting 1-sigma of the centre's depth; the size-prior
cue adds it in quadrature (:func:`widen_for_gravity`).

Camera frame (OpenCV: x right, y down, z forward); depths are optical-axis depths [m]; angles [rad].
"""

from __future__ import annotations

import dataclasses
import math
from typing import Sequence

from pipeline.camera.floor_fit import FloorEstimate, rotate_gravity
from pipeline.camera.geometry import Intrinsics
from pipeline.ranging.distance import Box, Truncation
from pipeline.ranging.fusion import Cue
from pipeline.ranging.placement import geometric_estimate


def gravity_sigma_z(box: Box, size_whl: Sequence[float], intr: Intrinsics, trunc: Truncation,
                    gravity_cam: Sequence[float], floor: FloorEstimate, method: str = "box_fit",
                    **fit_options: object) -> float:
    """1-sigma [m] of the size prior's centre depth caused by the floor's pitch and roll sigmas (central
    differences at +-1 sigma about ``gravity_cam``, the gravity the box was fitted under; 0 when a tilted
    fit fails or the method does not use gravity)."""
    if method != "box_fit":
        return 0.0
    g = gravity_cam
    var = 0.0
    for d_pitch, d_roll in ((floor.sigma_pitch, 0.0), (0.0, floor.sigma_roll)):
        zs = []
        for sign in (1.0, -1.0):
            est = geometric_estimate(box, size_whl, intr, trunc, tuple(rotate_gravity(g, sign * d_pitch, sign * d_roll)),
                                     method, **fit_options)
            if est is None or not math.isfinite(float(est.center[2])):
                return 0.0
            zs.append(float(est.center[2]))
        var += (0.5 * (zs[0] - zs[1])) ** 2
    return math.sqrt(var)


def widen_for_gravity(cue: Cue, sigma_z: float) -> Cue:
    """``cue`` (the size prior) with ``sigma_z`` [m] added in quadrature, said in its note."""
    if not (math.isfinite(sigma_z) and sigma_z > 0):
        return cue
    return dataclasses.replace(cue, sigma=math.hypot(cue.sigma, sigma_z),
                               note=f"{cue.note}; +-{sigma_z:.2f} m from the fitted gravity's pitch and roll")


__all__ = ["gravity_sigma_z", "widen_for_gravity"]
