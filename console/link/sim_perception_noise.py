"""Perception noise for the simulator: the renderer's exact boxes made to look like a detector's.

The simulated robot's renders carry their ground truth (boxes, instance masks, metric depth). Mapped
as they are, a rehearsal is kinder than the real models; :class:`PerceptionNoise` makes it less so,
with the figures the tour benchmark (``bench/sim_tour.py --noise``) has always used:

- box jitter: each box side moves by ``N(0, jitter_px)`` [px] (image pixels, x right, y down);
- missed detections: each visible object is dropped with probability ``miss``;
- false detections: with probability ``false_rate`` per photo, one box of a plausible class where
  there is nothing (30-120 px wide and high, in the lower two thirds of the image), its mask the box.

The depth map is left exact (the depth model's own error is the ranging's business). One module for
the bench and the console's ``--perception noisy`` so both rehearse the same thing.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Callable, Sequence

import numpy as np

PERCEPTION_MODES = ("exact", "noisy")
"""Values of ``--perception``: the renderer's ground truth as it is, or with :class:`PerceptionNoise`."""

FALSE_LABELS: tuple[str, ...] = ("office_chair", "suitcase", "compressor")
"""Classes a false detection takes (catalog class names found in offices)."""


@dataclass(frozen=True)
class PerceptionNoise:
    """How noisy the simulated perception is.

    Attributes:
        jitter_px: 1-sigma of each box side's shift [px].
        miss: Probability that a visible object is not detected, in ``[0, 1]``.
        false_rate: Probability of one false detection in a photo, in ``[0, 1]``.
    """

    jitter_px: float = 2.0
    miss: float = 0.1
    false_rate: float = 0.4

    def __post_init__(self) -> None:
        for name, hi in (("jitter_px", math.inf), ("miss", 1.0), ("false_rate", 1.0)):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) or not 0 <= v <= hi:
                bound = "a finite number >= 0" if hi == math.inf else f"a number in [0, {hi:g}]"
                raise ValueError(f"PerceptionNoise.{name}: must be {bound}, got {v!r}")

    def apply(self, boxes: Sequence[Sequence[float]], labels: Sequence[str], masks: Sequence[np.ndarray] | None,
              image_size: tuple[int, int], rng: np.random.Generator
              ) -> tuple[list[np.ndarray], list[str], list[np.ndarray] | None]:
        """The detections a noisy detector would report: ``(boxes [px], labels, masks)``.

        Args:
            boxes: Exact ``(x1, y1, x2, y2)`` boxes [px].
            labels: Their catalog class names.
            masks: Their ``bool`` HxW instance masks, or ``None``.
            image_size: ``(width, height)`` [px].
            rng: The random source (seed it for a repeatable run).
        """
        w, h = image_size
        out_b: list[np.ndarray] = []
        out_l: list[str] = []
        out_m: list[np.ndarray] = []
        for k, (box, label) in enumerate(zip(boxes, labels)):
            if rng.random() < self.miss:
                continue
            b = np.clip(np.asarray(box, dtype=np.float64) + rng.normal(0.0, self.jitter_px, 4), 0, [w, h, w, h])
            out_b.append(np.array([min(b[0], b[2]), min(b[1], b[3]), max(b[0], b[2]) + 1, max(b[1], b[3]) + 1]))
            out_l.append(str(label))
            if masks is not None:
                out_m.append(masks[k])
        if rng.random() < self.false_rate:
            bw, bh = rng.uniform(30, 120, 2)
            x0, y0 = rng.uniform(0, w - bw), rng.uniform(h / 3, h - bh)
            out_b.append(np.array([x0, y0, x0 + bw, y0 + bh]))
            out_l.append(str(rng.choice(list(FALSE_LABELS))))
            if masks is not None:
                m = np.zeros((h, w), dtype=bool)
                m[int(y0):int(y0 + bh), int(x0):int(x0 + bw)] = True
                out_m.append(m)
        return out_b, out_l, (out_m if masks is not None else None)


def noisy_bundle_for(noise: PerceptionNoise | None = None, seed: int | None = None) -> Callable[[Any], Any]:
    """A ``bundle_for(shot)`` serving a simulator render's ground truth through ``noise``.

    The shot is a :class:`~console.link.base.CaptureResult` whose ``ground_truth`` carries ``visible``
    (boxes, labels, instance indices), ``instances`` and ``depth``. ``seed`` makes the sequence of
    photos repeatable (``None``: a fresh one per console). Raises ``ValueError`` for a photo without
    ground truth (a real camera's).
    """
    from pipeline.models.ground_truth import ground_truth_bundle

    model = noise or PerceptionNoise()
    rng = np.random.default_rng(seed)

    def bundle_for(shot: Any) -> Any:
        gt = getattr(shot, "ground_truth", None)
        if gt is None:
            raise ValueError("this photo carries no ground truth: --perception noisy needs the simulator's renders")
        h, w = shot.image.shape[:2]
        masks = [gt.instances == v.index for v in gt.visible] if gt.instances is not None else None
        boxes, labels, masks = model.apply([v.bbox for v in gt.visible], [v.label for v in gt.visible], masks,
                                           (w, h), rng)
        return ground_truth_bundle(boxes, labels, masks if masks else None, gt.depth)

    return bundle_for


__all__ = ["FALSE_LABELS", "PERCEPTION_MODES", "PerceptionNoise", "noisy_bundle_for"]
