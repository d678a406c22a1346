"""Benchmark: today's planner (point robot with a soft margin, unseen space free) against the
known-space, robot-sized planner, on seeded random rooms and the paper's room.

Each room (world frame, the paper's 5 x 8 x 3 m workspace at 0.25 m, the room shell beyond it) holds
a line or wall of cardboard boxes across it (wall to wall, with gaps narrower and wider than the
robot, or with an open end), furniture in front of and behind it, and objects beside or behind the
robot's start (outside the first view). The robot stands at ``y = 0.7`` facing +y. Perception is
the simulator's ground truth: the render's depth with 2 % per-pixel noise (known space updated with
a 3 % depth sigma), the objects visible in at least 200 pixels mapped with 8 cm / 3 degree noise (and
those sigmas in their history: the new planner keeps its mapping margin, :mod:`planner.map_uncertainty`);
the ``miss10`` run drops each visible object with probability 0.1. Two capture protocols: ``one``
capture from the start, and ``look`` (look around: 6 headings, 60 degrees apart). Goals: three floor
spots behind the line, free in the true room for the robot's radius.

Per planner, counted over every (room, run, protocol, goal):

- ``routes``: plans found; ``hit body`` / ``hit radius``: routes whose robot (a 0.25 m body, the
  simulator's; or the 0.35 m planning radius) overlaps a true object anywhere along the route
  (sampled every 5 cm; walking: a cylinder up to 0.45 m, flying: a sphere round the origin and the
  cylinder up to 0.45 m above it);
- ``edge``: routes that bring the robot nearer the workspace's edge than its 0.35 m radius (walls
  ``x = 0 / 5``, ``y = 0 / 8``; flying, the top less the robot's height); ``wall``: routes whose 0.25 m
  body touches the room's shell (the paper room's walls are the workspace's ``x = 0`` and ``x = 5``);
- ``unseen``: routes through cells no capture saw free (walking cells: the column up to the robot's
  height), and their metres;
- ``refused: viewpoint / look around / other`` (the new planner's refusals);
- ``look+vp``: the new planner's refusals with a viewpoint in the ``look`` protocol, followed: the
  robot goes to the viewpoint (that leg counts), captures towards the goal, and plans again from there;
- ``plan ms``: median click-to-plan (goal check + A*) on the grid, and for the new planner the
  grid's build time per capture; ``update ms``: known-space update per 640 x 480 capture.

Ratios are new / today in the same run. Run from the repository root::

    .venv/bin/python bench/known_space.py                 # 50 rooms + the paper's room
    .venv/bin/python bench/known_space.py --rooms 10      # quicker
"""

from __future__ import annotations

import argparse
import math
import os
import sys
import time
from dataclasses import dataclass, field

_HERE = os.path.dirname(os.path.abspath(__file__))
# bench/planner.py would shadow the planner package: keep this folder off sys.path
sys.path[:] = [p for p in sys.path if os.path.abspath(p or os.getcwd()) != _HERE]
sys.path.insert(0, os.path.dirname(_HERE))

import numpy as np  # noqa: E402
from scipy import ndimage  # noqa: E402

from console.link.render import SceneRenderer  # noqa: E402
from console.link.sim_camera import visible_objects  # noqa: E402
from console.link.sim_config import DEFAULT_INTRINSICS, DEFAULT_MOUNT  # noqa: E402
from console.link.world import DEFAULT_START, ROOM_MAX, ROOM_MIN  # noqa: E402
from bench.rooms import RADIUS, WS, Room, paper, random_room  # noqa: E402  (the room generator, shared)
from pipeline.camera.geometry import Pose, camera_pose_in_world  # noqa: E402
from pipeline.mapping.known_space import KnownSpace, KnownState  # noqa: E402
from pipeline.mapping.known_space_update import DepthNoise, capture_update  # noqa: E402
from pipeline.scene import SceneObject, Sighting, Source  # noqa: E402
from planner.cspace import box_distance  # noqa: E402
from planner.grid import CellState, PlanningGrid, Workspace, box_cells, build_grid  # noqa: E402
from planner.robot_model import RobotModel  # noqa: E402
from planner.route import Route  # noqa: E402

