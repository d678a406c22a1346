"""calibrate with the wrong --board size names the size it finds in a photo (or says to check --board)."""

from __future__ import annotations

import numpy as np
import pytest
from calib_render import Renderer

from pipeline.camera.board_hint import board_size_hint, candidate_sizes
from pipeline.camera.calibration import Board, CalibrationError, calibrate

K = np.array([[520.0, 0.0, 320.0], [0.0, 520.0, 240.0], [0.0, 0.0, 1.0]])
DIST = np.zeros(5)
SIZE = (640, 480)


def test_candidates_hold_the_usual_mistakes() -> None:
    c = candidate_sizes(9, 6)
    assert (10, 7) in c and (8, 5) in c and (9, 5) in c and (9, 6) not in c


def test_the_wrong_board_size_names_the_right_one() -> None:
    views = Renderer(Board("chessboard", 9, 6, 0.025), K, DIST, SIZE).views(6)
    with pytest.raises(CalibrationError) as e:
        calibrate(views, Board("chessboard", 10, 7, 0.025), min_views=5)  # squares counted, not inner corners
    assert "the board was found in 0 of 6 photos; a 9x6 chessboard (inner corners) is in" in str(e.value)
    assert "give --board 9x6" in str(e.value)


def test_no_board_at_all_says_to_check_board() -> None:
    blank = [(f"p{i}.png", np.full((120, 160, 3), 90, np.uint8)) for i in range(2)]
    assert "check --board 9x6 first: it counts INNER corners" in board_size_hint(blank, 9, 6)
