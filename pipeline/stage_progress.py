"""Progress of one mapping run, stage by stage, for a caller that shows it (a console's progress bar).

:meth:`pipeline.mapper.Mapper.run` calls ``on_stage(name)`` as each stage of :data:`STAGES` begins,
in that order, each exactly once per run (a stage with nothing to do, e.g. segmentation when no
distance needs a mask, is still announced and ends at once). :class:`StageFractions` turns a stage
name into the share of the run done when it begins, from the measured time budget per stage
(:data:`STAGE_BUDGET_S`), so a bar moves roughly in proportion to time.

A callback that raises is logged and dropped for the rest of the run: progress display must never
fail a mapping run.
"""

from __future__ import annotations

import logging
from typing import Callable, Mapping

log = logging.getLogger(__name__)

STAGES: tuple[str, ...] = ("detect", "segment", "depth", "distance")
"""The stages a mapping run announces, in order."""

StageCallback = Callable[[str], None]
"""``on_stage(stage name)``: called as the stage begins; the name is one of :data:`STAGES`."""

STAGE_BUDGET_S: Mapping[str, float] = {"detect": 0.045, "segment": 0.005, "depth": 0.02, "distance": 0.01}
"""Time budget per stage for a 640 x 480 photo on 2 cores with the offline models and
``segment="auto"`` [s] (README, "Mapping speed"): YOLOX-Nano on the whole image and its tiles with
the Open Images SSD beside it (35 ms median for both, measured with ``bench/pipeline_speed.py``),
MobileSAM only on the rare photo where a mask changes a distance, FastDepth, then the distance cues
and their fusion. Sum: 0.08 s, under the 0.10 s target."""


class StageFractions:
    """Share of a mapping run done as each stage begins, weighted by :data:`STAGE_BUDGET_S`.

    Args:
        budget: Seconds per stage (every name of :data:`STAGES`, finite and > 0).

    Raises:
        ValueError: A stage is missing, or its budget is not a finite number > 0 (the message names it).
    """

    def __init__(self, budget: Mapping[str, float] = STAGE_BUDGET_S) -> None:
        total = 0.0
        for name in STAGES:
            v = budget.get(name)
            if not isinstance(v, (int, float)) or isinstance(v, bool) or not (0.0 < float(v) < float("inf")):
                raise ValueError(f"budget.{name}: must be a finite number of seconds > 0, got {v!r}")
            total += float(v)
        start, self._start = 0.0, {}
        for name in STAGES:
            self._start[name] = start / total
            start += float(budget[name])

    def at_start(self, stage: str) -> float:
        """Fraction of the run in [0, 1) done when ``stage`` begins.

        Raises:
            ValueError: ``stage`` is not one of :data:`STAGES`.
        """
        if stage not in self._start:
            raise ValueError(f"stage: must be one of {', '.join(STAGES)}, got {stage!r}")
        return self._start[stage]


def stage_reporter(on_stage: StageCallback | None) -> StageCallback:
    """``on_stage`` made safe to call from the mapper: a no-op for ``None``; a callback that raises
    is logged once and not called again (the run goes on)."""
    if on_stage is None:
        return lambda stage: None
    broken = [False]

    def report(stage: str) -> None:
        if broken[0]:
            return
        try:
            on_stage(stage)
        except Exception:
            broken[0] = True
            log.exception("stage progress callback failed at %r; no more progress for this run", stage)

    return report
