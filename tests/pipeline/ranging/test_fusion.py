"""Inverse-variance fusion of distance cues, outlier rejection, the border bound; and the size-prior cue."""

from __future__ import annotations

import math

import numpy as np
import pytest

from pipeline.ranging.distance import DistanceError, Truncation
from pipeline.ranging.fusion import Cue, FusionError, fuse_cues, soft_upper_bound
from pipeline.camera.geometry import Intrinsics
from pipeline.ranging.placement import geometric_estimate
from pipeline.ranging.size_prior import half_depth_stats, horizontal_extent_stats, size_prior_cue


def test_two_agreeing_cues_fuse_by_inverse_variance_in_log_distance() -> None:
    a, b = Cue("size_prior", 10.0, 1.0), Cue("ground_contact", 10.5, 0.5)
    f = fuse_cues([a, b])
    assert f is not None
    sa, sb = 0.1, 0.5 / 10.5
    w = np.array([1 / sa**2, 1 / sb**2])
    l = float(w @ np.log([10.0, 10.5]) / w.sum())
    s = 1 / math.sqrt(w.sum())
    assert f.distance == pytest.approx(math.exp(l))
    assert f.sigma == pytest.approx(math.exp(l) * s)  # agree within their sigmas: no inflation
    assert f.used == ("size_prior", "ground_contact") and f.method == "fused" and f.birge == 1.0
    assert f.sigma < min(a.sigma, b.sigma)


def test_one_cue_is_its_own_answer() -> None:
    f = fuse_cues([Cue("ground_contact", 4.0, 0.3)])
    assert f is not None and (f.distance, f.sigma, f.method) == (pytest.approx(4.0), pytest.approx(0.3), "ground_contact")
    assert fuse_cues([]) is None


def test_the_outlier_of_three_is_dropped() -> None:
    cues = [Cue("size_prior", 10.0, 1.0), Cue("ground_contact", 10.4, 0.8), Cue("depth", 25.0, 2.5)]
    f = fuse_cues(cues)
    assert f is not None and f.used == ("size_prior", "ground_contact")
    assert [n for n, _ in f.rejected] == ["depth"]
    assert 10.0 < f.distance < 10.4


def test_two_contradicting_cues_keep_the_one_with_the_smaller_sigma() -> None:
    f = fuse_cues([Cue("size_prior", 3.0, 0.3), Cue("ground_contact", 6.0, 0.3)])  # 10 % and 5 %
    assert f is not None and f.used == ("ground_contact",) and f.distance == pytest.approx(6.0)
    f = fuse_cues([Cue("size_prior", 3.0, 0.2), Cue("depth", 9.0, 1.5)])
    assert f is not None and f.used == ("size_prior",)


def test_scatter_within_the_gate_inflates_the_sigma() -> None:
    """Two cues 2.5 sigma apart (inside the 3-sigma gate): the fused sigma grows by the Birge ratio."""
    a, b = Cue("size_prior", 10.0, 0.5), Cue("ground_contact", 12.0, 0.6)
    f = fuse_cues([a, b])
    assert f is not None and len(f.used) == 2 and f.birge > 1.0
    la, lb, sa, sb = math.log(10), math.log(12), 0.05, 0.05
    l = (la / sa**2 + lb / sb**2) / (1 / sa**2 + 1 / sb**2)
    chi2 = ((la - l) / sa) ** 2 + ((lb - l) / sb) ** 2
    assert f.birge == pytest.approx(math.sqrt(chi2))
    # the inflated sigma covers the disagreement
    assert f.sigma >= abs(12.0 - 10.0) / 2 * 0.9


def test_soft_upper_bound_matches_a_monte_carlo_posterior() -> None:
    rng = np.random.default_rng(3)
    mu, s, b, sb = 3.0, 0.2, 2.75, 0.07
    x = rng.normal(mu, s, 2_000_000)
    keep = x <= rng.normal(b, sb, x.size)
    mean, sd = soft_upper_bound(mu, s, b, sb)
    assert mean == pytest.approx(float(x[keep].mean()), abs=2e-3)
    assert sd == pytest.approx(float(x[keep].std()), rel=0.01)
    # a bound far above changes nothing; far below, the answer sits under the bound
    assert soft_upper_bound(mu, s, mu + 10, 0.01) == pytest.approx((mu, s), rel=1e-6)
    far = soft_upper_bound(mu, s, mu - 3.0, 0.0)
    assert far[0] < mu - 3.0 and math.isfinite(far[1])