BODY = 0.25
HEIGHT = 0.45
POS_SIGMA = 0.08
"""Mapped object position noise, 1 sigma per horizontal axis [m]."""
YAW_SIGMA = math.radians(3.0)
"""Mapped object heading noise, 1 sigma [rad]."""
ROBOT = RobotModel(radius=RADIUS, flying_radius=RADIUS, flying_height=HEIGHT, mapping_margin=True)
"""The new planner's robot: the flying body's whole height and the mapping margin on (both off in the
default robot model: planner.robot_model)."""


def legacy_grid(objs: list[SceneObject], ws: Workspace, margin: float) -> PlanningGrid:
    """Today's grid (before known space): boxes occupied, free cells within ``margin`` of them only dangerous."""
    occ = np.zeros(ws.shape, bool)
    owner = np.full(ws.shape, -1, np.int32)
    for n, o in enumerate(objs):
        c = box_cells(o, ws)
        owner[c & ~occ] = n
        occ |= c
    state = np.zeros(ws.shape, np.uint8)
    if occ.any():
        dist = ndimage.distance_transform_edt(~occ, sampling=ws.resolution)
        state[(dist <= margin + 1e-9) & ~occ] = CellState.DANGEROUS
    state[occ] = CellState.OCCUPIED
    return PlanningGrid(ws, state, margin, tuple(o.id for o in objs), owner)


@dataclass
class Views:
    """One room's captures: per heading the depth (noisy), camera pose and visible true object ids."""

    depth: list[np.ndarray]
    cams: list[Pose]
    seen: list[set[str]]


def capture(room: Room, renderer: SceneRenderer, rng: np.random.Generator, headings: int = 6) -> Views:
    views = Views([], [], [])
    for h in range(headings):
        pose = Pose.from_xyz_yaw(room.start[0], room.start[1], 0.0, math.pi / 2 + h * 2 * math.pi / headings)
        cam = camera_pose_in_world(pose, DEFAULT_MOUNT)
        r = renderer.render(cam, DEFAULT_INTRINSICS)
        noisy = (r.depth * (1.0 + 0.02 * rng.standard_normal(r.depth.shape))).astype(np.float32)
        views.depth.append(noisy)
        views.cams.append(cam)
        views.seen.append({v.id for v in visible_objects(r, 200)})
    return views


def mapped_objects(room: Room, ids: set[str], rng: np.random.Generator, miss: float) -> list[SceneObject]:
    """The objects seen, each at one noisy draw (``POS_SIGMA`` per axis, ``YAW_SIGMA``) and with that one
    sighting and its sigmas in its history (as the map fusion leaves it: the planner's mapping margin)."""
    out = []
    for o in room.scene.objects:
        if o.id not in ids or rng.random() < miss:
            continue
        dx, dy = rng.normal(0.0, POS_SIGMA, 2)
        pos, yaw = (o.position[0] + dx, o.position[1] + dy, o.position[2]), o.yaw + float(rng.normal(0.0, YAW_SIGMA))
        seen = (Sighting("bench", pos, yaw, o.size, (POS_SIGMA, POS_SIGMA, YAW_SIGMA)),)
        out.append(SceneObject(o.id, o.label, pos, o.size, yaw, "world", source=Source("bench", "ground_truth"),
                               history=seen))
    return out


def densify(pts: np.ndarray, cells: np.ndarray, step: float = 0.05) -> tuple[np.ndarray, np.ndarray]:
    out, ground = [pts[0]], [cells[0, 2] == 0]
    for a, b, ca, cb in zip(pts[:-1], pts[1:], cells[:-1], cells[1:]):
        n = max(1, int(math.ceil(float(np.linalg.norm(b - a)) / step)))
        for i in range(1, n + 1):
            out.append(a + (b - a) * i / n)
            ground.append(bool(ca[2] == 0 and cb[2] == 0))
    return np.array(out), np.array(ground)


def hits(room: Room, pts: np.ndarray, ground: np.ndarray, r: float) -> bool:
    for o in room.scene.objects:
        lo, hi = o.position[2] - o.size[1] / 2, o.position[2] + o.size[1] / 2
        if ground.any() and lo < HEIGHT and hi > 0.0:
            if np.any(box_distance(o, pts[ground], horizontal=True) < r - 1e-9):
                return True
        if (~ground).any():  # flying: a sphere round the origin and the body's height above it
            air = pts[~ground]
            above = (box_distance(o, air, horizontal=True) < r - 1e-9) & (air[:, 2] + HEIGHT > lo) & (air[:, 2] < hi)
            if np.any(above) or np.any(box_distance(o, air) < r - 1e-9):
                return True
    return False


