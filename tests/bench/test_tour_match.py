"""The tour benchmark's matching (bench/sim_tour.py): a map that lacks one box of a line is scored as one box
missing, not as a chain of boxes each matched to its neighbour's true place."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
from scipy.optimize import linear_sum_assignment

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "bench"))

from sim_tour import MATCH_RADIUS, match  # noqa: E402


def test_a_missing_box_is_missing_not_a_shifted_chain() -> None:
    true_x = np.arange(6) * 0.45  # a line of six boxes 0.45 m apart
    mapped_x = np.delete(true_x, 2) + 0.05  # the third one not mapped, the others 5 cm off
    mapped_x = np.append(mapped_x, true_x[5] + 0.5)  # and a false one 0.5 m past the end
    cost = np.abs(mapped_x[:, None] - true_x[None, :])
    rows, cols = match(cost)
    pairs = {int(r): int(c) for r, c in zip(rows, cols)}
    assert pairs == {0: 0, 1: 1, 2: 3, 3: 4, 4: 5}  # each box to its own place; box 2 and the false one unmatched
    assert max(cost[r, c] for r, c in pairs.items()) < 0.06
    # maximising the number of pairs within the radius instead shifts boxes onto their neighbours' places
    r, c = linear_sum_assignment(np.where(cost <= MATCH_RADIUS, cost, 1e6))
    assert len(r) == 6 and max(cost[r, c]) > 0.35
