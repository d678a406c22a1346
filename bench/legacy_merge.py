"""The merge the console used before issue 12 (kept only so bench/sim_mapping.py --tour can compare).

Newest estimate wins: a re-sighting within max(0.6 m, half the footprint diagonal) of the same label
replaces the object (an uncut view is not replaced by a cut one); manual objects are never matched
(a re-sighting of one is added as a second object). World frame [m]. Not used by the console.
"""

from __future__ import annotations

import math
from dataclasses import replace

from pipeline.scene import Scene, SceneError, SceneObject


def merge_observations(scene: Scene, new: Scene, *, match_radius: float = 0.6) -> tuple[Scene, list[str], list[str]]:
    """Fold newly mapped world-frame objects into a scene.

    A new object replaces an existing one with the same id from the same capture (the same file
    loaded again; only an object the scene held before this merge and not yet replaced by it), or
    else the nearest existing object of the same label whose centre lies within
    ``match_radius`` [m] (or half the larger object's footprint diagonal, if bigger) — the same thing
    seen again. Ids from different captures say nothing (every capture numbers its objects from 1).
    A view cut by the image border never replaces an uncut view of the same object (a truncated box
    gives a biased position). Objects the operator placed or moved by hand
    (``source.method == "manual"``) are never replaced. Everything else is added; clashing ids get a
    suffix. Returns ``(scene, added_ids, updated_ids)``.
    """
    sizes = {c.id: (c.intrinsics.get("width"), c.intrinsics.get("height")) for c in scene.captures + new.captures}

    def cut(o: SceneObject) -> bool:
        w, h = sizes.get(o.source.capture or "", (None, None))
        b = o.source.bbox
        if b is None or not w or not h:
            return False
        return b[0] <= 2 or b[1] <= 2 or b[2] >= w - 2 or b[3] >= h - 2

    objects = list(scene.objects)
    index = {o.id: n for n, o in enumerate(objects)}
    added: list[str] = []
    updated: list[str] = []
    claimed: set[int] = set()
    for obj in new.objects:
        if obj.frame != "world":
            raise SceneError(f"objects[{obj.id}].frame", f"must be world to spawn, got {obj.frame}")
        target: int | None = index.get(obj.id)
        # the id rule holds only for an object of the scene as it was before this merge: once
        # replaced or added here it carries the new capture's id, and another new object sharing
        # that id is a different thing (ids of a capture are unique)
        if target is not None and (target in claimed or objects[target].source.capture != obj.source.capture):
            target = None
        if target is None:
            best = math.inf
            for n, old in enumerate(objects):
                if n in claimed or old.label != obj.label or old.source.method == "manual":
                    continue
                d = math.dist(old.position, obj.position)  # 3D: stacked boxes share x, y
                reach = max(match_radius, 0.5 * math.hypot(max(old.size[0], obj.size[0]), max(old.size[2], obj.size[2])))
                if d <= reach and d < best:
                    best, target = d, n
        elif objects[target].source.method == "manual":
            target = None
            obj = replace(obj, id=f"{obj.id}-seen")
        if target is not None:
            if not (cut(obj) and not cut(objects[target])):
                objects[target] = replace(obj, id=objects[target].id)
            claimed.add(target)
            updated.append(objects[target].id)
            continue
        new_id, k = obj.id, 1
        while new_id in index:
            k += 1
            new_id = f"{obj.id}-{k}"
        objects.append(replace(obj, id=new_id))
        index[new_id] = len(objects) - 1
        claimed.add(len(objects) - 1)
        added.append(new_id)
    known = {c.id for c in scene.captures}
    captures = scene.captures + tuple(c for c in new.captures if c.id not in known)
    return Scene(objects=tuple(objects), captures=captures), added, updated