def test_the_bound_pulls_a_too_far_estimate_in_and_says_so() -> None:
    """The issue's cut KITTI car: a width-based size prior (19.6 m, +-22 %) of a car whose floor lies
    nearer than 15.5 m (+-1.1 m)."""
    f = fuse_cues([Cue("size_prior", 19.6, 19.6 * 0.22)], upper_bound=(15.5, 1.1))
    assert f is not None and f.bounded
    assert 13.0 < f.distance < 15.5 and f.sigma < 19.6 * 0.22
    g = fuse_cues([Cue("size_prior", 10.0, 1.0)], upper_bound=(30.0, 1.0))
    assert g is not None and not g.bounded and g.distance == pytest.approx(10.0, rel=1e-3)


def test_bad_cues_and_parameters_are_named() -> None:
    with pytest.raises(FusionError, match="cue depth.sigma"):
        Cue("depth", 3.0, float("nan"))
    with pytest.raises(FusionError, match="cue size_prior.distance"):
        Cue("size_prior", -1.0, 0.1)
    with pytest.raises(FusionError, match="gate"):
        fuse_cues([Cue("depth", 3.0, 0.1)], gate=0)
    with pytest.raises(FusionError, match="upper_bound"):
        fuse_cues([Cue("depth", 3.0, 0.1)], upper_bound=(float("inf"), 1.0))


# --- size prior ---------------------------------------------------------------------------------

def test_horizontal_extent_statistics_match_a_uniform_yaw() -> None:
    a = np.random.default_rng(0).uniform(0, 2 * math.pi, 1_000_000)
    w, l = 1.6, 3.9
    ext = w * np.abs(np.cos(a)) + l * np.abs(np.sin(a))
    mean, sd = horizontal_extent_stats(w, l)
    assert mean == pytest.approx(float(ext.mean()), rel=1e-3)
    assert sd == pytest.approx(float(ext.std()), rel=5e-3)
    half, half_sd = half_depth_stats((w, 1.5, l), (0.0, 0.0, 0.0))
    assert (half, half_sd) == (pytest.approx(mean / 2), pytest.approx(sd / 2))
    with pytest.raises(DistanceError, match="footprint"):
        horizontal_extent_stats(0.0, 1.0)


INTR = Intrinsics(700.0, 700.0, 640.0, 360.0, 1280, 720)


def test_size_prior_sigma_follows_the_class_spread() -> None:
    """A 1.7 m person 10 m away seen whole: sigma = z * hypot(height spread, pixel error)."""
    h_px = 700.0 * 1.7 / 10.0
    box = (600.0, 300.0, 640.0, 300.0 + h_px)
    est = geometric_estimate(box, (0.6, 1.7, 0.5), INTR, Truncation(), None, "ray")
    assert est is not None
    tight = size_prior_cue(est, box, Truncation(), (0.6, 1.7, 0.5), (0.15, 0.07, 0.15))
    loose = size_prior_cue(est, box, Truncation(), (0.6, 1.7, 0.5), (0.5, 0.5, 0.4))
    z = float(est.center[2])
    assert tight.sigma == pytest.approx(z * math.hypot(0.07, max(1.5, 0.02 * h_px) / h_px))
    assert loose.sigma == pytest.approx(z * math.hypot(0.5, max(1.5, 0.02 * h_px) / h_px))


def test_a_cut_height_falls_back_to_the_width_with_the_yaw_spread() -> None:
    box = (500.0, 200.0, 700.0, 719.0)
    trunc = Truncation(bottom=True)
    est = geometric_estimate(box, (1.6, 1.5, 3.9), INTR, trunc, None, "ray")
    assert est is not None
    cue = size_prior_cue(est, box, trunc, (1.6, 1.5, 3.9), (0.07, 0.08, 0.1))
    mean, sd = horizontal_extent_stats(1.6, 3.9)
    assert cue.rel_sigma > sd / mean  # at least the yaw's spread (22 % for a car)
    assert "width" in cue.note
    with pytest.raises(DistanceError, match="spread"):
        size_prior_cue(est, box, trunc, (1.6, 1.5, 3.9), (0.1, float("nan"), 0.1))
