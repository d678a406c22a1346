"""Whether a set of calibration views can determine the intrinsics at all (pure computation).

Two properties of the views decide it, whatever OpenCV's fit reports:

- **Tilt diversity.** A board seen straight on (its normal along the optical axis) in every photo
  images as a scaled copy of itself: the focal length then trades off exactly with the distance
  (Zhang 2000, section 3.3), and the fit returns any focal length with a small, meaningless standard
  deviation. The board normals (board +z in the OpenCV camera frame: x right, y down, z forward) are
  estimated per view with :func:`cv2.solvePnP`; the largest angle between two of them is the *tilt
  spread* [deg]. Under :data:`MIN_TILT_SPREAD_DEG` the set is refused.
- **Border coverage.** Distortion (k1, k2, k3) and the principal point are only seen where the
  corners reach the image border. The image is cut into a 4 x 4 grid; its 12 outer cells are the
  border. No corner in any border cell (corners only in the image centre) is refused; fewer than
  :data:`WARN_BORDER_CELLS` is a warning.

The normals are judged with the principal point at the image centre and two focal lengths, the
smaller spread counting: the fit's fx clipped to a plausible range (:data:`JUDGE_FOCAL_RANGE` times the
image width) and a nominal :data:`NOMINAL_FOCAL` times the width. A straight-on board images as a
similarity, which every focal length explains with a zero tilt, while a fit that ran away (fx of tens of
thousands of pixels) would otherwise turn corner noise and lens distortion into tilts of 10 deg and more.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass
from typing import Sequence

import cv2
import numpy as np

MIN_TILT_SPREAD_DEG = 15.0
"""Least angle [deg] between the board normals of two views for the focal length to be observable."""

GRID = 4
"""The image is cut into GRID x GRID cells for the coverage figure; the outer ring is the border."""

BORDER_CELLS = 4 * GRID - 4
"""Number of border cells (12 for a 4 x 4 grid)."""

WARN_BORDER_CELLS = 6
"""Fewer border cells than this reached by any corner is a warning (distortion poorly determined)."""

JUDGE_FOCAL_RANGE = (0.3, 1.5)
"""Focal length used to judge the tilts, as a fraction of the image width: the fit's fx clipped to
this range (horizontal fields of view of about 37-118 deg)."""

NOMINAL_FOCAL = 0.8
"""The second focal length the tilts are judged with, times the image width (64 deg horizontal field)."""


@dataclass(frozen=True)
class Coverage:
    """How well a set of views covers the camera's parameters.

    Attributes:
        tilt_spread_deg: Largest angle between two views' board normals [deg].
        normals: Board normal of every view (OpenCV camera frame, unit vectors).
        border_cells: Border cells of the 4 x 4 grid reached by at least one corner (of 12).
        cells: Every cell reached, as ``(column, row)`` in 0..3.
        extent: ``(u_min, u_max, v_min, v_max)`` of all corners [px].
    """

    tilt_spread_deg: float
    normals: tuple[tuple[float, float, float], ...]
    border_cells: int
    cells: frozenset[tuple[int, int]]
    extent: tuple[float, float, float, float]

    @property
    def tilted_enough(self) -> bool:
        return self.tilt_spread_deg >= MIN_TILT_SPREAD_DEG

    @property
    def centre_only(self) -> bool:
        return self.border_cells == 0

    def tilt_problem(self) -> str:
        """Why the focal length is not observable and what to do ("" when the tilts are diverse)."""
        if self.tilted_enough:
            return ""
        return (f"the board faces the camera the same way in every photo (board normals within "
                f"{self.tilt_spread_deg:.1f} deg of each other; at least {MIN_TILT_SPREAD_DEG:.0f} deg needed): "
                "the focal length cannot be told from the distance. Tilt the board (or the camera) by 20-45 deg "
                "in different directions between photos: left, right, up and down")

    def border_problem(self, width: int, height: int) -> str:
        """Why distortion is not observable ("" when some corners reach the border)."""
        if not self.centre_only:
            return ""
        u0, u1, v0, v1 = self.extent
        return (f"the board was only seen in the image centre (corners within x {u0:.0f}..{u1:.0f} of {width} px, "
                f"y {v0:.0f}..{v1:.0f} of {height} px): distortion and the principal point are not determined. "
                "Take photos with the board near each edge and corner of the image")

    def border_warning(self, width: int, height: int) -> str:
        """A warning when the border is poorly covered ("" when well covered or refused anyway)."""
        if self.centre_only or self.border_cells >= WARN_BORDER_CELLS:
            return ""
        return (f"corners reach only {self.border_cells} of the {BORDER_CELLS} border cells of the image (4 x 4 grid; "
                f"{WARN_BORDER_CELLS} or more advised): distortion near the uncovered edges is extrapolated. "
                "Add photos with the board near the uncovered edges and corners")


def board_normals(obj_pts: Sequence[np.ndarray], img_pts: Sequence[np.ndarray], size: tuple[int, int],
                  fx: float | None = None) -> list[np.ndarray]:
    """Board normal (board +z) in the OpenCV camera frame for every view, unit vectors.

    ``fx`` [px] is the fit's focal length (clipped to :data:`JUDGE_FOCAL_RANGE`; ``None`` or not finite:
    the width). Views whose pose cannot be solved are left out."""
    w, h = size
    lo, hi = JUDGE_FOCAL_RANGE[0] * w, JUDGE_FOCAL_RANGE[1] * w
    f = float(fx) if fx is not None and math.isfinite(fx) and fx > 0 else float(w)
    f = min(max(f, lo), hi)
    K = np.array([[f, 0.0, w / 2.0], [0.0, f, h / 2.0], [0.0, 0.0, 1.0]])
    out: list[np.ndarray] = []
    for obj, img in zip(obj_pts, img_pts):
        ok, rvec, _ = cv2.solvePnP(np.asarray(obj, np.float64).reshape(-1, 3), np.asarray(img, np.float64).reshape(-1, 2),
                                   K, None, flags=cv2.SOLVEPNP_ITERATIVE)
        if not ok:
            continue
        R, _ = cv2.Rodrigues(rvec)
        n = R[:, 2]
        out.append(n / np.linalg.norm(n))
    return out


def tilt_spread_deg(normals: Sequence[np.ndarray]) -> float:
    """Largest angle [deg] between two of the normals (0 for fewer than two)."""
    best = 0.0
    for a, b in itertools.combinations(normals, 2):
        # a normal and its opposite are the same plane seen from the same side: compare |cos|
        c = min(1.0, abs(float(np.dot(a, b))))
        best = max(best, math.degrees(math.acos(c)))
    return best


def coverage(obj_pts: Sequence[np.ndarray], img_pts: Sequence[np.ndarray], size: tuple[int, int],
             fx: float | None = None) -> Coverage:
    """Tilt spread and border coverage of the views (``size`` = (width, height) [px])."""
    w, h = size
    normals = board_normals(obj_pts, img_pts, size, fx)
    nominal = board_normals(obj_pts, img_pts, size, NOMINAL_FOCAL * w)
    if tilt_spread_deg(nominal) < tilt_spread_deg(normals):
        normals = nominal
    pts = np.vstack([np.asarray(p, np.float64).reshape(-1, 2) for p in img_pts]) if img_pts else np.zeros((0, 2))
    cols = np.clip((pts[:, 0] * GRID / w).astype(int), 0, GRID - 1)
    rows = np.clip((pts[:, 1] * GRID / h).astype(int), 0, GRID - 1)
    cells = frozenset(zip(cols.tolist(), rows.tolist()))
    border = sum(1 for c, r in cells if c in (0, GRID - 1) or r in (0, GRID - 1))
    extent = ((float(pts[:, 0].min()), float(pts[:, 0].max()), float(pts[:, 1].min()), float(pts[:, 1].max()))
              if len(pts) else (0.0, 0.0, 0.0, 0.0))
    return Coverage(tilt_spread_deg(normals), tuple(tuple(float(v) for v in n) for n in normals), border, cells,
                    extent)


__all__ = ["BORDER_CELLS", "Coverage", "MIN_TILT_SPREAD_DEG", "WARN_BORDER_CELLS", "board_normals", "coverage",
           "tilt_spread_deg"]
