"""Folding newly mapped objects into the session's scene: a thin caller of :mod:`pipeline.mapping.map_fusion`.

All objects are in the world frame [m]. The fusion itself (association, uncertainty-weighted update,
pinned objects, support, consistency) is pure and lives in the pipeline; the console only calls it.
"""

from __future__ import annotations

from pipeline.mapping.map_fusion import FusionReport, fuse
from pipeline.scene import Scene

__all__ = ["FusionReport", "fuse", "merge_observations", "merge_report"]


def merge_observations(scene: Scene, new: Scene) -> tuple[Scene, list[str], list[str]]:
    """Fold newly mapped world-frame objects into a scene; returns ``(scene, added_ids, updated_ids)``.

    The session's merge: never held back (the mapping job checks a capture's consistency before it
    spawns it; a scene file the operator loads is merged as asked). See :func:`pipeline.mapping.map_fusion.fuse`.
    """
    merged, report = fuse(scene, new, check_consistency=False)
    return merged, report.added, report.updated


def merge_report(scene: Scene, new: Scene) -> tuple[Scene, FusionReport]:
    """:func:`merge_observations` with the whole :class:`FusionReport` (what was merged into what, what was
    removed and why), for the session to follow merged and removed objects (:mod:`console.session.object_follow`)."""
    return fuse(scene, new, check_consistency=False)
