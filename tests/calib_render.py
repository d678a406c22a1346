"""Photos of calibration boards rendered with a known pinhole + distortion camera (for the tests).

Every output pixel's ray (distortion removed with OpenCV) is intersected with the board plane and
looks up a texture of the board, so corners land exactly where the known camera projects them.
"""

from __future__ import annotations

import cv2
import numpy as np
from scipy.spatial.transform import Rotation

from pipeline.camera.calibration import Board

PX_PER_SQUARE = 40
MARGIN_PX = 40


def texture(board: Board) -> np.ndarray:
    """The board as a gray image: PX_PER_SQUARE px per square, MARGIN_PX px white margin; board
    frame origin (metres) at the top-left corner of the first square."""
    if board.kind == "charuco":
        size = (board.cols * PX_PER_SQUARE + 2 * MARGIN_PX, board.rows * PX_PER_SQUARE + 2 * MARGIN_PX)
        return board.charuco().generateImage(size, marginSize=MARGIN_PX, borderBits=1)
    cols, rows = board.cols + 1, board.rows + 1  # squares
    s, m = PX_PER_SQUARE, MARGIN_PX
    tex = np.full((rows * s + 2 * m, cols * s + 2 * m), 255, np.uint8)
    for r in range(rows):
        for c in range(cols):
            if (r + c) % 2 == 0:
                tex[m + r * s: m + (r + 1) * s, m + c * s: m + (c + 1) * s] = 0
    return tex


class Renderer:
    """Renders ``board`` as seen by the camera ``K`` (3 x 3) with distortion ``dist`` at ``size`` (w, h)."""

    def __init__(self, board: Board, K: np.ndarray, dist: np.ndarray, size: tuple[int, int]) -> None:
        self.board, self.size = board, size
        self.tex = texture(board)
        w, h = size
        u, v = np.meshgrid(np.arange(w, dtype=np.float32), np.arange(h, dtype=np.float32))
        n = cv2.undistortPoints(np.stack([u.ravel(), v.ravel()], 1).reshape(-1, 1, 2), K, dist).reshape(-1, 2)
        self.rays = np.concatenate([n, np.ones((len(n), 1))], 1)  # camera frame, z = 1
        # chessboard: the board frame starts at the first INNER corner, one square in
        self.offset = 1.0 if board.kind == "chessboard" else 0.0

    def render(self, rotation: Rotation, translation: np.ndarray) -> np.ndarray:
        """RGB photo of the board at ``camera <- board`` = (rotation, translation [m])."""
        R = rotation.as_matrix()
        t = np.asarray(translation, dtype=np.float64)
        lam = (R[:, 2] @ t) / (self.rays @ R[:, 2])
        xb = (lam[:, None] * self.rays - t) @ R  # board frame [m]
        s, sq = PX_PER_SQUARE, self.board.square
        tx = (xb[:, 0] / sq + self.offset) * s + MARGIN_PX - 0.5
        ty = (xb[:, 1] / sq + self.offset) * s + MARGIN_PX - 0.5
        bad = lam <= 0
        tx[bad] = -1e6
        w, h = self.size
        img = cv2.remap(self.tex, tx.reshape(h, w).astype(np.float32), ty.reshape(h, w).astype(np.float32),
                        cv2.INTER_LINEAR, borderValue=200)
        return cv2.cvtColor(img, cv2.COLOR_GRAY2RGB)

    def centre(self) -> np.ndarray:
        """The board's centre in the board frame [m]."""
        b = self.board
        if b.kind == "chessboard":
            return np.array([(b.cols - 1) / 2 * b.square, (b.rows - 1) / 2 * b.square, 0.0])
        return np.array([b.cols / 2 * b.square, b.rows / 2 * b.square, 0.0])

    def views(self, n: int, seed: int = 0, tilt_deg: float = 35.0, distance: tuple[float, float] = (0.38, 0.55),
              shift: tuple[float, float] = (0.04, 0.03)) -> list[tuple[str, np.ndarray]]:
        """``n`` photos from random tilts (up to ``tilt_deg``) and distances [m], the board's centre up to
        ``shift`` (x, y) [m] off the optical axis (the default keeps it near the image centre)."""
        rng = np.random.default_rng(seed)
        out = []
        for i in range(n):
            rot = Rotation.from_euler("xyz", np.radians([rng.uniform(-tilt_deg, tilt_deg),
                                                         rng.uniform(-tilt_deg, tilt_deg), rng.uniform(-20, 20)]))
            t = np.array([rng.uniform(-shift[0], shift[0]), rng.uniform(-shift[1], shift[1]), rng.uniform(*distance)])
            out.append((f"view{i:02d}.png", self.render(rot, t - rot.apply(self.centre()))))
        return out
