"""Scene graph: objects, what they stand on, how they relate, groups and reachability.

Built from a world-frame :class:`~pipeline.scene.Scene` and, when given, the robot pose
(``world <- robot``: position [m] and yaw [rad] about +z, the robot's x axis forward) and the
planning grid. The result is a JSON-ready dict (schema :data:`GRAPH_SCHEMA_VERSION`, see
:mod:`planner.scene_graph_schema`), for people (through :mod:`planner.scene_summary`) and for
language models.

Deterministic rules and their thresholds (all module constants):

- **Support**: an object stands on the floor when its bottom is within :data:`SUPPORT_TOL` of the
  floor; else on the object whose top is within :data:`SUPPORT_TOL` of its bottom and whose
  footprint covers at least :data:`SUPPORT_OVERLAP` of its own (the highest such top, then the
  largest overlap); else it is unsupported. ``A on_top_of B`` and ``B under A`` follow from it.
  Each object's ``placement`` (:data:`PLACEMENTS`) is ``below_floor`` when its bottom lies more
  than :data:`SUPPORT_TOL` below the floor, whatever it rests on (it is sunk into the floor, or
  wholly under it: a mapping error, stated as an uncertainty); else ``on_floor``, ``on_object``,
  or ``floating`` (unsupported with its bottom above the floor: an uncertainty too).
  ``floor_gap`` is its bottom minus the floor [m], negative below the floor.
- **next_to** (symmetric, listed once): footprints at most :data:`NEXT_TO_GAP` apart
  horizontally, their height ranges overlapping, and neither standing on the other.
- **As seen from the robot** (only with a robot pose): each object's footprint spans an interval
  of bearings. ``A behind B``: the intervals overlap by at least :data:`BEHIND_OVERLAP` of the
  narrower one, A's centre is at least :data:`BEHIND_DEPTH` farther and its nearest corner farther
  than B's, and their footprints lie at most :data:`BEHIND_GAP` apart (an object far behind another
  is not stated "behind" it; visibility still counts it); ``B in_front_of A`` is the inverse. ``A left_of B``: the intervals do not overlap,
  A's lies to the left, and the footprints are at most :data:`SIDE_GAP` apart (``B right_of A``).
- **Direction** from the robot: the bearing of the centre (robot frame, left positive) in eight
  45-degree sectors: ahead, ahead-left, left, behind-left, behind, ... (:func:`direction`).
- **Visibility**: the fraction of an object's bearing interval covered by nearer objects (per
  the behind rule) whose top is at least as high: ``hidden`` from :data:`HIDDEN_FRACTION`,
  ``partly_hidden`` from :data:`PARTLY_FRACTION`, else ``visible``.
- **Groups**: objects of one label joined by footprints at most :data:`GROUP_GAP` apart (or
  stacked), :data:`GROUP_MIN` or more: ``stack`` (one column), ``line`` (columns within
  :data:`LINE_WIDTH` of a straight line) or ``cluster``. A line ``crosses the workspace`` when both
  ends are within :data:`WALL_GAP` of opposite workspace walls. Relations between members of one
  group are left out; relations of an outside object to several members are stated once, against
  the group (left / right are not stated for groups). A group's id is ``group-`` and its first member
  in natural order (:func:`group_id`: ``group-cardboard_box-3``), so it keeps its name from capture to
  capture while that member stays.
- **Reachability** (with a robot pose and a grid): walk, fly or none, by
  :class:`planner.object_goal.Reachability` (the Aerial-Ground A*'s own connectivity and costs; the
  path itself, its cost and landing spot, is planned for the :data:`PLAN_MAX` nearest objects only);
  when unreachable, ``reach.code`` (:data:`planner.object_goal.REASONS`) and ``reach.reason`` say
  why: outside the planning workspace, no free floor beside it, closed in, cramped, walled off...
- **Uncertainties**: detector score below :data:`LOW_SCORE`, a size not from the catalog, a
  position from the depth map only, an object that seems to float or lies below the floor (how
  far, in words: never a negative height "above" the floor), a fused horizontal position
  error of :data:`SIGMA_WARN` or more (:func:`position_sigma`; not for pinned objects), and the
  map fusion's corrections (the object's ``flags``).
"""

