"""Camera calibration from photos of a chessboard or a ChArUco board (OpenCV), pure computation.

The result is the intrinsics (pinhole ``fx, fy, cx, cy`` [px] and OpenCV distortion ``k1, k2, p1, p2,
k3``) of the **upright** photos (EXIF orientation applied, see :mod:`pipeline.camera.image_io`), the RMS
reprojection error [px] and the error of every view. Refused with :class:`CalibrationError`: photos
of different sizes, fewer usable views than ``min_views``, and views that do not constrain the
camera: boards that face the camera the same way in every photo (board normals within
:data:`~pipeline.camera.calibration_coverage.MIN_TILT_SPREAD_DEG` of each other: the focal length trades
off with the distance), boards seen only in the image centre (no corner in the outer cells of a 4 x 4
grid: distortion and principal point undetermined), and a focal length whose standard deviation (OpenCV's
``calibrateCameraExtended``, judged at a corner noise of at least 0.1 px) exceeds ``max_focal_sigma`` of
its value. A border reached in few places is a warning (:attr:`Calibration.warnings`). Every parameter's
standard deviation is reported (:attr:`Calibration.sigmas`); see :mod:`pipeline.camera.calibration_coverage`.

Board geometry: ``cols`` x ``rows`` are the INNER corners of a chessboard (a board of 10 x 7 squares
has 9 x 6 inner corners), or the SQUARES of a ChArUco board; ``square`` is the side of one square
[m] (it scales the board poses only, not the intrinsics).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Sequence

import cv2
import numpy as np

from pipeline.camera.calibration_coverage import coverage
from pipeline.camera.geometry import Intrinsics

ARUCO_DICTIONARIES = ("DICT_4X4_50", "DICT_4X4_100", "DICT_5X5_50", "DICT_5X5_100", "DICT_6X6_250", "DICT_ARUCO_ORIGINAL")
"""ArUco dictionaries accepted for ChArUco boards (OpenCV names)."""


PARAMETERS = ("fx", "fy", "cx", "cy", "k1", "k2", "p1", "p2", "k3")
"""The intrinsics in the order of OpenCV's ``stdDeviationsIntrinsics``."""

NOISE_FLOOR_PX = 0.1
"""Corner noise [px] at which the focal length's uncertainty is judged (real corners: 0.05-0.3 px)."""


class CalibrationError(ValueError):
    """Calibration cannot give trustworthy intrinsics; the message says why and what to do."""


@dataclass(frozen=True)
class Board:
    """A calibration target.

    Attributes:
        kind: ``chessboard`` or ``charuco``.
        cols, rows: Inner corners (chessboard) or squares (ChArUco) along x and y.
        square: Side of one square [m].
        marker: Side of one ArUco marker [m] (ChArUco only).
        dictionary: ArUco dictionary name (ChArUco only), one of :data:`ARUCO_DICTIONARIES`.
    """

    kind: str = "chessboard"
    cols: int = 9
    rows: int = 6
    square: float = 0.025
    marker: float = 0.0
    dictionary: str = "DICT_5X5_100"

    def __post_init__(self) -> None:
        if self.kind not in ("chessboard", "charuco"):
            raise CalibrationError(f"board: kind must be 'chessboard' or 'charuco', got {self.kind!r}")
        least = 3 if self.kind == "chessboard" else 3
        for name in ("cols", "rows"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, int) or not least <= v <= 100:
                raise CalibrationError(f"board.{name}: must be a whole number within {least}..100, got {v!r}")
        if not (isinstance(self.square, (int, float)) and math.isfinite(self.square) and 0 < self.square <= 10):
            raise CalibrationError(f"board.square: must be within 0..10 m, got {self.square!r}")
        if self.kind == "charuco":
            if not (isinstance(self.marker, (int, float)) and math.isfinite(self.marker)
                    and 0 < self.marker < self.square):
                raise CalibrationError(f"board.marker: must be > 0 and smaller than the square ({self.square} m), "
                                       f"got {self.marker!r}")
            if self.dictionary not in ARUCO_DICTIONARIES:
                raise CalibrationError(f"board.dictionary: expected one of {', '.join(ARUCO_DICTIONARIES)}, "
                                       f"got {self.dictionary!r}")

    def charuco(self) -> "cv2.aruco.CharucoBoard":
        d = cv2.aruco.getPredefinedDictionary(getattr(cv2.aruco, self.dictionary))
        return cv2.aruco.CharucoBoard((self.cols, self.rows), float(self.square), float(self.marker), d)

    def object_points(self) -> np.ndarray:
        """Chessboard inner corners in the board frame (N x 3, z = 0) [m], in OpenCV's detection order."""
        grid = np.mgrid[0:self.cols, 0:self.rows].T.reshape(-1, 2).astype(np.float32)
        return np.hstack([grid * np.float32(self.square), np.zeros((len(grid), 1), np.float32)])


