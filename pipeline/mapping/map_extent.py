"""An object's extent in the map: partial views that join it, new objects outside the workspace, new ids.

Pure functions used by :mod:`pipeline.mapping.map_fusion`. World frame (z up) [m]; boxes are
centre, size ``(w, h, l)`` and yaw about +z [rad] (the length ``l`` along the yaw heading, see
:mod:`pipeline.scene`); a camera is its centre in the world frame.

- :func:`along_ray_match`: a partial view (cut by the border, mostly hidden behind nearer objects, at
  the edge of the view) places its centre from the class size, so along its viewing ray it may be
  far from the mapped object's centre while still being a view of that object. It joins the object
  when the ray from the camera through its centre passes through the mapped box (widened by twice the
  across-ray sigma) and the two boxes' intervals along that ray overlap (the fusion uses this only
  when exactly one object of the class qualifies).
- :func:`outside_workspace`: how far a new object's footprint reaches out of the workspace's floor plan;
  an object whose centre is outside it is not added (the planner would ignore it; the operator is told
  why).
- :func:`keep_inside`: an update that carries an object's centre out of the workspace's floor plan is
  undone to the nearest point inside, and flagged.
- :func:`next_id`: a new object's id is the next number of its class (``cardboard_box-7``), above every
  number the class has had (:func:`id_numbers`, kept in the map's ``last_ids``): an id is never reused.
"""

from __future__ import annotations

import math
import re
from typing import Iterable, Mapping, Sequence

import numpy as np

from pipeline.scene import SceneObject

RAY_SIGMAS = 2.0
"""How many across-ray sigmas a partial view's ray may pass beside a mapped box."""


def _axes(obj: SceneObject) -> tuple[np.ndarray, np.ndarray]:
    """The box's unit axes (length, width, up) as rows, and their half sizes [m]."""
    w, h, l = obj.size
    c, s = math.cos(obj.yaw), math.sin(obj.yaw)
    axes = np.array([[c, s, 0.0], [-s, c, 0.0], [0.0, 0.0, 1.0]])
    return axes, np.array([l / 2, w / 2, h / 2])


def half_extent(obj: SceneObject, direction: Sequence[float]) -> float:
    """Half the box's extent [m] along a unit ``direction`` (its support function)."""
    axes, half = _axes(obj)
    return float(np.abs(axes @ np.asarray(direction, dtype=np.float64)) @ half)


def ray_interval(camera: Sequence[float], direction: Sequence[float], obj: SceneObject,
                 margin: float = 0.0) -> tuple[float, float] | None:
    """Where the ray ``camera + t * direction`` (unit direction, ``t >= 0`` [m]) is inside the box
    widened by ``margin`` [m] on every side: ``(t_in, t_out)``, or ``None`` if it misses it."""
    axes, half = _axes(obj)
    o = axes @ (np.asarray(camera, dtype=np.float64) - np.asarray(obj.position, dtype=np.float64))
    d = axes @ np.asarray(direction, dtype=np.float64)
    lo, hi = 0.0, math.inf
    for k in range(3):
        ext = half[k] + margin
        if abs(d[k]) < 1e-12:
            if abs(o[k]) > ext:
                return None
            continue
        t1, t2 = (-ext - o[k]) / d[k], (ext - o[k]) / d[k]
        lo, hi = max(lo, min(t1, t2)), min(hi, max(t1, t2))
        if lo > hi:
            return None
    return lo, hi


def along_ray_match(obs: SceneObject, camera: Sequence[float] | None, across: float, obj: SceneObject) -> bool:
    """Whether the partial view ``obs`` (seen from ``camera``, across-ray sigma ``across`` [m]) may be a
    view of the mapped ``obj``: its viewing ray passes through ``obj``'s box (widened by
    :data:`RAY_SIGMAS` across-ray sigmas) and the two boxes' intervals along the ray overlap. The class
    and whether only one object qualifies are the caller's checks."""
    if camera is None:
        return False
    ray = np.asarray(obs.position, dtype=np.float64) - np.asarray(camera, dtype=np.float64)
    dist = float(np.linalg.norm(ray))
    if not dist > 1e-9:
        return False
    u = ray / dist
    hit = ray_interval(camera, u, obj, RAY_SIGMAS * across)
    if hit is None:
        return False
    r = half_extent(obs, u)
    return min(hit[1], dist + r) > max(hit[0], dist - r)


