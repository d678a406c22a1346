"""``calibrate --board``: when the board is not found, which size it may be instead.

A chessboard is given by its INNER corners (a board of 10 x 7 squares is ``9x6``); counting the
squares, or swapping columns and rows, are the usual mistakes. :func:`board_size_hint` looks for the
neighbouring sizes in one photo where the given size was not found, with OpenCV's fast check so a
photo without any board costs little, and says which one it found.
"""

from __future__ import annotations

from typing import Sequence

import cv2
import numpy as np


def candidate_sizes(cols: int, rows: int) -> list[tuple[int, int]]:
    """Board sizes (inner corners) a user may have meant instead of ``cols x rows``: the squares
    counted instead of the corners (both ways), one fewer or more on either side, and each swapped."""
    out: list[tuple[int, int]] = []
    for dc, dr in ((-1, -1), (1, 1), (-1, 0), (0, -1), (1, 0), (0, 1), (-2, -2), (2, 2)):
        c, r = cols + dc, rows + dr
        if c >= 2 and r >= 2 and (c, r) != (cols, rows):
            out.append((c, r))
    return out


def _gray(image: np.ndarray) -> np.ndarray:
    return image if image.ndim == 2 else cv2.cvtColor(image, cv2.COLOR_RGB2GRAY)


def board_size_hint(photos: Sequence[tuple[str, np.ndarray]], cols: int, rows: int, tries: int = 2) -> str:
    """``" (a 8x6 chessboard is in board_01.png: give --board 8x6)"`` or the generic advice to check
    ``--board``; looks at up to ``tries`` photos."""
    for name, image in list(photos)[:tries]:
        gray = _gray(image)
        for c, r in candidate_sizes(cols, rows):
            ok, _ = cv2.findChessboardCorners(gray, (c, r), flags=cv2.CALIB_CB_ADAPTIVE_THRESH |
                                              cv2.CALIB_CB_NORMALIZE_IMAGE | cv2.CALIB_CB_FAST_CHECK)
            if ok:
                return f"; a {c}x{r} chessboard (inner corners) is in {name}: give --board {c}x{r}"
    return (f"; check --board {cols}x{rows} first: it counts INNER corners, columns x rows (a board of 10 x 7 "
            "squares is 9x6)")


__all__ = ["board_size_hint", "candidate_sizes"]
