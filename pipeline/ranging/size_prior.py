"""The size-prior cue: how far an object is from its class's size distribution, with its sigma.

A catalog class has a typical size ``(w, h, l)`` [m] and a relative spread ``(s_w, s_h, s_l)`` (1-sigma
of real instances around it: people vary little, cabinets and tables a lot; ``assets/catalog.toml``).
An object of height ``h`` seen ``h_px`` tall is at ``z = f h / h_px``, so a relative size error is the
same relative distance error:

- box top and bottom not cut (the height is measured): ``sigma_z / z = sqrt(s_h^2 + (sigma_px / h_px)^2)``;
- otherwise the width across the image is used. Its expected value under an unknown yaw is
  ``E = 2 (w + l) / pi`` and its spread over yaws ``var = (w^2 + l^2) / 2 + 2 w l / pi - E^2``
  (:func:`horizontal_extent_stats`), to which the sizes' own spread adds:
  ``sigma_z / z = sqrt(var / E^2 + s_wl^2 + (sigma_px / w_px)^2)``;
- the 3D box fit's spread over the yaws that fit (``BoxFit.yaw_spread`` [m]) adds in quadrature.

Camera frame (OpenCV, z forward); distances are optical-axis depths of the centre [m].
"""

from __future__ import annotations

import math
from typing import Sequence

from pipeline.ranging.distance import Box, DistanceError, Truncation, check_box
from pipeline.ranging.fusion import Cue
from pipeline.ranging.placement import GeometricEstimate

DEFAULT_SPREAD = (0.2, 0.2, 0.2)
"""Relative size spread ``(w, h, l)`` of a class whose catalog entry gives none."""


def horizontal_extent_stats(width_m: float, length_m: float) -> tuple[float, float]:
    """Mean and standard deviation [m] of ``w |cos a| + l |sin a|`` (a footprint's extent across the
    view) for a yaw ``a`` uniform on the circle: ``E = 2 (w + l) / pi``,
    ``E[x^2] = (w^2 + l^2) / 2 + 2 w l / pi``."""
    w, l = float(width_m), float(length_m)
    if not (math.isfinite(w) and math.isfinite(l) and w > 0 and l > 0):
        raise DistanceError(f"footprint must be two numbers > 0 [m], got {width_m!r}, {length_m!r}")
    mean = 2.0 * (w + l) / math.pi
    second = (w * w + l * l) / 2.0 + 2.0 * w * l / math.pi
    return mean, math.sqrt(max(second - mean * mean, 0.0))


def half_depth_stats(size_whl: Sequence[float], spread_whl: Sequence[float]) -> tuple[float, float]:
    """Mean and 1-sigma [m] of the distance from a footprint's nearest point to its centre along the
    view (half the footprint's extent along the view, unknown yaw), including the size spread."""
    w, _, l = (float(v) for v in size_whl)
    sw, _, sl = (float(v) for v in spread_whl)
    mean, sd = horizontal_extent_stats(w, l)
    size_sd = math.hypot(sw * w, sl * l) / math.pi  # d(mean)/dw = 2 / pi, halved
    return mean / 2.0, math.hypot(sd / 2.0, size_sd)


def check_spread(spread: Sequence[float], where: str = "spread") -> tuple[float, float, float]:
    """``spread`` as three finite relative sigmas in ``[0, 2]``; :class:`DistanceError` naming ``where``."""
    try:
        vals = tuple(float(v) for v in spread)
    except (TypeError, ValueError):
        raise DistanceError(f"{where}: must be 3 numbers (w, h, l), got {spread!r}") from None
    if len(vals) != 3 or not all(math.isfinite(v) and 0 <= v <= 2 for v in vals):
        raise DistanceError(f"{where}: must be 3 relative sigmas within 0..2, got {spread!r}")
    return vals  # type: ignore[return-value]