from __future__ import annotations

import math
import re
from collections import defaultdict
from typing import Any, Sequence

import numpy as np

from pipeline.scene import Scene, SceneObject

from planner.graph_index import behind_mask, footprint_gaps, near_pairs, neighbours, overlapping_bearings
from planner.grid import PlanningGrid
from planner.map_uncertainty import position_sigma  # noqa: F401  (also read here by console.mcp)
from planner.object_goal import Reachability, footprint
from planner.route import Route
from planner.view_geometry import RobotView, overlap_fraction

GRAPH_SCHEMA_VERSION = 2
"""Version 2 added ``placement`` and ``floor_gap`` to objects and ``code`` to ``reach``."""
PLACEMENTS = ("on_floor", "on_object", "floating", "below_floor")
SUPPORT_TOL = 0.10  # [m]
SUPPORT_OVERLAP = 0.30  # fraction of the upper footprint
NEXT_TO_GAP = 0.50  # [m]
BEHIND_OVERLAP = 0.25  # fraction of the narrower bearing interval
BEHIND_DEPTH = 0.30  # [m]
BEHIND_GAP = 3.0  # [m] farthest footprint gap of a stated behind / in_front_of pair
PLAN_MAX = 100
"""Objects nearest the robot whose approach path is planned with the A* (cost, walk+fly, landing); the
others' reachability (walk / fly / none and why) comes from the grid's connectivity alone."""
SIDE_GAP = 1.00  # [m]
HIDDEN_FRACTION = 0.90
PARTLY_FRACTION = 0.25
GROUP_GAP = 0.30  # [m]
GROUP_MIN = 3
LINE_WIDTH = 0.30  # [m]
WALL_GAP = 0.50  # [m]
LOW_SCORE = 0.50
SIGMA_WARN = 0.25  # [m] horizontal 1-sigma position error worth stating
COLUMN_TOL = 0.25  # [m]: members whose centres are this close horizontally form one column
SECTORS = ("ahead", "ahead-left", "left", "behind-left", "behind", "behind-right", "right", "ahead-right")

RobotPose = tuple[float, float, float, float]
"""``(x, y, z, yaw)``: world position [m] and heading [rad] about +z (the robot's x axis)."""


class SceneGraphError(ValueError):
    """Bad input to the graph builder; ``field`` names it."""


def check_robot(robot: Sequence[float]) -> RobotPose:
    """A validated robot pose ``(x, y, z, yaw [rad])``; raises naming the bad component."""
    names = ("robot.x", "robot.y", "robot.z", "robot.yaw")
    if len(robot) != 4:
        raise SceneGraphError(f"robot: expected x, y, z, yaw, got {len(robot)} values")
    out = []
    for name, v in zip(names, robot):
        try:
            f = float(v)
        except (TypeError, ValueError):
            raise SceneGraphError(f"{name}: must be a number, got {v!r}") from None
        if not math.isfinite(f):
            raise SceneGraphError(f"{name}: must be finite, got {v!r}")
        out.append(f)
    return (out[0], out[1], out[2], out[3])


