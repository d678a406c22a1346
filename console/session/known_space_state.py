"""Known space in the console's session: updated by every capture, saved, restored, undone with it.

The session holds one :class:`~pipeline.mapping.known_space.KnownSpace` on the planning grid's cells
(world frame, z up [m]), or ``None`` before the first capture. Before the first capture the console's
map (``Session(empty_is_unseen=True)``) with no scene file spawned or loaded is *nothing seen*: it is
planned as all unknown space (:meth:`KnownSpaceSession.nothing_seen_locked`), so every way of planning
(a goal, Return, Land here, a search, Go look) refuses to cross it while unknown space is closed; a map
made of scene files (a hand-made map), and any session made without that flag (scripts), is taken as
fully known, as the planner does without known space. Each mapped capture casts its
depth (the simulator's rendered depth, a depth model's scaled map, or, without either, the mapped
boxes: :func:`~pipeline.mapping.known_space_update.box_depth`) through it, and the robot's own body
at the capture is free by definition. The planning grid is rebuilt with it: walking and flying only
through seen-free space unless the operator allows planning into unknown space ("Plan into unknown
space"; the planner then marks the unseen part of a route).

This module is :class:`KnownSpaceSession`, mixed into :class:`~console.session.session.Session`; the
session file keeps the known space under ``"known_space"`` (its compact JSON form) and the policy
under ``"plan_unknown"``; the undo history keeps it with each capture.
"""

from __future__ import annotations

import inspect
import logging
import math
from dataclasses import dataclass
from typing import Any, Mapping, Sequence

import numpy as np

from pipeline.mapping.known_space import KnownSpace, KnownSpaceError, KnownState, unlabelled_cells
from pipeline.scene import Scene, SceneObject
from planner.grid import GridError, PlanningGrid, Workspace, build_grid
from planner.robot_model import MORPHOGEAR

from console.session.session_types import Notice, SessionError
from console.session.topics import GRID, MISSION, ROUTE

log = logging.getLogger(__name__)

KNOWN_SPACE = "known_space"
"""Session topic: the known space changed (payload: :class:`KnownSpaceSummary`)."""

UNKNOWN_POLICIES = ("closed", "allow")

BODY_HEIGHT = 0.45
"""The robot's walking body height [m] kept free around it at each capture (MorphoGear's default)."""

NEAR_FREE = MORPHOGEAR.radius + 0.25
"""Around where the robot stood at a capture, cells within this [m] in plan (its footprint radius,
0.35 m, plus one planning cell) and up to its body height that no capture has seen are taken as free:
the robot's own cells are free by definition (it stands there), and the camera (0.35 m up, 24.5
degrees below the horizon at the edge of its view) cannot see the floor nearer than about 0.77 m.
Farther floor the camera did not see stays unknown. Cells a capture saw occupied keep that."""

_CURRENT: Any = object()
"""Default of the ``known`` arguments below: the session's own known space."""

DEPTH_NOISE_REL = 0.05
"""Relative 1-sigma depth error [1] assumed for a depth model's scaled map (the simulator's is exact)."""


@dataclass(frozen=True)
class KnownSpaceSummary:
    """What the known space holds, for the page.

    Attributes:
        cells: Cells of the grid.
        free: Seen-free cells.
        occupied: Seen-occupied cells.
        unknown: Cells no capture has seen.
        unlabelled: Occupied cells no mapped object explains (obstacles the detector missed).
        policy: ``closed`` (only seen-free space is planned through) or ``allow``.
        rule: ``captures`` (known space from captures), ``nothing_seen`` (no capture yet on the console's
            own map: every cell unknown) or ``fully_known`` (no known space: a hand-made map).
        given: With ``fully_known``: the map came from scene files (spawned or loaded).
    """

    cells: int = 0
    free: int = 0
    occupied: int = 0
    unknown: int = 0
    unlabelled: int = 0
    policy: str = "closed"
    rule: str = "captures"
    given: bool = False

    @property
    def seen_share(self) -> float:
        return (self.free + self.occupied) / self.cells if self.cells else 0.0

    def text(self) -> str:
        """``known space: 38 % seen · 12 unlabelled obstacle cells · unknown space closed``."""
        rule = "unknown space closed" if self.policy == "closed" else "planning into unknown space"
        if self.rule == "nothing_seen":
            then = ("no goal is planned until Capture & map or Look around" if self.policy == "closed"
                    else "routes cross space no capture has seen (drawn dashed)")
            return f"known space: nothing seen yet (every cell is unknown) · {rule}: {then}"
        if not self.cells:
            what = "the map from scene files" if self.given else "the map"
            return f"known space: none yet (Capture & map builds it); {what} is taken as fully known"
        cells = "cell" if self.unlabelled == 1 else "cells"
        return (f"known space: {100 * self.seen_share:.0f} % seen · {self.unlabelled} unlabelled obstacle {cells}"
                f" · {rule}")


