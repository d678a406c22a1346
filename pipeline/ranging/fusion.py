"""One distance from several cues, each with its own uncertainty: inverse-variance fusion.

Every distance cue (size prior, ground contact, depth map; :mod:`pipeline.ranging.size_prior`,
:mod:`pipeline.ranging.ground_contact`) returns a :class:`Cue`: the optical-axis depth [m] of the object's
centre (camera frame, OpenCV: z forward) and its 1-sigma [m]. :func:`fuse_cues` combines them.

The model: cue errors are roughly multiplicative (a size off by 20 % puts the object 20 % off), so
the cues are fused in log distance, ``l_i = ln d_i`` with ``s_i = sigma_i / d_i``:

- inverse-variance mean ``l = sum(l_i / s_i^2) / sum(1 / s_i^2)``, ``s = 1 / sqrt(sum(1 / s_i^2))``;
- **outlier rejection**: a cue whose normalised residual against the fusion of the *others*,
  ``|l_i - l_-i| / sqrt(s_i^2 + s_-i^2)``, exceeds ``gate`` (3 sigma) is dropped, worst first, while
  two or more cues remain. With exactly two cues that contradict each other neither can be singled out
  by the data; the one with the larger sigma is dropped (the better-understood cue is kept);
- **consistency**: when the kept cues scatter more than their sigmas allow (Birge ratio
  ``sqrt(chi2 / (n - 1)) > 1``), the fused sigma is multiplied by that ratio, so the reported sigma
  stays honest when the cues disagree within the gate;
- an optional **upper bound** (a box cut by the bottom border of the photo: the floor contact lies
  beyond the border, so the object is nearer than the floor at the border row, see
  :func:`pipeline.ranging.ground_contact.border_bound`), itself uncertain, multiplies the Gaussian by the
  probability of lying below it: the fused distance and sigma are that skew normal's mean and
  standard deviation (:func:`soft_upper_bound`).

The fused distance is ``exp(l)`` (the median of the log-normal) and its sigma ``exp(l) * s`` [m].
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Sequence

from scipy.stats import norm

DEFAULT_GATE = 3.0
"""Normalised residual beyond which a cue is an outlier [sigmas]."""


class FusionError(ValueError):
    """A cue or fusion parameter is invalid (non-finite, not positive)."""


@dataclass(frozen=True)
class Cue:
    """One distance estimate.

    Attributes:
        name: Which cue (``size_prior``, ``ground_contact``, ``depth``).
        distance: Optical-axis depth of the object's centre [m] (camera frame z), > 0.
        sigma: Its 1-sigma [m], > 0.
        note: How it was obtained (for the debug output and the bench).
        down_weighted: Why its sigma was widened beyond the cue's own error model (an implausible box,
            a border cut, a floor at odds with the given pose), in a few words; empty when it was not.
    """

    name: str
    distance: float
    sigma: float
    note: str = ""
    down_weighted: str = ""

    def __post_init__(self) -> None:
        for key in ("distance", "sigma"):
            v = getattr(self, key)
            if not isinstance(v, (int, float)) or not math.isfinite(v) or v <= 0:
                raise FusionError(f"cue {self.name}.{key}: must be a finite number > 0 [m], got {v!r}")

    @property
    def rel_sigma(self) -> float:
        """``sigma / distance``: the log-distance sigma."""
        return self.sigma / self.distance


@dataclass(frozen=True)
class Fused:
    """The fused distance.

    Attributes:
        distance: Optical-axis depth of the centre [m].
        sigma: Its 1-sigma [m].
        used: Names of the cues that made it.
        rejected: ``(name, why)`` of the cues dropped as outliers.
        bounded: The upper bound moved the estimate (a box cut by the bottom border).
        birge: Birge ratio applied to the sigma (1 when the cues agree within their sigmas).
    """

    distance: float
    sigma: float
    used: tuple[str, ...]
    rejected: tuple[tuple[str, str], ...] = field(default_factory=tuple)
    bounded: bool = False
    birge: float = 1.0

    @property
    def method(self) -> str:
        """``fused`` (several cues), else the one cue's name mapped to the scene's method names."""
        if len(self.used) > 1:
            return "fused"
        return {"size_prior": "geometric", "depth": "depth", "ground_contact": "ground_contact"}.get(
            self.used[0], self.used[0])


def _combine(ls: Sequence[float], ss: Sequence[float]) -> tuple[float, float]:
    w = [1.0 / s**2 for s in ss]
    tot = sum(w)
    return sum(wi * li for wi, li in zip(w, ls)) / tot, 1.0 / math.sqrt(tot)


def combine_log(cues: Sequence[Cue]) -> tuple[float, float]:
    """Inverse-variance mean and sigma of ``cues`` in log distance: ``(l, s)`` with the distance
    ``exp(l)`` [m] and its relative sigma ``s``. ``cues`` must not be empty."""
    if not cues:
        raise FusionError("combine_log: no cues")
    return _combine([math.log(c.distance) for c in cues], [c.rel_sigma for c in cues])


def soft_upper_bound(mu: float, s: float, bound: float, bound_sigma: float) -> tuple[float, float]:
    """Mean and standard deviation of ``l ~ N(mu, s^2)`` given that ``l <= B`` with ``B ~ N(bound,
    bound_sigma^2)`` (all in log distance): the posterior ``N(l; mu, s^2) * Phi((bound - l) /
    bound_sigma)`` is a skew normal. With ``tau = sqrt(s^2 + bound_sigma^2)``, ``a = (bound - mu) / tau``
    and ``lam = phi(a) / Phi(a)``: mean ``mu - s^2 / tau * lam``, variance ``s^2 - s^4 / tau^2 * lam *
    (lam + a)``. ``bound_sigma = 0`` is the plain truncated normal. The inverse Mills ratio ``lam`` is
    evaluated in logs (``scipy.stats.norm.logpdf / logcdf``), so a bound far below ``mu`` does not
    overflow.
    """
    tau = math.sqrt(s**2 + bound_sigma**2)
    a = (bound - mu) / tau
    lam = math.exp(norm.logpdf(a) - norm.logcdf(a))
    mean = mu - s**2 / tau * lam
    var = s**2 - s**4 / tau**2 * lam * (lam + a)
    return mean, math.sqrt(max(var, 1e-4 * s**2))


def fuse_cues(cues: Sequence[Cue], gate: float = DEFAULT_GATE,
              upper_bound: tuple[float, float] | None = None) -> Fused | None:
    """Fuse ``cues`` (see the module docstring); ``None`` when there is none.

    Args:
        cues: The estimates of one object.
        gate: Outlier threshold [sigmas], > 0.
        upper_bound: ``(bound, sigma)`` [m]: the object's centre depth is at most ``bound``, itself
            known to ``sigma`` (``None``: no bound); see :func:`soft_upper_bound`.
    """
    if not (isinstance(gate, (int, float)) and math.isfinite(gate) and gate > 0):
        raise FusionError(f"gate: must be a finite number > 0, got {gate!r}")
    if upper_bound is not None and not (len(upper_bound) == 2 and all(math.isfinite(v) for v in upper_bound)
                                        and upper_bound[0] > 0 and upper_bound[1] >= 0):
        raise FusionError(f"upper_bound: must be (bound > 0, sigma >= 0) [m], got {upper_bound!r}")
    kept = list(cues)
    if not kept:
        return None
    rejected: list[tuple[str, str]] = []
    while len(kept) >= 2:
        worst, worst_r = -1, gate
        for i, c in enumerate(kept):
            others = kept[:i] + kept[i + 1:]
            lo, so = _combine([math.log(o.distance) for o in others], [o.rel_sigma for o in others])
            r = abs(math.log(c.distance) - lo) / math.sqrt(c.rel_sigma**2 + so**2)
            if r > worst_r:
                worst, worst_r = i, r
        if worst < 0:
            break
        if len(kept) == 2:  # the residual is the same for both: the larger sigma goes
            worst = 0 if kept[0].rel_sigma > kept[1].rel_sigma else 1
        c = kept.pop(worst)
        rejected.append((c.name, f"{c.distance:.2f} m disagrees with the other cues by {worst_r:.1f} sigma"))
    ls = [math.log(c.distance) for c in kept]
    ss = [c.rel_sigma for c in kept]
    l, s = _combine(ls, ss)
    birge = 1.0
    if len(kept) >= 2:
        chi2 = sum(((li - l) / si) ** 2 for li, si in zip(ls, ss))
        birge = max(1.0, math.sqrt(chi2 / (len(kept) - 1)))
        s *= birge
    bounded = False
    if upper_bound is not None:
        l2, s2 = soft_upper_bound(l, s, math.log(upper_bound[0]), upper_bound[1] / upper_bound[0])
        bounded = l - l2 > 0.1 * s  # the bound moved the estimate noticeably
        l, s = l2, s2
    d = math.exp(l)
    return Fused(d, d * s, tuple(c.name for c in kept), tuple(rejected), bounded, birge)


__all__ = ["Cue", "DEFAULT_GATE", "combine_log", "Fused", "FusionError", "fuse_cues", "soft_upper_bound"]
