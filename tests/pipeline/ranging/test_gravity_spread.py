"""A size prior fitted under a gravity that was itself fitted from the photo carries that gravity's sigma."""

from __future__ import annotations

import math

import numpy as np
import pytest

from pipeline.camera.floor_fit import FloorEstimate
from pipeline.camera.geometry import Intrinsics, project
from pipeline.ranging.distance import Truncation
from pipeline.ranging.fusion import Cue
from pipeline.ranging.gravity_spread import gravity_sigma_z, widen_for_gravity

INTR = Intrinsics(600.0, 600.0, 640.0, 360.0, 1280, 720)
TABLE = (0.9, 0.75, 1.6)  # w, h, l [m]


def _floor(sigma_deg: float, g: np.ndarray) -> FloorEstimate:
    s2 = math.radians(sigma_deg) ** 2
    return FloorEstimate(tuple(g), 1.5, tuple(g), (0.0, 0.0), ((s2, 0, 0), (0, s2, 0), (0, 0, 0.01)), 0, None, "")


def _table_box(g: np.ndarray) -> tuple[float, float, float, float]:
    """2D box of a table 3 m ahead on the floor, seen from 1.5 m up by a camera pitched 25 deg down."""
    fwd = np.cross(np.array([1.0, 0.0, 0.0]), g)
    fwd /= np.linalg.norm(fwd)
    c = 1.5 * g + 3.0 * fwd - 0.5 * TABLE[1] * g
    right = np.array([1.0, 0.0, 0.0])
    corners = np.array([c + a * 0.5 * TABLE[0] * right + b * 0.5 * TABLE[1] * g + e * 0.5 * TABLE[2] * fwd
                        for a in (-1, 1) for b in (-1, 1) for e in (-1, 1)])
    uv = project(corners, INTR)
    return (float(uv[:, 0].min()), float(uv[:, 1].min()), float(uv[:, 0].max()), float(uv[:, 1].max()))


def test_an_uncertain_fitted_gravity_widens_the_size_prior_in_proportion() -> None:
    p = math.radians(25.0)
    g = np.array([0.0, math.cos(p), math.sin(p)])
    box = _table_box(g)
    sure = gravity_sigma_z(box, TABLE, INTR, Truncation(), g, _floor(0.2, g))
    unsure = gravity_sigma_z(box, TABLE, INTR, Truncation(), g, _floor(5.0, g))
    assert 0.0 <= sure < 0.05 and unsure > 0.1  # a table seen from above: its depth follows the pitch
    assert unsure > 10 * sure
    assert gravity_sigma_z(box, TABLE, INTR, Truncation(), g, _floor(5.0, g), "ray") == 0.0  # the ray ignores gravity
    cue = Cue("size_prior", 3.2, 0.3, "height 0.75 m")
    wide = widen_for_gravity(cue, unsure)
    assert wide.distance == cue.distance and wide.sigma == pytest.approx(math.hypot(0.3, unsure))
    assert "from the fitted gravity's pitch and roll" in wide.note
    assert widen_for_gravity(cue, 0.0) is cue