def _grid_takes_known() -> bool:
    try:
        return "known" in inspect.signature(build_grid).parameters
    except (TypeError, ValueError):
        return False


def grid_for(scene: Scene, workspace: Workspace, margin: float, known: KnownSpace | None,
             policy: str = "closed") -> PlanningGrid:
    """The planning grid of ``scene`` with ``known`` space (``None``: fully known) under ``policy``."""
    if known is not None and _grid_takes_known():
        return build_grid(scene, workspace, margin, known=known, unknown=policy)  # type: ignore[call-arg]
    return build_grid(scene, workspace, margin)


def empty_known(workspace: Workspace) -> KnownSpace:
    """All unknown, on the planning grid's cells."""
    return KnownSpace.empty(workspace.min, workspace.max, workspace.resolution)


def known_from_saved(data: Mapping[str, Any], workspace: Workspace | None) -> tuple[KnownSpace | None, str, list[str]]:
    """The known space and policy of a session file's dict, and the problems (a bad part is dropped)."""
    problems: list[str] = []
    policy = data.get("plan_unknown", "closed")
    if policy not in UNKNOWN_POLICIES:
        problems.append(f"plan_unknown: must be 'closed' or 'allow', got {policy!r}: unknown space is closed")
        policy = "closed"
    raw = data.get("known_space")
    if raw is None:
        return None, policy, problems
    try:
        space = KnownSpace.from_dict(raw, "known_space")
    except KnownSpaceError as exc:
        problems.append(f"{exc}: the known space was not restored (the next capture starts it again)")
        return None, policy, problems
    if workspace is not None and not space.same_grid(empty_known(workspace)):
        problems.append(f"known_space: made for another workspace (origin {space.origin}, cells {space.resolution} m, "
                        f"{space.shape}): not restored")
        return None, policy, problems
    return space, policy, problems


def near_free(space: KnownSpace, position: Sequence[float], radius: float, height: float) -> KnownSpace:
    """``space`` with its *unknown* cells whose centre lies within ``radius`` [m] in plan of
    ``position`` (world [m], on the floor) and up to ``height`` [m] above it marked seen free (one
    miss); seen cells keep their state (see :data:`NEAR_FREE`)."""
    xs, ys, zs = (space.origin[a] + (np.arange(n) + 0.5) * space.resolution for a, n in enumerate(space.shape))
    foot = np.hypot(xs[:, None] - position[0], ys[None, :] - position[1]) <= radius + 1e-9
    col = (zs >= position[2] - 1e-9) & (zs <= position[2] + height + 1e-9)
    mask = foot[:, :, None] & col[None, None, :] & (space.log_odds == 0)
    if not mask.any():
        return space
    return space.updated(mask, np.zeros(space.shape, dtype=bool))


def objects_over(position: Sequence[float], objects: Sequence[SceneObject], radius: float,
                 height: float = BODY_HEIGHT) -> list[SceneObject]:
    """The world-frame objects whose box comes within ``radius`` [m] in plan of ``position`` (the
    robot's origin, world [m]) and overlaps the robot's body height: objects placed over the robot."""
    x, y, z = (float(v) for v in position[:3])
    out = []
    for o in objects:
        if o.frame != "world":
            continue
        w, h, l = o.size
        c, s = math.cos(o.yaw), math.sin(o.yaw)
        dx, dy = x - o.position[0], y - o.position[1]
        along, across = c * dx + s * dy, -s * dx + c * dy
        d = math.hypot(max(0.0, abs(along) - l / 2), max(0.0, abs(across) - w / 2))
        if d < radius and o.position[2] - h / 2 < z + height and o.position[2] + h / 2 > z:
            out.append(o)
    return out


