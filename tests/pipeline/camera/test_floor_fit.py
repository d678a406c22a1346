"""The floor from the photo: contacts and a depth map's plane give gravity and camera height (synthetic pinhole)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from pipeline.camera.floor_fit import (
    UNKNOWN_POSE_PRIOR, Contact, FloorFitError, FloorPrior, contact_sigma, disagreement, fit_floor, plane_from_depth,
)
from pipeline.camera.geometry import Intrinsics, project

INTR = Intrinsics(700.0, 700.0, 640.0, 360.0, 1280, 720)


def gravity(pitch_deg: float, roll_deg: float = 0.0) -> np.ndarray:
    """Unit gravity (camera frame) of a camera pitched down by ``pitch_deg`` and rolled by ``roll_deg``."""
    p, r = math.radians(pitch_deg), math.radians(roll_deg)
    g = np.array([0.0, math.cos(p), math.sin(p)])
    return np.array([math.cos(r) * g[0] - math.sin(r) * g[1], math.sin(r) * g[0] + math.cos(r) * g[1], g[2]])


def floor_contacts(g: np.ndarray, H: float, points: list[tuple[float, float]], rel: float = 0.07) -> list[Contact]:
    """Contacts at floor points ``(lateral x, forward distance)`` [m] seen from ``H`` over the floor."""
    fwd = np.cross(np.array([1.0, 0.0, 0.0]), g)
    fwd /= np.linalg.norm(fwd)
    right = np.cross(g, fwd)
    out = []
    for x, d in points:
        P = H * g + x * right + d * fwd
        (u, v), = project(P[None], INTR)
        out.append(Contact((float(u), float(v)), float(P[2]), rel, "person"))
    return out


def pitch_of(g) -> float:
    return math.degrees(math.atan2(g[2], math.hypot(g[0], g[1])))


def test_contacts_give_pitch_roll_and_height_of_an_unknown_pose() -> None:
    g, H = gravity(20.0, 3.0), 1.3
    contacts = floor_contacts(g, H, [(-1.5, 3.0), (0.0, 4.0), (1.0, 6.0), (2.0, 9.0), (-2.0, 12.0)])
    prior = FloorPrior((0.0, 1.0, 0.0), **UNKNOWN_POSE_PRIOR)
    fit = fit_floor(prior, contacts, INTR)
    assert abs(fit.pitch_deg - 20.0) < 1.0 and abs(fit.roll_deg - math.degrees(math.atan2(g[0], g[1]))) < 1.5
    assert abs(fit.camera_height - H) < 0.15  # exact contacts: the common size scale (8 %) bounds the height
    assert fit.sigma_pitch < math.radians(3.0) and fit.sigma_height < 0.25
    assert "floor from the photo: pitch 20." in fit.note and "5 object contacts" in fit.note


def test_a_false_contact_does_not_tilt_the_floor() -> None:
    g, H = gravity(10.0), 1.5
    contacts = floor_contacts(g, H, [(-1.0, 4.0), (0.5, 6.0), (1.5, 8.0), (-2.0, 10.0)])
    wrong = Contact(contacts[1].uv, contacts[1].depth * 2.5, 0.07, "toilet")  # a misdetection's size
    prior = FloorPrior((0.0, 1.0, 0.0), **UNKNOWN_POSE_PRIOR)
    fit = fit_floor(prior, contacts + [wrong], INTR)
    assert abs(fit.pitch_deg - 10.0) < 1.5 and abs(fit.camera_height - H) < 0.2
    # leaving the false one out gives the same floor; leaving a true one out, a wider one
    assert abs(fit_floor(prior, contacts + [wrong], INTR, leave_out=4).pitch_deg - 10.0) < 1.0


def test_no_evidence_leaves_the_prior_and_its_sigmas() -> None:
    prior = FloorPrior((0.0, 1.0, 0.0), **UNKNOWN_POSE_PRIOR)
    fit = fit_floor(prior, [], INTR)
    assert abs(fit.pitch_deg) < 1e-6 and abs(fit.camera_height - 1.5) < 1e-6
    assert fit.sigma_pitch == pytest.approx(math.radians(20.0), rel=0.05)


def test_the_floor_plane_of_a_depth_map_outside_the_objects() -> None:
    g, H = gravity(25.0, -4.0), 1.3
    v, u = np.mgrid[0:INTR.height, 0:INTR.width].astype(np.float64)
    r = np.stack([(u - INTR.cx) / INTR.fx, (v - INTR.cy) / INTR.fy, np.ones_like(u)], axis=-1)
    gr = r @ g
    depth = np.where(gr > 0.01, H / np.maximum(gr, 1e-9), np.nan)  # optical-axis depth of the floor
    depth[300:600, 400:800] = 1.0  # a box standing in front: not the floor
    exclude = np.zeros(depth.shape, dtype=bool)
    plane = plane_from_depth(depth, INTR, (0.0, 1.0, 0.0), exclude)
    assert plane is not None
    assert math.degrees(math.acos(min(1.0, float(np.dot(plane.gravity_cam, g))))) < 0.5
    assert abs(plane.camera_height - H) < 0.02 and plane.inlier_share > 0.5
    # with the plane, the fit knows the tilt without any contact
    fit = fit_floor(FloorPrior((0.0, 1.0, 0.0), **UNKNOWN_POSE_PRIOR), [], INTR, plane)
    assert abs(fit.pitch_deg - pitch_of(g)) < 1.0
    with pytest.raises(FloorFitError, match="does not match"):
        plane_from_depth(depth[:100], INTR, (0.0, 1.0, 0.0))


def test_contact_sigma_grows_with_distance_and_follows_the_covariance() -> None:
    g, H = gravity(5.0), 1.5
    contacts = floor_contacts(g, H, [(-1.0, 5.0), (1.0, 10.0), (0.0, 20.0)])
    fit = fit_floor(FloorPrior((0.0, 1.0, 0.0), **UNKNOWN_POSE_PRIOR), contacts, INTR)
    near = contact_sigma(fit, floor_contacts(g, H, [(0.0, 4.0)])[0].uv, INTR)
    far = contact_sigma(fit, floor_contacts(g, H, [(0.0, 40.0)])[0].uv, INTR)
    assert 0 < near < far
    assert contact_sigma(fit, (640.0, 10.0), INTR) == float("inf")  # above the horizon: no floor there


def test_disagreement_with_a_given_pose() -> None:
    g, H = gravity(20.0), 1.2
    contacts = floor_contacts(g, H, [(-1.5, 3.0), (0.0, 4.0), (1.0, 6.0), (1.5, 8.0)])
    given_right = FloorPrior(tuple(g), H, 0.01, 0.01, 0.03)
    fit = fit_floor(FloorPrior(tuple(g), H, math.radians(20), math.radians(8), 0.5), contacts, INTR)
    assert disagreement(given_right, fit) < 3.4
    level = (0.0, 1.0, 0.0)
    fit_l = fit_floor(FloorPrior(level, 0.35, math.radians(20), math.radians(8), 0.5), contacts, INTR)
    assert disagreement(FloorPrior(level, 0.35, 0.01, 0.01, 0.1), fit_l) > 3.4


def test_bad_values_are_named() -> None:
    with pytest.raises(FloorFitError, match="camera_height"):
        FloorPrior((0.0, 1.0, 0.0), float("nan"), 0.1, 0.1, 0.1)
    with pytest.raises(FloorFitError, match="gravity_cam"):
        FloorPrior((0.0, 2.0, 0.0), 1.0, 0.1, 0.1, 0.1)
    with pytest.raises(FloorFitError, match="contact depth"):
        Contact((1.0, 2.0), -1.0, 0.1)