@dataclass(frozen=True)
class Calibration:
    """What calibration found.

    Attributes:
        intrinsics: Camera of the photos (upright image size) with distortion ``(k1, k2, p1, p2, k3)``.
        rms: RMS reprojection error over all used corners [px].
        per_view: ``(photo name, RMS error [px])`` of every used view.
        skipped: ``(photo name, reason)`` of every photo not used.
        focal_sigma: Standard deviation of ``fx`` and ``fy`` [px] (OpenCV's, at >= 0.1 px corner noise).
        sigmas: Standard deviation of every parameter at the same noise, by name (``fx fy cx cy`` [px],
            ``k1 k2 p1 p2 k3`` [-]).
        tilt_spread_deg: Largest angle between two views' board normals [deg].
        border_cells: Outer cells of a 4 x 4 image grid reached by a corner (of 12).
        warnings: What is poorly determined and what to do (printed by ``morphonavi calibrate``).
    """

    intrinsics: Intrinsics
    rms: float
    per_view: tuple[tuple[str, float], ...]
    skipped: tuple[tuple[str, str], ...] = ()
    focal_sigma: tuple[float, float] = (0.0, 0.0)
    board: Board = field(default_factory=Board)
    sigmas: dict[str, float] = field(default_factory=dict)
    tilt_spread_deg: float = 0.0
    border_cells: int = 0
    warnings: tuple[str, ...] = ()

    def report(self) -> str:
        """Human-readable summary: intrinsics, RMS and per-view errors, skipped photos."""
        i = self.intrinsics
        lines = [f"{len(self.per_view)} view(s) used, {len(self.skipped)} skipped; RMS reprojection error "
                 f"{self.rms:.3f} px",
                 f"fx {i.fx:.2f}  fy {i.fy:.2f}  cx {i.cx:.2f}  cy {i.cy:.2f}  ({i.width}x{i.height} px; "
                 f"sigma fx {self.focal_sigma[0]:.2f}, fy {self.focal_sigma[1]:.2f} px)",
                 "dist " + ", ".join(f"{d:.5f}" for d in i.dist) + "  (k1, k2, p1, p2, k3)"]
        if self.sigmas:
            lines.append("sigma " + ", ".join(f"{k} {v:.3g}" for k, v in self.sigmas.items())
                         + "  (standard deviations at >= 0.1 px corner noise)")
        lines.append(f"views: board tilt spread {self.tilt_spread_deg:.1f} deg, corners reach {self.border_cells} of "
                     f"12 border cells")
        lines.extend(f"warning: {w}" for w in self.warnings)
        worst = max((e for _, e in self.per_view), default=0.0)
        for name, err in self.per_view:
            flag = "  <- worst" if err == worst and len(self.per_view) > 1 else ""
            lines.append(f"  {name}: {err:.3f} px{flag}")
        for name, why in self.skipped:
            lines.append(f"  skipped {name}: {why}")
        return "\n".join(lines)


def _gray(image: np.ndarray) -> np.ndarray:
    if image.ndim == 2:
        return image
    return cv2.cvtColor(image, cv2.COLOR_RGB2GRAY)


def find_chessboard(image: np.ndarray, board: Board) -> np.ndarray | None:
    """Sub-pixel inner corners of the chessboard in an RGB (or gray) photo (N x 2 [px]), or ``None``."""
    gray = _gray(image)
    ok, corners = cv2.findChessboardCornersSB(gray, (board.cols, board.rows), flags=cv2.CALIB_CB_EXHAUSTIVE)
    if not ok:
        ok, corners = cv2.findChessboardCorners(
            gray, (board.cols, board.rows), flags=cv2.CALIB_CB_ADAPTIVE_THRESH | cv2.CALIB_CB_NORMALIZE_IMAGE)
        if not ok:
            return None
        corners = cv2.cornerSubPix(gray, corners, (5, 5), (-1, -1),
                                   (cv2.TERM_CRITERIA_EPS + cv2.TERM_CRITERIA_MAX_ITER, 50, 1e-3))
    return corners.reshape(-1, 2).astype(np.float32)


def find_charuco(image: np.ndarray, board: Board) -> tuple[np.ndarray, np.ndarray] | None:
    """``(object points N x 3 [m], image points N x 2 [px])`` of the ChArUco corners found, or ``None``
    when fewer than 6 corners are seen (too few to constrain a view)."""
    detector = cv2.aruco.CharucoDetector(board.charuco())
    corners, ids, _, _ = detector.detectBoard(_gray(image))
    if corners is None or ids is None or len(ids) < 6:
        return None
    obj, img = board.charuco().matchImagePoints(corners, ids)
    if obj is None or len(obj) < 6:
        return None
    return obj.reshape(-1, 3).astype(np.float32), img.reshape(-1, 2).astype(np.float32)


