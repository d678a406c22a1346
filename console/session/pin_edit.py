"""Pin and Unpin: the operator says whether captures may move an object (mixed into the session).

A **pinned** object (:attr:`pipeline.scene.SceneObject.is_pinned`) is never moved by the map fusion: the
operator placed, moved or typed it, or a scene file gave it (``source.method == "manual"``), or pinned it.
**Unpin** releases it: later captures that see it correct its position again (its sightings weigh as a
mapped object's, :mod:`pipeline.mapping.observation_sigma`). An object the operator had placed keeps its
position and is marked ``source.method = "unpinned"`` (``manual`` would pin it again); any other method is
kept. **Pin** sets the flag (``pinned: true`` in the scene file). Both are map edits: the planning grid is
rebuilt (a pinned object gets no uncertainty margin, :mod:`planner.map_uncertainty`), and Undo / Redo take
them back like a move (``Undo unpin box-3``). World frame [m].
"""

from __future__ import annotations

from dataclasses import replace

from pipeline.mapping.map_fusion import pinned
from pipeline.scene import SceneObject

from console.session.session_core import SessionCore
from console.session.session_types import SessionError
from console.session.topics import GRID, MISSION, ROUTE, SCENE, SELECTION

UNPINNED_METHOD = "unpinned"
"""``source.method`` of an object the operator placed and then released to the captures."""


def with_pin(obj: SceneObject, value: bool) -> SceneObject:
    """``obj`` pinned (``value``) or released: :attr:`~pipeline.scene.SceneObject.is_pinned` then equals ``value``."""
    out = pinned(obj, value)
    if not value and out.source.method == "manual":
        out = replace(out, source=replace(out.source, method=UNPINNED_METHOD))
    return out


class PinEdits(SessionCore):
    """The Pin / Unpin edit of :class:`~console.session.session.Session` (mixed into it)."""

    def set_pinned(self, object_id: str, value: bool) -> list[str]:
        """Pin (``value``) or unpin the object ``object_id``, undoably; returns the grid rebuild's notes.

        Raises:
            SessionError: No such object (``no object 'box-3' in the map ...``), or it is pinned (unpinned)
                already (``box-3 is pinned already``); nothing changes then.
        """
        verb = "pin" if value else "unpin"
        with self._lock:
            try:
                obj = self._scene.object(object_id)
            except KeyError:
                raise SessionError(f"no object {object_id!r} in the map (was it deleted in another tab?)") from None
            if obj.is_pinned == bool(value):
                raise SessionError(f"{object_id} is {'pinned' if value else 'not pinned'} already: nothing to {verb}")
            objs = [with_pin(o, bool(value)) if o.id == object_id else o for o in self._scene.objects]
            notes = self._set_scene_locked(self._scene.with_objects(objs), f"{verb} {object_id}")  # type: ignore[attr-defined]
        self._emit([(SCENE, None), (GRID, None), (ROUTE, None), (MISSION, None), (SELECTION, object_id)])
        return notes


__all__ = ["PinEdits", "UNPINNED_METHOD", "with_pin"]
