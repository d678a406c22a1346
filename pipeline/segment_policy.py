"""Which detections the mapper segments (``MapperConfig.segment``), so the MobileSAM encoder (0.85 s of
a 0.98 s photo on 2 cores) runs only on photos where a mask changes a result.

``auto`` (the default) asks for a mask where:

- the distance depends on it (:meth:`pipeline.ranging.ranger.Ranger.needs_mask`: an object of unknown size,
  whose extent is measured from the mask, or a box the border cuts on both axes, ranged from the
  depth under the mask alone); a known-size object's distance comes from its box (size prior, floor
  contact) and the depth over the middle of its box;
- the depth is exact (a simulator's ground truth, whose masks cost nothing): it decides every
  distance, read under the mask, and the yaw is fitted to the mask's depth points;
- ``yaw_from_depth`` is forced on: the yaw is fitted to the mask's depth points.

On the dev bench this keeps the accuracy of ``all`` (same median error with and without dataset
boxes) and leaves the encoder out of 22 of 26 photo runs (README, "Mapping speed").
"""

from __future__ import annotations

from typing import Any, Callable


def mask_wanted(config: Any, det: Any, width: int, height: int, needs_mask: Callable[[Any, int, int], bool],
                exact_depth: bool) -> bool:
    """Whether detection ``det`` of a ``width`` x ``height`` [px] photo gets a mask.

    Args:
        config: The :class:`~pipeline.mapper_config.MapperConfig`.
        det: The detection (``score``, ``width``, ``height`` [px]).
        needs_mask: Whether the distance of ``det`` depends on its mask (``Ranger.needs_mask``).
        exact_depth: The depth map is exact metric depth.
    """
    if config.segment == "none" or det.score < config.segment_min_score or det.width < 2 or det.height < 2:
        return False
    if config.segment == "all":
        return True
    return exact_depth or config.yaw_from_depth is True or needs_mask(det, width, height)