def near_edge(pts: np.ndarray, ground: np.ndarray) -> bool:
    """Whether the robot at any of ``pts`` (world [m]) is nearer the workspace's edge than its radius
    (in plan), or flying, nearer its top than its height."""
    lo, hi = np.asarray(WS.min), np.asarray(WS.max)
    plan = np.minimum(pts[:, :2] - lo[:2], hi[:2] - pts[:, :2]).min(axis=1)
    top = hi[2] - pts[:, 2]
    return bool(np.any(plan < RADIUS - 1e-9) or np.any(top[~ground] < max(RADIUS, HEIGHT) - 1e-9))


def hits_wall(pts: np.ndarray) -> bool:
    """Whether the simulator's body (:data:`BODY` radius, :data:`HEIGHT` high) at any of ``pts``
    touches the room's shell (its walls in plan, its ceiling)."""
    lo, hi = np.asarray(ROOM_MIN), np.asarray(ROOM_MAX)
    plan = np.minimum(pts[:, :2] - lo[:2], hi[:2] - pts[:, :2]).min(axis=1)
    return bool(np.any(plan < BODY - 1e-9) or np.any(pts[:, 2] + HEIGHT > hi[2] + 1e-9))


def unseen_metres(cells: np.ndarray, seen: np.ndarray) -> float:
    """Metres of moves ending in a cell not seen free (walking: its column up to the robot's height)."""
    kh = int(math.ceil(HEIGHT / WS.resolution))
    ok = np.where(cells[:, 2] == 0, seen[cells[:, 0], cells[:, 1], :kh].all(axis=1),
                  seen[cells[:, 0], cells[:, 1], cells[:, 2]])
    steps = np.linalg.norm(np.diff(cells, axis=0), axis=1) * WS.resolution
    return float(steps[~ok[1:]].sum())


@dataclass
class Tally:
    plans: int = 0
    routes: int = 0
    hit_body: int = 0
    hit_radius: int = 0
    near_edge: int = 0
    hit_wall: int = 0
    unseen_routes: int = 0
    unseen_m: float = 0.0
    refused_viewpoint: int = 0
    refused_look: int = 0
    refused_other: int = 0
    plan_ms: list[float] = field(default_factory=list)
    build_ms: list[float] = field(default_factory=list)
    examples: list[str] = field(default_factory=list)


def _route_check(room: Room, grid: PlanningGrid, res, seen: np.ndarray, tl: "Tally") -> None:
    tl.routes += 1
    dense, ground = densify(res.points(grid), res.cells)
    tl.hit_body += hits(room, dense, ground, BODY)
    tl.hit_radius += hits(room, dense, ground, RADIUS)
    tl.near_edge += near_edge(dense, ground)
    tl.hit_wall += hits_wall(dense)
    m = unseen_metres(res.cells, seen)
    tl.unseen_routes += m > 0
    tl.unseen_m += m


@dataclass
class Follow:
    """The suggested look, taken: walk or fly to the viewpoint, capture towards the goal, plan again."""

    renderer: SceneRenderer
    rng: np.random.Generator
    tally: "Tally"


def follow_viewpoint(room: Room, objs: list[SceneObject], ks: KnownSpace, grid: PlanningGrid, route: Route,
                     goal, vp, fw: Follow) -> None:
    tl = fw.tally
    tl.plans += 1
    on_floor = vp[2] <= WS.floor + DEFAULT_MOUNT.position[2] + 1e-6
    stand = (vp[0], vp[1], 0.0) if on_floor else vp
    leg = route.plan(route.start, stand)
    if not leg.ok:
        tl.refused_other += 1
        return
    end = leg.goal or stand
    robot_z = 0.0 if on_floor else end[2] - DEFAULT_MOUNT.position[2]
    yaw = math.atan2(goal[1] - end[1], goal[0] - end[0])
    cam = camera_pose_in_world(Pose.from_xyz_yaw(end[0], end[1], robot_z, yaw), DEFAULT_MOUNT)
    r = fw.renderer.render(cam, DEFAULT_INTRINSICS)
    noisy = (r.depth * (1.0 + 0.02 * fw.rng.standard_normal(r.depth.shape))).astype(np.float32)
    ks2 = capture_update(ks, noisy, DEFAULT_INTRINSICS, cam, noise=DepthNoise(relative=0.03)).space
    if on_floor:  # the robot stood there: its body is free (as the console marks it at each capture)
        ks2 = ks2.with_free_body((end[0], end[1], 0.0), RADIUS, HEIGHT)
    known = {o.id for o in objs}
    new_ids = {v.id for v in visible_objects(r, 200)} - known
    objs2 = objs + mapped_objects(room, new_ids, fw.rng, 0.0)
    grid2 = build_grid(objs2, WS, known=ks2, robot=ROBOT)
    route2 = Route(grid2, end)
    res = route2.plan(end, goal)
    seen = ks.state() == KnownState.FREE
    if not res.ok:
        if res.viewpoint is not None:
            tl.refused_viewpoint += 1
        elif "Look around" in res.message:
            tl.refused_look += 1
        else:
            tl.refused_other += 1
        return
    _route_check(room, grid, leg, seen, tl)  # the way to the viewpoint counts too
    tl.routes -= 1
    _route_check(room, grid2, res, ks2.state() == KnownState.FREE, tl)


