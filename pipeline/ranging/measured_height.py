"""At least how tall a floor-standing object is: what the photo shows of it.

The catalog gives a class's typical height and spread; a real cabinet may be 1.9 m where the catalog
says 0.9 m, and a map that keeps 0.9 m lets the planner fly into it. Once the object's distance is
known (fused from the size prior, the floor contact and the depth map, :mod:`pipeline.ranging.ranger`), the
ray through its box's top edge gives the height of its top above the floor.

Camera frame (OpenCV: x right, y down, z forward) [m]; the floor is ``g . X = H`` (``g`` the unit
gravity-down vector, ``H`` the camera height above the floor, as in :mod:`pipeline.ranging.ground_contact`).

- The top edge of a box is the top of the object's *near* face when that top is above the camera
  (the ray climbs with distance), of its *far* face when below (the camera looks down onto the top).
  Either way it is the lower of the two heights the top-edge ray reaches at the near and the far face,
  ``h_top = min(h(d_c - a), h(d_c + a))``, with ``d_c`` the centre's horizontal distance and ``a`` the
  expected half depth of the footprint along the view.
- 1-sigma: a relative distance error ``s`` moves the height by ``|H - h_top| s`` (the ray's height
  changes linearly with distance); the box edge's pixel error adds ``sigma_px / f * d``.
- The border cuts the top: the object reaches at least ``h_top`` (a lower bound, itself uncertain).
  The height is the class prior (log-normal: the catalog height, the class spread) given that bound:
  the mean and sigma of the truncated log-normal (:func:`pipeline.ranging.fusion.soft_upper_bound` mirrored),
  so a 0.9 +- 50 % "cabinet" seen at least 1.65 m tall is expected about 2 m tall, and a bound below the
  catalog height changes little. The object stands on the floor: its centre is half that height up.
- The top is in view: the catalog height stays. Fusing ``h_top`` with it (inverse variance, with or
  without a 2-3 sigma consistency gate) was measured on ``../shared/bench/dev`` with dataset boxes and
  made the centres worse (median 5.9 % -> 6.3-6.6 %): the datasets' boxes are loose or projected 3D
  boxes, and the footprint's depth along the view is unknown, so an uncut top edge is a noisy height.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Sequence

import numpy as np

from pipeline.ranging.distance import DistanceError
from pipeline.ranging.fusion import soft_upper_bound
from pipeline.camera.geometry import Intrinsics


@dataclass(frozen=True)
class HeightEstimate:
    """An object's height [m] and how it was obtained.

    Attributes:
        height: The height to use [m].
        sigma: Its 1-sigma [m].
        top: The top-edge reading ``h_top`` [m] (``None``: the ray does not give one).
        how: ``catalog`` or ``at_least_visible`` (cut top, the bound raised the height by over 1 %).
    """

    height: float
    sigma: float
    top: float | None
    how: str


def _ray_height(r: np.ndarray, g: np.ndarray, H: float, dist: float) -> float:
    """Height above the floor [m] of the point of ray ``r`` at horizontal distance ``dist`` [m]."""
    horiz = float(np.linalg.norm(r - float(r @ g) * g))
    t = dist / horiz
    return H - t * float(r @ g)


def top_height(top_row: float, u: float, centre_cam: Sequence[float], half_depth: float, intr: Intrinsics,
               gravity_cam: Sequence[float], camera_height: float) -> float | None:
    """``h_top`` [m] (module docstring) for the top-edge pixel ``(u, top_row)``; ``None`` when the
    centre is not in front of the camera horizontally or the half depth is not below its distance."""
    g = np.asarray(gravity_cam, dtype=np.float64)
    c = np.asarray(centre_cam, dtype=np.float64)
    d_c = float(np.linalg.norm(c - float(c @ g) * g))
    if not (math.isfinite(d_c) and d_c > 0 and 0 <= half_depth < d_c):
        return None
    p = intr.undistort_pixels(np.array([u, top_row], dtype=np.float64))[0]
    r = np.array([(p[0] - intr.cx) / intr.fx, (p[1] - intr.cy) / intr.fy, 1.0])
    return min(_ray_height(r, g, camera_height, d_c - half_depth), _ray_height(r, g, camera_height, d_c + half_depth))


def estimate_height(
    box: Sequence[float],
    top_cut: bool,
    centre_cam: Sequence[float],
    rel_sigma: float,
    half_depth: float,
    catalog_height: float,
    spread_h: float,
    intr: Intrinsics,
    gravity_cam: Sequence[float],
    camera_height: float,
    sigma_px: float = 1.5,
) -> HeightEstimate:
    """The height of a floor-standing object (module docstring).

    Args:
        box: Its 2D box ``(x1, y1, x2, y2)`` [px].
        top_cut: The image border cuts the box's top.
        centre_cam: Its centre (camera frame) [m], placed at the fused distance.
        rel_sigma: Relative 1-sigma of that distance.
        half_depth: Expected half depth of its footprint along the view [m].
        catalog_height: The class's typical height [m], > 0.
        spread_h: The class's relative height spread (1-sigma).
        intr: Camera intrinsics.
        gravity_cam: Unit gravity-down vector, camera frame.
        camera_height: Camera centre above the floor [m].
        sigma_px: The top edge's 1-sigma [px].

    Raises:
        DistanceError: A non-finite or non-positive height, spread or sigma.
    """
    for key, v in (("catalog_height", catalog_height), ("camera_height", camera_height)):
        if not (math.isfinite(v) and v > 0):
            raise DistanceError(f"{key}: must be a finite number > 0 [m], got {v!r}")
    for key, v in (("spread_h", spread_h), ("rel_sigma", rel_sigma), ("sigma_px", sigma_px)):
        if not (math.isfinite(v) and v >= 0):
            raise DistanceError(f"{key}: must be a finite number >= 0, got {v!r}")
    x1, y1, x2, _ = (float(v) for v in box)
    catalog = HeightEstimate(catalog_height, spread_h * catalog_height, None, "catalog")
    top = top_height(y1, 0.5 * (x1 + x2), centre_cam, half_depth, intr, gravity_cam, camera_height)
    if top is None or not top > 0:
        return catalog
    d = float(np.linalg.norm(np.asarray(centre_cam, dtype=np.float64)))
    # distance error, the footprint's unknown depth (near or far face: +-half_depth), the edge's pixels
    slope = abs(camera_height - top) / d
    sigma_top = math.sqrt((slope * d * rel_sigma) ** 2 + (slope * half_depth) ** 2 + (sigma_px / intr.fy * d) ** 2)
    if not top_cut:
        return HeightEstimate(catalog_height, catalog.sigma, top, "catalog")
    # log-normal class prior given "at least the visible height": the mirror image of an upper bound
    neg_mean, sd = soft_upper_bound(-math.log(catalog_height), max(spread_h, 1e-3), -math.log(top),
                                    sigma_top / top)
    h = math.exp(-neg_mean)
    return HeightEstimate(h, h * sd, top, "at_least_visible" if h > catalog_height * 1.01 else "catalog")


__all__ = ["HeightEstimate", "estimate_height", "top_height"]