def size_prior_cue(
    estimate: GeometricEstimate,
    box: Box,
    trunc: Truncation,
    size_whl: Sequence[float],
    spread_whl: Sequence[float],
    sigma_px: float = 1.5,
    focal: tuple[float, float] | None = None,
) -> Cue:
    """The size prior's distance (the estimate's centre depth [m]) with its sigma (module docstring).

    Args:
        estimate: The centre from the known size (:func:`pipeline.ranging.placement.geometric_estimate`).
        box: The 2D box [px].
        trunc: Which sides the border cuts (decides which dimension was measured).
        size_whl: The class's typical size [m].
        spread_whl: Its relative spread (1-sigma).
        sigma_px: Box edge 1-sigma [px] (at least; 2 % of the measured dimension when larger).
        focal: ``(fx, fy)`` [px]: check a whole box's aspect against the class (:func:`too_wide`); an
            implausibly wide one adds ``ln k`` to the relative sigma and says why in the note.
    """
    x1, y1, x2, y2 = check_box(box)
    w, h, l = (float(v) for v in size_whl)
    sw, sh, sl = check_spread(spread_whl)
    z = float(estimate.center[2])
    if not (math.isfinite(z) and z > 0):
        raise DistanceError(f"estimate.center: depth must be > 0 [m], got {z!r}")
    why: list[str] = []
    if not trunc.vertical_cut:
        px = y2 - y1
        rel = math.hypot(sh, max(sigma_px, 0.02 * px) / px)
        how = f"height {h:.2f} m +-{sh:.0%} over {px:.0f} px"
    else:
        cut = " and ".join(s for s, c in (("top", trunc.top), ("bottom", trunc.bottom)) if c)
        why.append(f"{cut} cut by the image border: its width across the view used, not its height")
        px = x2 - x1
        mean, sd = horizontal_extent_stats(w, l)
        s_wl = math.hypot(sw * w, sl * l) * 2.0 / math.pi / mean
        rel = math.sqrt((sd / mean) ** 2 + s_wl**2 + (max(sigma_px, 0.02 * px) / px) ** 2)
        how = f"width across the view {mean:.2f} m +-{sd / mean:.0%} (yaw) +-{s_wl:.0%} (size) over {px:.0f} px"
    sigma = z * rel
    if estimate.fit is not None:
        sigma = math.hypot(sigma, estimate.fit.yaw_spread)
    if focal is not None and not trunc.vertical_cut and not trunc.horizontal_cut:
        k = too_wide(box, size_whl, spread_whl, focal)
        if k > 1.0:  # the box shows less of the height than the class has: down-weighted, not moved
            sigma = math.hypot(sigma, z * math.log(k))
            how += (f"; size prior down-weighted: the box is {k:.2f}x wider for its height than the class can look "
                    "(crouching, sitting, partly hidden or a box around more than the object)")
            why.append(f"box {k:.2f}x wider for its height than the class can look")
    return Cue("size_prior", z, sigma, how, "; ".join(why))


ASPECT_SIGMAS = 2.0
"""A box is implausibly wide when its width / height exceeds the widest view of the class (the footprint's
diagonal over the height) with both sizes this many spreads off in the widening direction."""


def too_wide(box: Box, size_whl: Sequence[float], spread_whl: Sequence[float], focal: tuple[float, float]) -> float:
    """How many times the box's aspect ``(w_px / fx) / (h_px / fy)`` exceeds the widest a ``size_whl`` object can
    look (``hypot(w, l) (1 + n s_wl) / (h (1 - n s_h))``, ``n`` = :data:`ASPECT_SIGMAS`); 1.0 when it does not
    (a box cut by the border is not judged: the caller passes only whole boxes)."""
    x1, y1, x2, y2 = check_box(box)
    w, h, l = (float(v) for v in size_whl)
    sw, sh, sl = check_spread(spread_whl)
    fx, fy = focal
    aspect = ((x2 - x1) / fx) / ((y2 - y1) / fy)
    widest = math.hypot(w, l) * (1 + ASPECT_SIGMAS * max(sw, sl)) / (h * max(1 - ASPECT_SIGMAS * sh, 0.2))
    return max(aspect / widest, 1.0)


__all__ = ["ASPECT_SIGMAS", "DEFAULT_SPREAD", "check_spread", "half_depth_stats", "horizontal_extent_stats", "size_prior_cue",
           "too_wide"]