def direction(bearing: float) -> str:
    """Sector name of a bearing [rad] in the robot frame (0 ahead, positive to the left)."""
    deg = math.degrees(bearing) % 360.0
    return SECTORS[int(((deg + 22.5) % 360.0) // 45.0)]


def _bottom(o: SceneObject) -> float:
    return o.position[2] - o.size[1] / 2


def _top(o: SceneObject) -> float:
    return o.position[2] + o.size[1] / 2


def placement(on: str | None, floor_gap: float) -> str:
    """One of :data:`PLACEMENTS` for an object standing on ``on`` (``"floor"``, an id or ``None``)
    whose bottom is ``floor_gap`` [m] above the floor (negative below it)."""
    if floor_gap < -SUPPORT_TOL:
        return "below_floor"
    return "on_floor" if on == "floor" else "floating" if on is None else "on_object"


def placement_text(kind: str, floor_gap: float, height: float) -> str:
    """The placement problem of an object in words (``""`` when there is none): ``floor_gap`` [m]
    is its bottom above the floor (negative below), ``height`` [m] its own height."""
    if kind == "floating":
        return f"seems to float {floor_gap:.2f} m above the floor with nothing under it"
    if kind != "below_floor":
        return ""
    depth = -floor_gap
    if depth >= height:
        return (f"lies entirely below the floor (its top {depth - height:.2f} m under it, its bottom "
                f"{depth:.2f} m): likely a mapping error")
    return f"sunk {depth:.2f} m into the floor: likely a mapping error"


def natural_key(text: str) -> tuple[Any, ...]:
    """Sort key that orders ``box-2`` before ``box-10``."""
    return tuple((0, int(t), "") if t.isdigit() else (1, 0, t) for t in re.split(r"(\d+)", text) if t)


def _r(v: float, nd: int = 3) -> float:
    return round(float(v), nd)


def _support(objs: Sequence[SceneObject], floor: float) -> list[tuple[str | None, float]]:
    """For each object: ``("floor" | id | None, gap [m])``; only objects whose footprints may overlap
    are compared (:func:`planner.graph_index.near_pairs`)."""
    out: list[tuple[str | None, float]] = []
    close = neighbours(len(objs), near_pairs(objs, 0.0))
    for n, a in enumerate(objs):
        bot = _bottom(a)
        if abs(bot - floor) <= SUPPORT_TOL:
            out.append(("floor", _r(bot - floor)))
            continue
        best: tuple[float, float, str] | None = None
        for b in (objs[k] for k in close[n]):
            if b is a or abs(_top(b) - bot) > SUPPORT_TOL:
                continue
            frac = overlap_fraction(a, b)
            if frac >= SUPPORT_OVERLAP:
                key = (_top(b), frac, b.id)
                if best is None or key[:2] > best[:2]:
                    best = key
        if best is not None:
            out.append((best[2], _r(bot - best[0])))
        else:
            out.append((None, _r(bot - floor)))
    return out


def _groups(objs: Sequence[SceneObject], gaps: dict[tuple[int, int], float], support: list[tuple[str | None, float]],
            grid: PlanningGrid | None) -> list[dict[str, Any]]:
    ids = {o.id: n for n, o in enumerate(objs)}
    parent = list(range(len(objs)))

    def find(i: int) -> int:
        while parent[i] != i:
            parent[i] = parent[parent[i]]
            i = parent[i]
        return i

    def join(a: int, b: int) -> None:
        ra, rb = find(a), find(b)
        if ra != rb:
            parent[max(ra, rb)] = min(ra, rb)

    for (a, b), gap in gaps.items():
        if objs[a].label == objs[b].label and gap <= GROUP_GAP:
            join(a, b)
    for n, (on, _) in enumerate(support):
        if on not in (None, "floor") and objs[ids[on]].label == objs[n].label:
            join(n, ids[on])
    members: dict[int, list[int]] = defaultdict(list)
    for n in range(len(objs)):
        members[find(n)].append(n)
    out: list[dict[str, Any]] = []
    for root in sorted(members):
        mem = members[root]
        if len(mem) < GROUP_MIN:
            continue
        out.append(_describe_group(group_id([objs[n].id for n in mem]), [objs[n] for n in mem], grid))
    return out


def group_id(members: Sequence[str]) -> str:
    """A group's id: ``group-`` and its first member id in natural order (``group-cardboard_box-3``).

    Stable while that member stays in the group: the map fusion never renames an object and gives a new
    one the next free number of its class, so a box mapped later joins as a later member; the name
    depends on the map alone, so a restart (the map saved and loaded) keeps it. It changes only when that
    member leaves the group (deleted, moved away, merged) or two groups join (the joint group takes the
    first member of both).
    """
    return "group-" + min(members, key=natural_key)


def _describe_group(gid: str, mem: list[SceneObject], grid: PlanningGrid | None) -> dict[str, Any]:
    xy = np.array([o.position[:2] for o in mem])
    cols: list[np.ndarray] = []
    for p in xy:
        if not any(np.hypot(*(c - p)) <= COLUMN_TOL for c in cols):
            cols.append(p)
    corners = np.concatenate([footprint(o) for o in mem])
    centre = corners.mean(axis=0)
    kind, axis = "cluster", np.array([1.0, 0.0])
    if len(cols) == 1:
        kind = "stack"
    else:
        c = np.array(cols)
        _, _, vt = np.linalg.svd(c - c.mean(axis=0))
        axis = vt[0]
        off = np.abs((c - c.mean(axis=0)) @ np.array([-axis[1], axis[0]]))
        if off.max() <= LINE_WIDTH:
            kind = "line"
    along = (corners - centre) @ axis
    across = (corners - centre) @ np.array([-axis[1], axis[0]])
    g: dict[str, Any] = {
        "id": gid, "kind": kind, "label": mem[0].label, "members": sorted((o.id for o in mem), key=natural_key),
        "columns": len(cols),
        "centre": [_r(centre[0]), _r(centre[1]), _r((min(map(_bottom, mem)) + max(map(_top, mem))) / 2)],
        "length": _r(float(along.max() - along.min())), "width": _r(float(across.max() - across.min())),
        "height": _r(max(map(_top, mem)) - min(map(_bottom, mem))),
        "axis_deg": _r(math.degrees(math.atan2(axis[1], axis[0])) % 180.0, 1),
        "crosses_workspace": False,
    }
    if kind == "line" and grid is not None:
        ws = grid.workspace
        ends = [centre + axis * along.min(), centre + axis * along.max()]
        for a in (0, 1):
            lo_end = min(ends, key=lambda e: e[a])
            hi_end = max(ends, key=lambda e: e[a])
            if lo_end[a] - ws.min[a] <= WALL_GAP and ws.max[a] - hi_end[a] <= WALL_GAP:
                g["crosses_workspace"] = True
    return g


def build_scene_graph(scene: Scene, robot: Sequence[float] | None = None, grid: PlanningGrid | None = None,
                      route: Route | None = None, floor: float | None = None) -> dict[str, Any]:
    """The scene graph of a world-frame scene (see the module docstring for the rules).

    Args:
        scene: Objects in the world frame.
        robot: ``(x, y, z, yaw)`` robot pose (world [m], heading [rad]) or ``None`` (no distances,
            directions, views or reachability).
        grid: Planning grid for reachability (and the workspace floor and walls), or ``None``.
        route: A route on ``grid`` whose costs the reachability uses (default costs otherwise).
        floor: Floor height [m] (default the grid's floor, else 0).

    Returns:
        A JSON-ready dict: ``schema``, ``version``, ``frame``, ``robot``, ``workspace``, ``objects``,
        ``relations``, ``groups``, ``uncertainties``; lists in a deterministic order.
    """
    for o in scene.objects:
        if o.frame != "world":
            raise SceneGraphError(f"objects[{o.id}].frame: the scene graph needs world-frame objects, got {o.frame}")
    pose = check_robot(robot) if robot is not None else None
    objs = sorted(scene.objects, key=lambda o: natural_key(o.id))
    fl = float(floor) if floor is not None else (grid.workspace.floor if grid is not None else 0.0)
    n = len(objs)
    support = _support(objs, fl)
    place = [placement(on, _bottom(o) - fl) for o, (on, _) in zip(objs, support)]
    feet = [footprint(o) for o in objs]
    gaps: dict[tuple[int, int], float] = {}
    # only pairs whose centres lie within both half-diagonals plus the largest gap (a KD-tree search)
    pairs = near_pairs(objs, max(NEXT_TO_GAP, SIDE_GAP, GROUP_GAP, BEHIND_GAP))
    if pairs:
        fa = np.array([feet[a] for a, _ in pairs])
        fb = np.array([feet[b] for _, b in pairs])
        gaps = dict(zip(pairs, footprint_gaps(fa, fb).tolist()))
    groups = _groups(objs, gaps, support, grid)
    group_of = {m: g["id"] for g in groups for m in g["members"]}
    rel: set[tuple[str, str, str]] = set()

    def add(a: int, kind: str, b: int) -> None:
        sa, sb = objs[a].id, objs[b].id
        ga, gb = group_of.get(sa), group_of.get(sb)
        if ga is not None and ga == gb:
            return  # inside one group: implied by the group
        if (ga or gb) and kind in ("left_of", "right_of"):
            return  # a group spans too wide a view for left / right to say much
        rel.add((ga or sa, kind, gb or sb))

    idx = {o.id: k for k, o in enumerate(objs)}
    for a, (on, _) in enumerate(support):
        if on not in (None, "floor"):
            add(a, "on_top_of", idx[on])
            add(idx[on], "under", a)
    for (a, b), gap in gaps.items():
        if gap > NEXT_TO_GAP or support[a][0] == objs[b].id or support[b][0] == objs[a].id:
            continue
        if min(_top(objs[a]), _top(objs[b])) <= max(_bottom(objs[a]), _bottom(objs[b])):
            continue
        x, y = sorted((a, b), key=lambda k: group_of.get(objs[k].id, objs[k].id))
        add(x, "next_to", y)
    records: list[dict[str, Any]] = []
    view = RobotView(objs, pose, BEHIND_DEPTH, BEHIND_OVERLAP) if pose is not None else None
    reach = Reachability(grid, pose[:3], route, objs) if (pose is not None and grid is not None) else None
    planned: set[int] = set()  # the objects whose path is planned with the A* (the nearest PLAN_MAX)
    if reach is not None and view is not None:
        planned = set(np.argsort(view.centre, kind="stable")[:PLAN_MAX].tolist())
    behind_of: list[list[int]] = [[] for _ in range(n)]  # for each a: the b it lies behind
    tops = np.array([_top(o) for o in objs])
    if view is not None:
        overlapping = overlapping_bearings(view.lo, view.hi, view.contains)  # behind needs overlapping views
        for a in range(n):
            cand = overlapping[a]
            for b in (cand[k] for k in np.flatnonzero(behind_mask(view, a, cand))):
                b = int(b)
                behind_of[a].append(b)
                if support[a][0] != objs[b].id and support[b][0] != objs[a].id and \
                        gaps.get((min(a, b), max(a, b)), math.inf) <= BEHIND_GAP:
                    add(a, "behind", b)
                    add(b, "in_front_of", a)
        for (a, b), gap in gaps.items():
            if gap <= SIDE_GAP:
                if view.left_of(a, b):
                    add(a, "left_of", b)
                    add(b, "right_of", a)
                elif view.left_of(b, a):
                    add(b, "left_of", a)
                    add(a, "right_of", b)
    uncertain: list[str] = []
    for a, o in enumerate(objs):
        rec: dict[str, Any] = {
            "id": o.id, "label": o.label, "score": _r(o.score),
            "centre": [_r(v) for v in o.position], "size": [_r(v) for v in o.size], "yaw": _r(o.yaw, 4),
            "bottom": _r(_bottom(o)), "top": _r(_top(o)),
            "on": support[a][0], "placement": place[a], "floor_gap": _r(_bottom(o) - fl),
            "group": group_of.get(o.id),
            "from_robot": None, "visibility": None, "reach": None, "uncertain": [],
        }
        if view is not None:
            rec["from_robot"] = {"distance": _r(view.centre[a], 2), "nearest": _r(view.near[a], 2),
                                 "bearing_deg": _r(math.degrees(view.bearing[a]), 1),
                                 "direction": direction(view.bearing[a])}
            cb = np.asarray(behind_of[a], dtype=np.int64)
            cover = [int(b) for b in cb[tops[cb] >= tops[a] - 1e-6] if support[a][0] != objs[b].id]
            frac = view.hidden_fraction(a, cover)
            rec["visibility"] = ("hidden" if frac >= HIDDEN_FRACTION else
                                 "partly_hidden" if frac >= PARTLY_FRACTION else "visible")
        if reach is not None:
            app = reach.approach(o, plan=a in planned)
            rec["reach"] = {"mode": app.mode, "goal": None if app.goal is None else [_r(v) for v in app.goal],
                            "gap": None if app.goal is None else _r(app.gap),
                            "cost": None if not math.isfinite(app.cost) else _r(app.cost),
                            "planned": app.planned or None,
                            "landing": None if app.landing is None else [_r(v) for v in app.landing],
                            "reason": app.reason or None, "code": app.code or None}
        u = rec["uncertain"]
        if o.score < LOW_SCORE:
            u.append(f"low detector score {o.score:.2f}")
        if not o.size_known:
            u.append("size estimated, not from the catalog")
        if o.source.method == "depth":
            u.append("position from the depth map only")
        problem = placement_text(place[a], _bottom(o) - fl, o.size[1])
        if problem:
            u.append(problem)
        sigma = position_sigma(o)
        if sigma is not None and sigma >= SIGMA_WARN and not getattr(o, "is_pinned", False):
            u.append(f"position uncertain by about {sigma:.2f} m (1 sigma)")
        u += [f"map fusion: {f}" for f in getattr(o, "flags", ())]
        uncertain += [f"{o.id}: {t}" for t in u]
        records.append(rec)
    if pose is None:
        uncertain.append("robot pose unknown: no distances, directions, visibility or reachability")
    elif grid is None:
        uncertain.append("no planning grid: reachability not computed")
    if reach is not None and reach.start_problem:
        uncertain.append(f"reachability unknown: {reach.start_problem}")
    if reach is not None and not reach.start_problem and n > len(planned):
        uncertain.append(f"paths planned for the nearest {len(planned)} objects only; the reachability of the other "
                         f"{n - len(planned)} comes from the grid's connectivity (plan --goal-object ID plans one)")
    ws = None
    if grid is not None:
        w = grid.workspace
        ws = {"min": [_r(v) for v in w.min], "max": [_r(v) for v in w.max], "resolution": _r(w.resolution),
              "margin": _r(grid.margin)}
    order = {"on_top_of": 0, "under": 1, "next_to": 2, "behind": 3, "in_front_of": 4, "left_of": 5, "right_of": 6}
    relations = [{"subject": s, "relation": k, "object": t}
                 for s, k, t in sorted(rel, key=lambda r: (order[r[1]], r[0], r[2]))]
    return {
        "schema": "morphonavi.scene_graph",
        "version": GRAPH_SCHEMA_VERSION,
        "frame": "world",
        "units": "metres, degrees for bearings and axes, radians for yaw",
        "robot": None if pose is None else {"position": [_r(v) for v in pose[:3]],
                                             "yaw_deg": _r(math.degrees(pose[3]), 1)},
        "workspace": ws,
        "objects": records,
        "relations": relations,
        "groups": groups,
        "uncertainties": uncertain,
    }


__all__ = ["GRAPH_SCHEMA_VERSION", "PLACEMENTS", "RobotPose", "SceneGraphError", "build_scene_graph", "check_robot", "group_id",
           "direction", "placement", "placement_text"]