class KnownSpaceSession:
    """The known-space half of :class:`~console.session.session.Session` (mixed in; its lock, state, save)."""

    # the session's state and hooks this mixin uses (set by Session.__init__)
    _lock: Any
    _workspace: Workspace
    _margin: float
    _scene: Scene
    _grid: PlanningGrid
    _route: Any
    _mission: Any
    _run: Any
    _outbox: list[Notice]
    _known: KnownSpace | None
    _plan_unknown: str
    _empty_is_unseen: bool
    _map_given: bool
    _emit: Any
    _save_locked: Any
    _mission_after_edit_locked: Any
    _set_scene_locked: Any
    notify: Any

    # --- read ------------------------------------------------------------------------------------
    @property
    def known_space(self) -> KnownSpace | None:
        with self._lock:
            return self._known

    @property
    def plan_unknown(self) -> str:
        """``closed`` (default) or ``allow``: whether routes may pass through unknown space."""
        with self._lock:
            return self._plan_unknown

    def known_summary(self) -> KnownSpaceSummary:
        with self._lock:
            known, scene, policy = self._known, self._scene, self._plan_unknown
            nothing, given = self.nothing_seen_locked(), self._map_given
        if nothing:
            n = int(np.prod(self._workspace.shape))
            return KnownSpaceSummary(n, 0, 0, n, 0, policy, "nothing_seen")
        if known is None:
            return KnownSpaceSummary(policy=policy, rule="fully_known", given=given)
        c = known.counts()
        unl = int(unlabelled_cells(known, scene.objects).sum())
        return KnownSpaceSummary(int(np.prod(known.shape)), c["free"], c["occupied"], c["unknown"], unl, policy)

    def unseen_route(self) -> tuple[np.ndarray, float]:
        """The route's moves into space not seen yet (only with unknown space allowed): line segments
        ``(K, 2, 3)`` (world [m], ground moves on the floor) and their length [m]. A move counts when
        the cell it ends in is unseen (as the planner counts its unseen metres)."""
        from planner.route import path_points

        with self._lock:
            grid = self._grid
            unseen = getattr(grid, "unseen", None)
            paths = list(self._route.registered)
            if self._route.candidate is not None:
                paths.append(self._route.candidate.cells)
        if unseen is None or not np.any(unseen):
            return np.zeros((0, 2, 3)), 0.0
        segs: list[np.ndarray] = []
        for cells in paths:
            c = np.asarray(cells, dtype=np.int64).reshape(-1, 3)
            if len(c) < 2:
                continue
            pts = path_points(c, grid)
            hit = unseen[c[1:, 0], c[1:, 1], c[1:, 2]]
            if hit.any():
                segs.append(np.stack([pts[:-1][hit], pts[1:][hit]], axis=1))
        if not segs:
            return np.zeros((0, 2, 3)), 0.0
        out = np.concatenate(segs, axis=0)
        return out, float(np.linalg.norm(out[:, 1] - out[:, 0], axis=1).sum())

    def nothing_seen_locked(self, scene: Scene | None = None, known: Any = _CURRENT) -> bool:
        """Whether the map is the console's own with nothing seen yet: made with ``empty_is_unseen``, no
        known space (no capture), and no scene file spawned or loaded that still has objects (a hand-made
        map). ``scene`` / ``known``: judge those instead of the session's (a change being made)."""
        scene = self._scene if scene is None else scene
        known = self._known if known is _CURRENT else known
        return bool(self._empty_is_unseen and known is None and not (self._map_given and scene.objects))

    def _grid_for_locked(self, scene: Scene, known: Any = _CURRENT) -> PlanningGrid:
        """The planning grid for ``scene`` with this session's known space (or ``known``) and policy; on
        the console's map with nothing seen yet (:meth:`nothing_seen_locked`) every cell is unknown (the
        robot's own cells are opened by the route, as at any start)."""
        known = self._known if known is _CURRENT else known
        if self.nothing_seen_locked(scene, known):
            known = empty_known(self._workspace)
        try:
            return grid_for(scene, self._workspace, self._margin, known, self._plan_unknown)
        except GridError as exc:
            raise SessionError(f"cannot build the planning grid: {exc}") from None

    def _known_json_locked(self) -> dict[str, Any]:
        """The session file's known-space keys."""
        return {"known_space": None if self._known is None else self._known.to_dict(),
                "plan_unknown": self._plan_unknown}

    # --- change ----------------------------------------------------------------------------------
    def set_plan_unknown(self, allow: bool) -> str:
        """Allow (or close again) planning into unknown space; the grid and route follow. Returns what changed."""
        policy = "allow" if allow else "closed"
        with self._lock:
            if self._run.active:
                raise SessionError("a mission is under way (running or paused): abort it before changing the rule")
            if policy == self._plan_unknown:
                return f"unknown space already {'allowed' if allow else 'closed'}"
            self._plan_unknown = policy
            self._regrid_locked()
        self._emit([(GRID, None), (ROUTE, None), (MISSION, None), (KNOWN_SPACE, self.known_summary())])
        return ("planning into unknown space: routes may cross space no capture has seen (drawn dashed)" if allow
                else "unknown space closed: routes only through seen-free space")

    def _regrid_locked(self) -> None:
        """Rebuild the grid for the same scene (not an undo step); the route and mission follow."""
        grid = self._grid_for_locked(self._scene)
        self._grid = grid
        self._route.set_grid(grid)
        self._mission = self._mission_after_edit_locked()
        self._save_locked()

    def observe_capture(self, capture_id: str, depth: np.ndarray | None, intrinsics: Any, camera_pose: Any,
                        robot_pose: Any, exact: bool = False) -> KnownSpaceSummary:
        """Cast one capture's depth [m] (optical axis, ``H x W``; ``None``: the mapped boxes') from
        ``camera_pose`` (``world <- camera``, OpenCV optical frame) through the known space; the robot's
        body at ``robot_pose`` is free. One undo step with the capture (same key). ``exact``: the
        simulator's rendered depth (no noise).

        Raises :class:`SessionError` when the depth cannot be used (wrong size, bad pose).
        """
        from pipeline.mapping.known_space_update import DepthNoise, box_depth, capture_update

        with self._lock:
            space = self._known if self._known is not None else empty_known(self._workspace)
            scene, ws, radius = self._scene, self._workspace, self._margin
        try:
            d = depth
            if d is None:
                d = box_depth(scene.objects, intrinsics, camera_pose, floor=ws.floor, pixel_step=4)
                upd = capture_update(space, d, intrinsics, camera_pose, pixel_step=4)
            else:
                noise = DepthNoise() if exact else DepthNoise(relative=DEPTH_NOISE_REL)
                upd = capture_update(space, np.nan_to_num(np.asarray(d, dtype=np.float64), nan=0.0), intrinsics,
                                     camera_pose, noise=noise)
            t = robot_pose.translation
            at = (float(t[0]), float(t[1]), max(float(t[2]), ws.floor))
            new = near_free(upd.space.with_free_body(at, radius, BODY_HEIGHT), at, max(radius, NEAR_FREE), BODY_HEIGHT)
        except KnownSpaceError as exc:
            raise SessionError(f"capture {capture_id}: known space not updated: {exc}") from None
        log.info("known space: capture %s cast %d rays in %.3f s (%d free, %d occupied cells)", capture_id,
                 upd.rays, upd.seconds, upd.free_cells, upd.occupied_cells)
        with self._lock:
            self._known = new
            notes = self._set_scene_locked(self._scene, f"capture {capture_id}", f"capture:{capture_id}")
            for note in notes:  # what the known space changed in the route (a goal not seen yet ...): said, not silent
                if note.startswith("candidate dropped"):
                    self._outbox.append(Notice("Route", f"capture {capture_id}: {note}", "warning"))
        summary = self.known_summary()
        self._emit([(GRID, None), (ROUTE, None), (MISSION, None), (KNOWN_SPACE, summary)])
        return summary

    def warn_objects_over_robot(self, what: str) -> list[str]:
        """Notices naming the mapped objects placed over the robot (a scene file, a load); returns them."""
        with self._lock:
            robot = getattr(self, "_robot", None)
            objects = self._scene.objects
            radius = self._margin
        if robot is None:
            return []
        here = robot.pose.translation
        names = [f"{o.label} '{o.id}'" for o in objects_over(here, objects, radius)]
        if names:
            body = (f"{what}: {', '.join(names)} lies over the robot at ({here[0]:.2f}, {here[1]:.2f}): the robot's own "
                    "cells stay free so it can move away, but check the object's position (move or delete it)")
            self.notify("Object over the robot", body, "warning")
            return [body]
        return []


__all__ = ["KNOWN_SPACE", "NEAR_FREE", "KnownSpaceSession", "KnownSpaceSummary", "UNKNOWN_POLICIES", "empty_known",
           "grid_for", "known_from_saved", "near_free", "objects_over"]
