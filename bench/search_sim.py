"""A light simulation of a search for the benchmark: the robot in a hidden room, captures, moves.

World frame (z up) [m], headings counter-clockwise from +x [rad]. Runs the console's search loop
(:mod:`console.session.search`: capture where the robot stands; a target seen in
:data:`~console.session.search.CONFIRM_CAPTURES` captures is confirmed and the robot goes beside it
with go-to-object; seen once: face it and capture again; else pick the next viewpoint, go, turn,
capture) with a pluggable viewpoint picker, on a simulated robot much faster than the console's
(no mission runner, no time scale), so that hundreds of searches fit in minutes:

- **capture**: the room rendered (:class:`console.link.render.SceneRenderer`) at ``image_scale`` of
  the simulated 640 x 480 camera (default 0.5: 320 x 240; the same field of view) from the robot's
  pose and the default mount (level camera 0.35 m up); depth with 2 % per-pixel noise cast into
  the known space with a 3 % depth sigma, then the robot's body and the floor round it free (as
  :meth:`console.session.session.Session.observe_capture` does); objects covering at least 200
  pixels of the full-size image (scaled with the image) and at least :data:`MIN_RANGE` away are
  mapped with 8 cm / 3 degree noise (averaged over captures, by their true id; the captures' sigmas
  kept as the object's sightings, so the planner keeps its mapping margin); with ``miss`` each
  is dropped with that probability per capture (as ``bench/known_space.py`` and ``bench/sim_tour.py``);
- **move**: the planner's A* route on the map built from the captures so far
  (:func:`planner.grid.build_grid` with the known space, the robot's size), followed in 5 cm steps;
  the simulator's body (0.25 m radius, 0.45 m tall) stops where it would touch a true object: a
  **collision** (the route was wrong about the room); turning is free of contact;
- **time**: the robot's own time from the simulator's speeds (walk 0.4 m/s, fly 0.8 m/s, climb 0.5,
  descend 0.4 m/s, 1 s spool-up, 0.5 s settle, 120 deg/s turns) and :data:`CAPTURE_S` per capture.

Path cost is measured on the true room's planner cost (closed cells priced as dangerous ones).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from typing import Any, Callable

import numpy as np

from bench.search_rooms import SearchRoom, near_target, true_grid
from console.link.render import SceneRenderer
from console.link.sim_camera import visible_objects
from console.link.sim_config import DEFAULT_INTRINSICS, DEFAULT_MOUNT, SimConfig
from console.link.sim_contact import BodyContact
from console.session.known_space_state import BODY_HEIGHT, NEAR_FREE, grid_for, near_free
from console.session.search_finish import is_contact, look_beside, repeats
from console.session.search_types import CONFIRM_CAPTURES
from pipeline.camera.geometry import Intrinsics, Pose, camera_pose_in_world
from pipeline.mapping.known_space import KnownSpace
from pipeline.mapping.known_space_update import DepthNoise, capture_update
from pipeline.scene import Scene, SceneObject, Sighting, Source
from planner.grid import CostWeights, PlanningGrid
from planner.mission import heading_to
from planner.object_goal import ObjectGoalError, goal_beside
from planner.robot_model import MORPHOGEAR
from planner.route import Route
from planner.search_viewpoints import Viewpoint, cells_in_view

MIN_PIXELS = 200
"""Pixels an object must cover in the full-size 640 x 480 image to be mapped."""
MIN_RANGE = 0.5
"""Nearest an object may be (its median depth) to be mapped [m] (the mapper drops closer ones)."""
POS_SIGMA = 0.08
"""Mapped object position noise, 1 sigma per horizontal axis [m]."""
YAW_SIGMA = math.radians(3.0)
CAPTURE_S = 2.0
"""Robot time per capture (hold still, photo, mapping) [s]."""
STEP = 0.05
"""Path following step [m]."""

Picker = Callable[["SimSearch"], "tuple[Viewpoint, str] | None"]


def scaled_intrinsics(scale: float) -> Intrinsics:
    """The simulated camera at ``scale`` of its 640 x 480 size (same field of view)."""
    k = DEFAULT_INTRINSICS
    if scale == 1.0:
        return k
    w, h = int(round(k.width * scale)), int(round(k.height * scale))
    return Intrinsics(k.fx * scale, k.fy * scale, (k.cx + 0.5) * scale - 0.5, (k.cy + 0.5) * scale - 0.5, w, h)


@dataclass
class Outcome:
    """One search's end (a row of the benchmark's records)."""

    room: str
    run: str
    strategy: str
    found: bool = False
    success: bool = False
    reason: str = ""
    final: tuple[float, float, float] = (0.0, 0.0, 0.0)
    distance: float | None = None  # horizontal, to the true target's centre [m] (success: its footprint within 1 m)
    path_m: float = 0.0
    path_cost: float = 0.0
    captures: int = 0
    robot_s: float = 0.0
    choose_s: list[float] = field(default_factory=list)
    collisions: int = 0
    moves_refused: int = 0
    wall_s: float = 0.0
    contacts: list[dict] = field(default_factory=list)  # what each collision touched (:meth:`SimSearch.diagnose`)
    target_views: dict = field(default_factory=lambda: {"mapped": 0, "missed": 0, "too_near": 0})
    """Captures in which the target covered enough pixels: mapped, dropped as a missed detection, too near."""


class SimSearch:
    """One search in one room (see the module docstring).

    Args:
        room: The hidden room.
        renderer: Its renderer (shared by the searches of one room).
        picker: The strategy: ``picker(sim) -> (viewpoint, unknown policy) | None``.
        rng: Noise and misses (and the random strategy).
        miss: Chance an object in view is missed per capture.
        budget: Capture budget.
        image_scale: Rendered image size against 640 x 480.
        looked: Keep the cells each capture had in view that stayed unknown (the console's search does).
    """

    def __init__(self, room: SearchRoom, renderer: SceneRenderer, picker: Picker, rng: np.random.Generator,
                 miss: float, budget: int, image_scale: float = 0.5, looked: bool = False) -> None:
        self.room, self.renderer, self.picker, self.rng = room, renderer, picker, rng
        self.miss, self.budget = float(miss), int(budget)
        self.intrinsics = scaled_intrinsics(image_scale)
        self.min_pixels = max(1, int(round(MIN_PIXELS * image_scale ** 2)))
        self.ws = room.workspace
        self.known = KnownSpace.empty(self.ws.min, self.ws.max, self.ws.resolution)
        self.pos = (room.start[0], room.start[1], 0.0)
        self.yaw = room.start[2]
        self.target_height = 0.4
        self.keep_looked = looked
        self.looked: np.ndarray | None = None
        self.visited: list[tuple[float, float, float]] = []
        self.views: list[tuple[tuple[float, float, float], float]] = []  # (camera position, heading) per capture
        self._seen: dict[str, list[Any]] = {}  # id -> [true object, sum of noisy xy, sum of yaw offsets, captures]
        self._contact = BodyContact(room.objects, SimConfig.body_radius, SimConfig.body_height)
        truth = true_grid(room)
        self._true_cost = self._priced(truth)
        self.cfg = SimConfig()
        self.out = Outcome(room.name, "", "")
        self.steps: list[str] = []
        self._grids: dict[tuple[str, int], PlanningGrid] = {}
        self.confirmed_from: list[tuple[float, float, float]] = []  # spots a confirming capture was taken from
        self.confirm_target: Any = None  # the target to confirm from elsewhere (the product's choice reads it)
        self.contact_routes: list[tuple[tuple[float, ...], tuple[float, ...]]] = []  # (start, goal) that hit

    # --- the map ------------------------------------------------------------------------------------
    @staticmethod
    def _priced(grid: PlanningGrid) -> np.ndarray:
        w = CostWeights()
        c = grid.cost(w)
        layer = np.full(c.shape[2], w.flight)
        layer[0] = w.ground
        layer[1] = w.takeoff
        return np.where(np.isfinite(c), c, np.broadcast_to(layer * w.danger, c.shape))

    def objects(self) -> list[SceneObject]:
        """The mapped objects (world frame): each true object seen, at its mean noisy position."""
        out = []
        for o, xy, dyaw, n in self._seen.values():
            pos, yaw = (xy[0] / n, xy[1] / n, o.position[2]), o.yaw + dyaw / n  # its n sightings' sigmas kept in history
            seen = (Sighting(None, pos, yaw, o.size, (POS_SIGMA, POS_SIGMA, YAW_SIGMA)),) * int(n)
            out.append(SceneObject(o.id, o.label, pos, o.size, yaw, "world", source=Source(None, "ground_truth"),
                                   history=seen))
        return out

    def grid(self, policy: str = "closed") -> PlanningGrid:
        """The planning grid of the map so far, as the console builds it (``closed`` or ``allow`` unknown
        space); built once per capture and rule."""
        key = (policy, self.out.captures)
        if key not in self._grids:
            if self._grids and next(iter(self._grids))[1] != self.out.captures:
                self._grids.clear()
            self._grids[key] = grid_for(Scene(objects=tuple(self.objects())), self.ws, MORPHOGEAR.radius, self.known,
                                        policy)
        return self._grids[key]

    def here(self) -> tuple[float, float, float]:
        return (self.pos[0], self.pos[1], max(self.pos[2], self.ws.floor))

    def target_seen(self) -> tuple[str, int] | None:
        t = self.room.target_id
        if t is None or t not in self._seen:
            return None
        return t, int(self._seen[t][3])

    # --- actions ------------------------------------------------------------------------------------
    def capture(self) -> None:
        self.out.captures += 1
        self.out.robot_s += CAPTURE_S
        pose = Pose.from_xyz_yaw(self.pos[0], self.pos[1], self.pos[2], self.yaw)
        cam = camera_pose_in_world(pose, DEFAULT_MOUNT)
        r = self.renderer.render(cam, self.intrinsics)
        depth = r.depth.astype(np.float64)
        noisy = depth * (1.0 + 0.02 * self.rng.standard_normal(depth.shape))
        noisy = np.where(np.isfinite(noisy), noisy, 0.0)
        up = capture_update(self.known, noisy, self.intrinsics, cam, noise=DepthNoise(relative=0.03))
        at = self.here()
        self.known = near_free(up.space.with_free_body(at, MORPHOGEAR.radius, BODY_HEIGHT), at,
                               max(MORPHOGEAR.radius, NEAR_FREE), BODY_HEIGHT)
        self.visited.append(self.pos)
        self.views.append(((float(cam.translation[0]), float(cam.translation[1]), float(cam.translation[2])), self.yaw))
        truth = {o.id: o for o in self.room.objects}
        for v in visible_objects(r, self.min_pixels):
            if v.id not in truth:
                continue
            tgt = v.id == self.room.target_id
            if self.rng.random() < self.miss:
                self.out.target_views["missed"] += tgt
                continue
            if float(np.median(depth[r.instances == v.index])) < MIN_RANGE:
                self.out.target_views["too_near"] += tgt
                continue
            self.out.target_views["mapped"] += tgt
            o = truth[v.id]
            dx, dy = self.rng.normal(0.0, POS_SIGMA, 2)
            rec = self._seen.setdefault(o.id, [o, np.zeros(2), 0.0, 0])
            rec[1] = rec[1] + np.array([o.position[0] + dx, o.position[1] + dy])
            rec[2] += float(self.rng.normal(0.0, YAW_SIGMA))
            rec[3] += 1
        if self.keep_looked:
            state = self.known.state()
            eye = (self.pos[0], self.pos[1], max(self.pos[2], self.ws.floor) + MORPHOGEAR.camera_height)
            seen = cells_in_view(state, self.grid(), eye, self.yaw, self.target_height)
            self.looked = seen if self.looked is None else (self.looked | seen)

    def turn(self, yaw: float) -> None:
        d = abs((yaw - self.yaw + math.pi) % (2 * math.pi) - math.pi)
        self.out.robot_s += d / self.cfg.yaw_rate
        self.yaw = float(yaw)

    def move(self, goal: tuple[float, float, float], policy: str) -> str | None:
        """Plan and follow a route to ``goal``; ``None`` when there, else why not."""
        grid = self.grid(policy)
        here = self.here()
        res = Route(grid, here).plan(here, goal)
        if not res.ok:
            self.out.moves_refused += 1
            return res.message
        pts = res.points(grid)
        pts[0] = np.asarray(self.pos)
        cells = res.cells
        cfg = self.cfg
        for n in range(1, len(pts)):
            a, b = pts[n - 1], pts[n]
            k = max(1, int(math.ceil(float(np.linalg.norm(b - a)) / STEP)))
            prev = a
            for i in range(1, k + 1):
                p = a + (b - a) * i / k
                if self._contact.blocked(tuple(prev), tuple(p)) is not None:
                    self.out.collisions += 1
                    self.out.contacts.append(self.diagnose(p, goal))
                    self.steps.append(f"contact at ({p[0]:.2f}, {p[1]:.2f}, {p[2]:.2f}) on the way to {goal} ({policy})")
                    self.pos = (float(prev[0]), float(prev[1]), float(prev[2]))
                    return f"contact with a true object at ({p[0]:.2f}, {p[1]:.2f}, {p[2]:.2f})"
                d = p - prev
                flat = math.hypot(float(d[0]), float(d[1]))
                if prev[2] < 0.01 and p[2] < 0.01:
                    self.out.robot_s += flat / cfg.walk_speed
                else:
                    self.out.robot_s += max(flat / cfg.fly_speed, max(d[2], 0) / cfg.climb_rate,
                                            max(-d[2], 0) / cfg.descent_rate)
                    if prev[2] < 0.01:
                        self.out.robot_s += cfg.spool_time
                    elif p[2] < 0.01:
                        self.out.robot_s += cfg.settle_time
                self.out.path_m += float(np.linalg.norm(d))
                prev = p
            ca, cb = cells[n - 1], cells[n]
            step = self.ws.resolution * float(np.linalg.norm(cb - ca))
            self.out.path_cost += step * (self._true_cost[tuple(ca)] + self._true_cost[tuple(cb)]) / 2.0
            heading = math.atan2(float(b[1] - a[1]), float(b[0] - a[0]))
            if math.hypot(float(b[0] - a[0]), float(b[1] - a[1])) > 1e-6:
                self.turn(heading)
            self.pos = (float(b[0]), float(b[1]), float(b[2]))
        return None

    def diagnose(self, p: np.ndarray, goal: tuple[float, float, float]) -> dict:
        """What the body at ``p`` (world [m]) touched and what the map knew of it: the true object, its
        footprint's distance to the body's axis [m], whether it was mapped (and how far off [m]), and the
        known-space states of its cells (``unknown``, ``free``, ``occupied`` counts)."""
        from planner.object_goal import footprint_distance

        xy = np.array([[float(p[0]), float(p[1])]])
        z = float(p[2])
        best, bd = None, math.inf
        for o in self.room.objects:
            lo, hi = o.position[2] - o.size[1] / 2, o.position[2] + o.size[1] / 2
            if z >= hi or z + SimConfig.body_height <= lo:
                continue
            d = float(footprint_distance(o, xy)[0])
            if d < bd:
                best, bd = o, d
        info: dict = {"at": [round(float(v), 3) for v in p], "goal": [round(float(v), 3) for v in goal],
                      "object": best.id if best else None, "label": best.label if best else None,
                      "distance": round(bd, 3), "captures": self.out.captures}
        if best is not None:
            rec = self._seen.get(best.id)
            info["mapped"] = rec is not None
            if rec is not None:
                info["mapped_off"] = round(math.dist(rec[1] / rec[3], best.position[:2]), 3)
            mapped = next((m for m in self.objects() if m.id == best.id), None)
            if mapped is not None:
                info["mapped_distance"] = round(float(footprint_distance(mapped, xy)[0]), 3)
            ws = self.ws
            i0 = ws.cell_of((best.position[0], best.position[1], max(best.position[2], ws.floor)))
            state = self.known.state()
            if i0 is not None:
                r = int(math.ceil(max(best.size[0], best.size[2]) / 2 / ws.resolution))
                k1 = max(1, int(math.ceil((best.position[2] + best.size[1] / 2) / ws.resolution)))
                box = state[max(0, i0[0] - r):i0[0] + r + 1, max(0, i0[1] - r):i0[1] + r + 1, :k1]
                info["cells"] = {"unknown": int((box == 0).sum()), "free": int((box == 1).sum()),
                                 "occupied": int((box == 2).sum())}
        return info

    # --- the loop (console.session.search.SearchJob._loop) --------------------------------------------
    def run(self) -> Outcome:
        t0 = time.perf_counter()
        out = self.out
        try:
            out.reason = self._loop()
        finally:
            out.wall_s = time.perf_counter() - t0
            out.final = self.pos
            t = self.room.target
            if t is not None:
                out.distance = math.dist(self.pos[:2], t.position[:2])
            out.success = bool(out.found and near_target(self.room, self.pos))
        return out

    def _loop(self) -> str:
        """The console's loop (:meth:`console.session.search.SearchJob._loop`), step for step."""
        out = self.out
        self.capture()
        while True:
            seen = self.target_seen()
            self.confirm_target = None  # a target seen once whose confirming capture from here missed it
            if seen is not None:
                tid, n = seen
                if n >= CONFIRM_CAPTURES:
                    return self._finish(tid)
                if out.captures >= self.budget:
                    return "budget used (target seen once, not confirmed)"
                if not any(math.dist(self.pos[:2], p[:2]) < 0.5 for p in self.confirmed_from):
                    o = next(o for o in self.objects() if o.id == tid)
                    if math.dist(self.pos[:2], o.position[:2]) > 0.3:
                        self.turn(heading_to(self.pos, o.position))
                    self.confirmed_from.append(self.pos)
                    self.capture()
                    continue
                self.steps.append(f"{out.captures}: {tid} seen once; the confirming capture from here missed it")
                self.confirm_target = next(o for o in self.objects() if o.id == tid)
            if out.captures >= self.budget:
                return "not found: budget used"
            t0 = time.perf_counter()
            pick = self.picker(self)
            out.choose_s.append(time.perf_counter() - t0)
            if pick is None:
                return "not found: nowhere left to look"
            vp, policy = pick
            self.steps.append(f"{out.captures}: {policy}: {vp.why}")
            here = self.pos
            if repeats(here, vp.goal, self.contact_routes):  # never the same route after a contact (as the console)
                self.steps.append("the route there ended in contact before: not repeated; capturing here")
            elif math.dist(here, vp.goal) > 0.2 and not (vp.mode == "walk" and math.dist(here[:2], vp.goal[:2]) < 0.2
                                                          and here[2] < 0.1):
                why = self.move(vp.goal, policy)  # a refused or stopped move: capture where the robot is
                if why is not None:
                    if is_contact(why):
                        self.contact_routes.append((here, tuple(vp.goal)))
                    self.steps.append(f"move not done: {why}")
            self.turn(vp.yaw)
            self.capture()

    def _finish(self, tid: str) -> str:
        """The console's last approach (:meth:`console.session.search_finish.SearchFinish._finish`): beside
        the target over seen space only; none reachable: look to open the floor beside it
        (:func:`console.session.search_finish.look_beside`) while the budget lasts, then *found, not
        reached*; a move that stopped: capture and plan again, never the same route twice."""
        looks: list[tuple[tuple[float, ...], float]] = []  # the looks taken here (never taken twice)
        for _ in range(self.budget + 4):
            grid = self.grid("closed")
            here = self.here()
            scene = Scene(objects=tuple(self.objects()))
            try:
                _, app = goal_beside(scene, grid, tid, here, Route(grid, here))
            except ObjectGoalError as exc:
                if self.out.captures >= self.budget:
                    return f"found, not reached: no seen-free spot beside it is reachable ({exc})"
                look, none = look_beside(scene, grid, self.grid("allow"), tid, here, None, self.views + looks)
                if look is None:  # no look towards it is left: explore on (the strategy's own next viewpoint)
                    pick = self.picker(self)
                    if pick is None:
                        return f"found, not reached: no seen-free spot beside it is reachable ({exc}); {none}"
                    look = pick[0]
                    self.steps.append(f"{self.out.captures}: no look beside {tid} left ({none}): exploring on from "
                                      f"{look.why}")
                else:
                    self.steps.append(f"{self.out.captures}: no seen-free spot beside {tid}: looking from {look.why}")
                looks.append((tuple(look.eye), float(look.yaw)))
                if math.dist(here, look.goal) > 0.2:
                    why = self.move(tuple(float(v) for v in look.goal), "closed")
                    if why is not None:
                        if is_contact(why):
                            self.contact_routes.append((here, tuple(float(v) for v in look.goal)))
                        self.steps.append(f"move to the look not done: {why}")
                self.turn(look.yaw)
                self.capture()
                continue
            if math.dist(here[:2], app.goal[:2]) < 0.2 and self.pos[2] < 0.1:
                self.out.found = True
                return "found"
            goal = tuple(float(v) for v in app.goal)
            if repeats(here, goal, self.contact_routes):
                return "found, not reached: the route beside it ended in contact before (not repeated)"
            self.steps.append(f"going beside {tid} at {goal}")
            why = self.move(goal, "closed")
            if why is None:
                self.out.found = True
                return "found"
            if is_contact(why):
                self.contact_routes.append((here, goal))
            self.steps.append(f"the move beside {tid} did not end there: {why}")
            self.capture()
        return "found but the move beside it failed"


__all__ = ["CAPTURE_S", "MIN_PIXELS", "Outcome", "Picker", "SimSearch", "scaled_intrinsics"]