def outside_workspace(obj: SceneObject, lo: Sequence[float], hi: Sequence[float]) -> tuple[bool, float]:
    """``(centre outside, how far [m] the footprint reaches beyond the workspace)`` in the floor plan
    (world x, y; ``lo``/``hi`` the workspace box's corners, only their x, y used): the height is the
    support rules' business (a mat estimated 1 cm under the floor is set on it, not dropped)."""
    axes, half = _axes(obj)
    c = np.asarray(obj.position, dtype=np.float64)[:2]
    corners = np.array([c + (axes[0, :2] * half[0] * a + axes[1, :2] * half[1] * b) for a in (1, -1) for b in (1, -1)])
    lo_a, hi_a = np.asarray(lo, dtype=np.float64)[:2], np.asarray(hi, dtype=np.float64)[:2]
    beyond = np.maximum(lo_a - corners, 0.0) + np.maximum(corners - hi_a, 0.0)
    centre_out = bool(np.any(c < lo_a) or np.any(c > hi_a))
    return centre_out, float(np.linalg.norm(beyond, axis=1).max())


def keep_inside(objects: list[SceneObject], ids: Iterable[str], lo: Sequence[float], hi: Sequence[float]
                ) -> list[tuple[str, str]]:
    """Move (in place) each object of ``ids`` whose centre left the workspace's floor plan back onto its edge.

    A new object with its centre outside is not added (:func:`outside_workspace`); an update can still
    carry one out (a box at the end of a line, seen mostly hidden from the side, put beyond the wall).
    The room holds its objects, so the estimate is the nearest point inside (world x, y; ``lo``/``hi``
    the workspace corners). Returns ``(id, what was corrected)`` per object moved (also its flag).
    """
    from dataclasses import replace

    wanted = set(ids)
    out: list[tuple[str, str]] = []
    for n, o in enumerate(objects):
        if o.id not in wanted or o.is_pinned:
            continue
        x, y = (min(max(o.position[a], lo[a]), hi[a]) for a in (0, 1))
        far = math.hypot(x - o.position[0], y - o.position[1])
        if far > 0:
            what = f"its views put its centre {far:.2f} m outside the workspace: kept at its edge"
            objects[n] = replace(o, position=(x, y, o.position[2]), flags=o.flags + (what,))
            out.append((o.id, what))
    return out


_NUMBERED = re.compile(r"^(.*)-(\d+)$")


def id_numbers(objects: Iterable[SceneObject], last: Mapping[str, int] | None = None) -> dict[str, int]:
    """Highest id number per class: ``last`` (a map's :attr:`~pipeline.scene.Scene.last_ids`) raised by
    the ``{label}-{n}`` ids of ``objects`` (an id of another form, a scene file's own, has no number)."""
    out = dict(last or {})
    for o in objects:
        m = _NUMBERED.match(o.id)
        if m is not None and m.group(1) == o.label:
            out[o.label] = max(out.get(o.label, 0), int(m.group(2)))
    return out


def next_id(wanted: str, label: str, taken: Iterable[str], last: Mapping[str, int] | None = None) -> str:
    """A new object's id, never one another object has had.

    Args:
        wanted: The mapper's ``{label}-{n}`` of its photo, or a scene file's own id.
        label: Its class.
        taken: The ids in the map now.
        last: Highest number each class's ids have had in the map's life (:func:`id_numbers` of the
            map before this capture): a ``{label}-{n}`` with ``n`` at most that was an object merged or
            removed since.

    Returns:
        ``wanted`` when no object has or had it, else the class's next number ``{label}-{n}`` (one more
        than the highest the class has had); never a compound id like ``cardboard_box-3-3``.
    """
    ids = set(taken)
    high = (last or {}).get(label, 0)
    m = _NUMBERED.match(wanted)
    had = m is not None and m.group(1) == label and int(m.group(2)) <= high
    if wanted not in ids and not had:
        return wanted
    top = high
    for t in ids:
        m = _NUMBERED.match(t)
        if m is not None and m.group(1) == label:
            top = max(top, int(m.group(2)))
    return f"{label}-{top + 1}"


__all__ = ["RAY_SIGMAS", "along_ray_match", "half_extent", "id_numbers", "keep_inside", "next_id", "outside_workspace",
           "ray_interval"]
