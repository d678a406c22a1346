"""An assumed camera for photos without a calibration, with its uncertainty, flagged as assumed.

When no camera file is given (``morphonavi map PHOTO`` without ``--camera-file``), the intrinsics are
assumed, in this order of preference:

1. ``--fov DEG``: the horizontal field of view the user states -> ``fx = (W / 2) / tan(fov / 2)``,
   taken as uncertain by +-10 % (a stated, not measured, field of view);
2. the photo's EXIF ``FocalLengthIn35mmFilm`` (phones and most cameras write it) -> ``fx = f35 *
   diagonal_px / 43.27 mm`` (the 35 mm frame's diagonal, CIPA DC-008), uncertain by +-5 % (the tag
   is rounded to whole millimetres and some makers compute it over the width instead of the diagonal);
3. otherwise a typical phone / webcam lens, :data:`DEFAULT_HFOV_DEG` = 65 deg horizontal, uncertain by
   +-30 % (real lenses span about 50-80 deg).

Always: principal point at the image centre, square pixels, no distortion. Distances from the size
prior scale with ``fx``, so they carry the same relative uncertainty. The result says how it was
made (:attr:`AssumedCamera.how`) for the warning and the scene's capture record.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

from pipeline.camera.geometry import CameraError, Intrinsics
from pipeline.scene import Scene

DEFAULT_HFOV_DEG = 65.0
DEFAULT_SIGMA = 0.30
EXIF_SIGMA = 0.05
FOV_SIGMA = 0.10
FULL_FRAME_DIAGONAL_MM = 43.27
MAX_FOV_DEG = 170.0
"""Largest field of view [deg] an assumed camera may give either axis (a narrow strip of an image with a
normal horizontal field of view would otherwise get a near-180 deg vertical one, fx of a few pixels)."""


@dataclass(frozen=True)
class AssumedCamera:
    """Intrinsics assumed for an uncalibrated photo.

    Attributes:
        intrinsics: For the upright image [px].
        rel_sigma: Relative 1-sigma uncertainty of ``fx``/``fy`` and so of distances.
        how: How they were made, e.g. ``EXIF 35 mm focal length 26 mm``.
    """

    intrinsics: Intrinsics
    rel_sigma: float
    how: str

    @property
    def warning(self) -> str:
        i = self.intrinsics
        return (f"no camera file: intrinsics ASSUMED from {self.how}: fx = fy = {i.fx:.0f} px "
                f"({math.degrees(i.hfov):.0f} deg horizontal field of view), principal point at the centre, no "
                f"distortion; focal length and distances uncertain by +-{self.rel_sigma:.0%}. Calibrate the camera "
                "with `morphonavi calibrate` and pass --camera-file camera.toml")


def assumed_camera(width: int, height: int, *, hfov_deg: float | None = None,
                   focal_35mm: float | None = None) -> AssumedCamera:
    """The assumed camera of a ``width`` x ``height`` [px] upright photo (see the module docstring).

    Raises:
        CameraError: ``hfov_deg`` outside 1..179 deg or not finite (named ``--fov``), or a field of view
            over :data:`MAX_FOV_DEG` on the other (vertical) axis for this image size (named ``--fov``
            when stated, with the image size).
    """
    if hfov_deg is not None:
        if not (isinstance(hfov_deg, (int, float)) and math.isfinite(hfov_deg) and 1.0 <= hfov_deg <= 179.0):
            raise CameraError(f"--fov: the horizontal field of view must be within 1..179 deg, got {hfov_deg!r}")
        f, sigma, how = (width / 2.0) / math.tan(math.radians(hfov_deg) / 2.0), FOV_SIGMA, \
            f"the stated field of view {hfov_deg:g} deg"
    elif focal_35mm is not None:
        f = focal_35mm * math.hypot(width, height) / FULL_FRAME_DIAGONAL_MM
        sigma, how = EXIF_SIGMA, f"the photo's EXIF 35 mm equivalent focal length {focal_35mm:g} mm"
    else:
        f = (width / 2.0) / math.tan(math.radians(DEFAULT_HFOV_DEG) / 2.0)
        sigma, how = DEFAULT_SIGMA, f"a typical lens ({DEFAULT_HFOV_DEG:g} deg horizontal field of view)"
    vfov = math.degrees(2.0 * math.atan2(height / 2.0, f))
    if vfov > MAX_FOV_DEG:
        what = f"--fov {hfov_deg:g}" if hfov_deg is not None else f"the focal length assumed from {how}"
        raise CameraError(f"{what}: on this {width}x{height} px image fx = {f:.1f} px gives a {vfov:.1f} deg vertical "
                          f"field of view, over the limit of {MAX_FOV_DEG:g} deg (the image is far taller than "
                          "wide): give a camera file (--camera-file) or a smaller --fov for this image")
    return AssumedCamera(Intrinsics(f, f, width / 2.0, height / 2.0, int(width), int(height)), sigma, how)


def widen_sigmas(scene: Scene, rel: float) -> Scene:
    """``scene`` with each object's ``sigma`` [m] widened by a relative error ``rel`` common to every
    distance (an assumed focal length: ``sigma^2 + (rel * range)^2``, range from the camera-frame centre)."""
    if not (math.isfinite(rel) and rel >= 0):
        raise ValueError(f"rel: must be a finite number >= 0, got {rel!r}")
    out = []
    for o in scene.objects:
        cam = o.source.positions.get("camera")
        if o.sigma is None or cam is None:
            out.append(o)
            continue
        out.append(replace(o, sigma=math.hypot(o.sigma, rel * math.dist(cam, (0.0, 0.0, 0.0)))))
    return replace(scene, objects=tuple(out))


__all__ = ["AssumedCamera", "DEFAULT_HFOV_DEG", "assumed_camera", "widen_sigmas"]