def calibrate(photos: Sequence[tuple[str, np.ndarray]], board: Board, *, min_views: int = 5,
              max_focal_sigma: float = 0.02) -> Calibration:
    """Calibrate from named RGB photos of ``board``, all of one size.

    Args:
        photos: ``(name, image)`` pairs; images H x W x 3 uint8 RGB (upright).
        board: The target.
        min_views: Fewest photos in which the board must be found.
        max_focal_sigma: Largest accepted standard deviation of fx / fy, as a fraction of them.

    Raises:
        CalibrationError: No photos, photos of different sizes, too few views with the board, or
            degenerate views (the focal length is not determined).
    """
    if not photos:
        raise CalibrationError("no photos given")
    if int(min_views) < 1:
        raise CalibrationError(f"min_views: must be at least 1, got {min_views}")
    h0, w0 = photos[0][1].shape[:2]
    obj_pts: list[np.ndarray] = []
    img_pts: list[np.ndarray] = []
    used: list[str] = []
    skipped: list[tuple[str, str]] = []
    for name, image in photos:
        h, w = image.shape[:2]
        if (w, h) != (w0, h0):
            raise CalibrationError(f"{name}: the photo is {w}x{h} px but {photos[0][0]} is {w0}x{h0}; one calibration "
                                   "is for one image size (and orientation)")
        if board.kind == "chessboard":
            corners = find_chessboard(image, board)
            if corners is None:
                skipped.append((name, f"no {board.cols}x{board.rows} chessboard (inner corners) found"))
                continue
            obj_pts.append(board.object_points())
            img_pts.append(corners)
        else:
            found = find_charuco(image, board)
            if found is None:
                skipped.append((name, "fewer than 6 ChArUco corners found"))
                continue
            obj_pts.append(found[0])
            img_pts.append(found[1])
        used.append(name)
    if len(used) < min_views:
        hint = ""
        if board.kind == "chessboard" and len(used) <= len(photos) // 2:  # mostly not found: the size, likely
            from pipeline.camera.board_hint import board_size_hint

            missed = {name for name, _ in skipped}
            hint = board_size_hint([p for p in photos if p[0] in missed], board.cols, board.rows)
        raise CalibrationError(f"the board was found in {len(used)} of {len(photos)} photo{'' if len(photos) == 1 else 's'}"
                               f"{hint}; at least {min_views} {'is' if min_views == 1 else 'are'} needed (different "
                               "angles and distances, the board filling much of the frame)")
    rms, K, dist, _, _, std_intr, _, per_view = cv2.calibrateCameraExtended(
        obj_pts, img_pts, (w0, h0), None, None)
    fx, fy = float(K[0, 0]), float(K[1, 1])
    # OpenCV's sigma scales with the residual; judge the views at a corner noise of at least
    # NOISE_FLOOR_PX, so that near-perfect corners do not hide an ill-posed set of views
    scale = max(1.0, NOISE_FLOOR_PX / rms) if rms > 0 else 1.0
    sigma = (float(std_intr[0, 0]) * scale, float(std_intr[1, 0]) * scale)
    sigmas = {name: float(v) * scale for name, v in zip(PARAMETERS, np.asarray(std_intr).ravel())}
    # the geometry of the views first: a straight-on set fits ANY focal length with a small sigma
    cov = coverage(obj_pts, img_pts, (w0, h0), fx)
    if not cov.tilted_enough:
        raise CalibrationError(f"degenerate views: {cov.tilt_problem()} (this set gave fx {fx:.0f} px, which "
                               "cannot be trusted)")
    if cov.centre_only:
        raise CalibrationError(f"poor coverage: {cov.border_problem(w0, h0)}")
    if not all(math.isfinite(v) for v in (*K.ravel(), *dist.ravel(), *sigma)) or fx <= 0 or fy <= 0:
        raise CalibrationError("calibration did not converge (degenerate views): take photos of the board at "
                               "different tilts and distances")
    if sigma[0] > max_focal_sigma * fx or sigma[1] > max_focal_sigma * fy:
        raise CalibrationError(
            f"degenerate views: the focal length is not determined (fx {fx:.1f} +- {sigma[0]:.1f} px, fy {fy:.1f} +- "
            f"{sigma[1]:.1f} px, over {max_focal_sigma:.0%}); tilt the board by 20-45 deg in different directions "
            "between photos instead of facing it straight on")
    cx, cy = float(K[0, 2]), float(K[1, 2])
    intr = Intrinsics(fx, fy, cx, cy, int(w0), int(h0), tuple(float(d) for d in dist.ravel()[:5]))
    views = tuple((n, float(e)) for n, e in zip(used, np.asarray(per_view).ravel()))
    warnings = tuple(w for w in (cov.border_warning(w0, h0),) if w)
    return Calibration(intr, float(rms), views, tuple(skipped), sigma, board, sigmas, cov.tilt_spread_deg,
                       cov.border_cells, warnings)


__all__ = ["ARUCO_DICTIONARIES", "Board", "Calibration", "CalibrationError", "calibrate", "find_charuco",
           "find_chessboard"]