def run_case(room: Room, objs: list[SceneObject], ks: KnownSpace, tallies: dict[str, Tally],
             follow: Follow | None = None) -> None:
    seen = ks.state() == KnownState.FREE
    start = (room.start[0], room.start[1], 0.0)
    t0 = time.perf_counter()
    grids = {"today": legacy_grid(objs, WS, RADIUS)}
    tallies["today"].build_ms.append((time.perf_counter() - t0) * 1e3)
    t0 = time.perf_counter()
    grids["new"] = build_grid(objs, WS, known=ks, robot=ROBOT)
    tallies["new"].build_ms.append((time.perf_counter() - t0) * 1e3)
    for name, grid in grids.items():
        tl = tallies[name]
        route = Route(grid, start)
        for goal in room.goals:
            tl.plans += 1
            t0 = time.perf_counter()
            res = route.plan(start, goal)
            tl.plan_ms.append((time.perf_counter() - t0) * 1e3)
            if not res.ok:
                if res.viewpoint is not None:
                    tl.refused_viewpoint += 1
                    if follow is not None and name == "new":
                        follow_viewpoint(room, objs, ks, grid, route, goal, res.viewpoint, follow)
                elif "Look around" in res.message:
                    tl.refused_look += 1
                else:
                    tl.refused_other += 1
                    if len(tl.examples) < 3:
                        tl.examples.append(f"{room.name} {goal}: {res.message}")
                continue
            _route_check(room, grid, res, seen, tl)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0], formatter_class=argparse.RawDescriptionHelpFormatter,
                                 epilog="Counts and times per planner; ratios are new / today, measured in the same run.")
    ap.add_argument("--rooms", type=int, default=50, help="random rooms besides the paper's (default 50)")
    ap.add_argument("--seed", type=int, default=19, help="random seed (default 19)")
    args = ap.parse_args(argv)
    if args.rooms < 0:
        ap.error("--rooms must be >= 0")
    rng = np.random.default_rng(args.seed)
    rooms = [paper()] + [random_room(rng, n) for n in range(args.rooms)]
    keys = [(p, r) for p in ("one", "look") for r in ("noise", "miss10")]
    tallies = {k: {"today": Tally(), "new": Tally()} for k in keys}
    follows = {"noise": Tally(), "miss10": Tally()}
    update_ms: list[float] = []
    t_all = time.perf_counter()
    # compile the numba kernels outside the timings
    capture_update(KnownSpace.empty(WS.min, WS.max, WS.resolution), np.ones((480, 640), np.float32),
                   DEFAULT_INTRINSICS, camera_pose_in_world(DEFAULT_START, DEFAULT_MOUNT))
    for room in rooms:
        renderer = SceneRenderer(room.scene, (ROOM_MIN, ROOM_MAX))
        views = capture(room, renderer, rng)
        body = (room.start[0], room.start[1], 0.0)
        for proto in ("one", "look"):
            n = 1 if proto == "one" else len(views.depth)
            ks = KnownSpace.empty(WS.min, WS.max, WS.resolution)
            for d, cam in zip(views.depth[:n], views.cams[:n]):
                up = capture_update(ks, d, DEFAULT_INTRINSICS, cam, noise=DepthNoise(relative=0.03))
                update_ms.append(up.seconds * 1e3)
                ks = up.space
            ks = ks.with_free_body(body, RADIUS, HEIGHT)
            ids = set().union(*views.seen[:n])
            for run, miss in (("noise", 0.0), ("miss10", 0.1)):
                follow = Follow(renderer, rng, follows[run]) if proto == "look" else None
                run_case(room, mapped_objects(room, ids, rng, miss), ks, tallies[(proto, run)], follow)
    total = time.perf_counter() - t_all
    print(f"{len(rooms)} rooms (the paper's + {args.rooms} random, seed {args.seed}), "
          f"{sum(len(r.goals) for r in rooms)} goals behind the line, workspace {WS.shape} at {WS.resolution} m")
    head = (f"{'protocol':8} {'run':7} {'planner':7} {'plans':>5} {'routes':>6} {'hit body':>8} {'hit radius':>10} "
            f"{'edge':>4} {'wall':>4} {'unseen':>6} {'unseen m':>8} {'ref vp':>6} {'ref look':>8} {'ref other':>9} {'plan ms':>7} {'build ms':>8}")
    print(head)
    print("-" * len(head))
    for (proto, run), pair in tallies.items():
        for name, t in pair.items():
            print(f"{proto:8} {run:7} {name:7} {t.plans:5d} {t.routes:6d} {t.hit_body:8d} {t.hit_radius:10d} "
                  f"{t.near_edge:4d} {t.hit_wall:4d} {t.unseen_routes:6d} {t.unseen_m:8.1f} {t.refused_viewpoint:6d} {t.refused_look:8d} "
                  f"{t.refused_other:9d} {np.median(t.plan_ms):7.2f} {np.median(t.build_ms):8.2f}")
    for run, t in follows.items():
        print(f"{'look+vp':8} {run:7} {'new':7} {t.plans:5d} {t.routes:6d} {t.hit_body:8d} {t.hit_radius:10d} "
              f"{t.near_edge:4d} {t.hit_wall:4d} {t.unseen_routes:6d} {t.unseen_m:8.1f} {t.refused_viewpoint:6d} {t.refused_look:8d} "
              f"{t.refused_other:9d}")
    allp = {n: [v for pair in tallies.values() for v in pair[n].plan_ms] for n in ("today", "new")}
    allb = {n: [v for pair in tallies.values() for v in pair[n].build_ms] for n in ("today", "new")}
    print(f"click-to-plan median: today {np.median(allp['today']):.2f} ms, new {np.median(allp['new']):.2f} ms "
          f"(ratio {np.median(allp['new']) / np.median(allp['today']):.2f}); 95th percentile today "
          f"{np.percentile(allp['today'], 95):.2f} ms, new {np.percentile(allp['new'], 95):.2f} ms")
    print(f"grid build per capture median: today {np.median(allb['today']):.1f} ms, new {np.median(allb['new']):.1f} ms "
          f"(ratio {np.median(allb['new']) / np.median(allb['today']):.2f})")
    print(f"known-space update per 640x480 capture: median {np.median(update_ms):.1f} ms, max {np.max(update_ms):.1f} ms "
          f"({len(update_ms)} updates)")
    for (proto, run), pair in tallies.items():
        for ex in pair["new"].examples[:1]:
            print(f"example other refusal ({proto}, {run}): {ex}")
    new_hits = sum(p["new"].hit_body for p in tallies.values()) + sum(t.hit_body for t in follows.values())
    new_close = sum(p["new"].hit_radius for p in tallies.values()) + sum(t.hit_radius for t in follows.values())
    new_unseen = sum(p["new"].unseen_m for p in tallies.values()) + sum(t.unseen_m for t in follows.values())
    new_edge = sum(p["new"].near_edge for p in tallies.values()) + sum(t.near_edge for t in follows.values())
    print(f"routes nearer the workspace's edge than the robot's radius: today "
          f"{sum(p['today'].near_edge for p in tallies.values())}, new {new_edge} "
          f"({'met' if new_edge == 0 else 'MISSED'}: 0)")
    print(f"targets: new planner 0 colliding routes (body contact: {new_hits}, "
          f"{'met' if new_hits == 0 else 'MISSED'}; {new_close} within the 0.35 m radius of a true object), "
          f"0 unseen metres ({new_unseen:.1f}, {'met' if new_unseen == 0 else 'MISSED'}); total {total:.0f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
