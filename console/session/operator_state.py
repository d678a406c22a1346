"""The operator's state rules in one place: where the route starts, what may run, which vehicle
commands apply, which goals are refused, and missions that start in the air.

Pure functions over the session's values (no locks, no I/O): :class:`console.session.session.Session`
calls them under its lock and the views only draw what they return.

The rules:

- **The route starts at the robot.** Whenever no mission runs and the robot is at rest, the next
  candidate is planned from :func:`robot_origin` (the floor under the robot, or, in the air, the
  robot's own position in its air cell). A route with registered segments that does not start
  there (restored, reconnected, the robot moved) is *stale*: :func:`route_note` says so and the
  operator has one action, *Re-plan from the robot*.
- **Execute is enabled only for a mission that can run**; :func:`execute_blocker` gives the reason
  otherwise (no robot state, link lost, position unknown or stale, vehicle not ready to take off,
  robot moving, the mission starts elsewhere ...).
- **A position that is not known is never used**: while the link reports no valid position
  (unknown before the first one, stale after its stream stopped), :func:`robot_origin` is
  ``None`` (the route does not follow a placeholder, the launch spot is not moved) and
  :func:`position_blocker` says why.
- **Vehicle commands** (:func:`vehicle_commands`): Hold, Land here, Return and Disarm, shown
  whenever the robot is armed or off the ground and no mission is driving it. Land here and
  Return plan from the robot's position: off while it is unknown or stale; Return from the ground
  (a take-off) also waits for readiness. Hold and Disarm need no position.
- **What each button may do in each mission state** (running, paused, failsafe, ended) is one
  table, :mod:`console.session.mission_rules`: no Build, Execute or route edit while a mission is
  under way (paused included), with the reason; :func:`route_edits` applies it to the route buttons.
- **Goals inside the robot's margin are refused** with the reason (:func:`goal_clearance`).
- **Battery** (like a ground station's low-battery warning and ArduPilot's battery failsafe):
  below :data:`BATTERY_LOW` Execute is off with the reason (:func:`battery_blocker`) and every tab
  is warned once per crossing; below :data:`BATTERY_CRITICAL` a running mission is ended and the
  robot lands where it is (Land here), unless the vehicle's own failsafe already acts
  (:func:`battery_action`). An unknown charge (``None``) never blocks.
- **A mission that ends in the air** is flagged (:func:`ends_in_air`) so the operator can add a landing.
- **A mission whose remaining segments cross an obstacle** (:func:`remaining_blocked`) is ended and
  re-planned from the robot.

Frames and units: world frame (z up) [m]; yaw [rad].
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Sequence

import numpy as np

from pipeline.scene import Scene
from planner.grid import CellState, Closed, CostWeights, PlanningGrid, Workspace
from planner.landing_spot import landing_problem, unseen_footprint
from planner.mission import (
    Mission, MissionError, MissionSegment, SegmentKind, check_landing, mission_from_cells, simplify,
)

from console.session import mission_rules
from console.session.session_types import RobotSnapshot, RunStatus, Vec3, fmt_point
from console.wording import kind_text

START_TOLERANCE = 0.3
"""How far [m] (3D) a mission or route may start from the robot and still count as starting there
(the simulator's own start tolerance)."""
MOVING_MODES = frozenset({"walking", "taking_off", "flying", "landing"})
"""Robot modes in which it is under way (not at rest)."""
BATTERY_LOW = 0.25
"""Charge [0..1] below which Execute is off and the operator is warned (land or Return)."""
BATTERY_CRITICAL = 0.10
"""Charge [0..1] below which a running mission is ended and the robot lands where it is."""
BATTERY_HYSTERESIS = 0.02
"""How far [0..1] the charge must rise above a threshold before crossing it again warns again."""
ROBOT_HEIGHT = 0.45
"""Height of the robot's body above the floor [m], for the clearance of ground goals."""


# --- where the robot is ------------------------------------------------------------------------------
def airborne(robot: RobotSnapshot, ws: Workspace) -> bool:
    """Whether the robot is off the ground (the link's ``landed`` flag, else its height)."""
    landed = getattr(robot, "landed", None)
    if landed is not None:
        return not landed
    return float(robot.pose.translation[2]) - ws.floor > ws.resolution / 2


def at_rest(robot: RobotSnapshot) -> bool:
    """Whether the robot is standing or hovering (not walking, climbing, flying or landing)."""
    return robot.mode not in MOVING_MODES


def position_blocker(robot: RobotSnapshot) -> str | None:
    """Why the robot's reported position cannot be used (unknown or stale), or ``None``."""
    status = getattr(robot, "position_status", "known")
    if status == "unknown":
        return "the robot's position is unknown (no valid position from the vehicle yet)"
    if status == "stale":
        return "the robot's position is stale (no valid position from the vehicle lately)"
    return None


def link_lost(robot: RobotSnapshot) -> str:
    """The reason for a lost link (steady text: no ages that change with every sample)."""
    return "the robot link is lost" + (": its position is stale" if getattr(robot, "position_status", "") == "stale"
                                       else "")


def readiness_blocker(robot: RobotSnapshot) -> str | None:
    """Why the robot cannot take off now (its readiness), or ``None`` when it is ready."""
    if getattr(robot, "ready", True):
        return None
    return "the robot is not ready: " + (getattr(robot, "readiness", "") or "the vehicle says so")


def battery_level(robot: RobotSnapshot | None) -> str:
    """``"critical"``, ``"low"`` or ``"ok"`` for the robot's charge (``"ok"`` when it is unknown)."""
    b = None if robot is None else getattr(robot, "battery", None)
    if b is None or not isinstance(b, (int, float)) or not math.isfinite(b):
        return "ok"  # unknown never blocks
    if b < BATTERY_CRITICAL:
        return "critical"
    return "low" if b < BATTERY_LOW else "ok"


def battery_blocker(robot: RobotSnapshot | None) -> str | None:
    """Why the charge forbids a new mission (below :data:`BATTERY_LOW`), or ``None``."""
    level = battery_level(robot)
    if level == "ok":
        return None
    b = float(robot.battery)  # type: ignore[union-attr]
    if level == "critical":
        return f"battery {100 * b:.0f} %: critical (below {100 * BATTERY_CRITICAL:.0f} %), the robot must land"
    return f"battery {100 * b:.0f} %: below {100 * BATTERY_LOW:.0f} %, land or Return"


def battery_text(robot: RobotSnapshot) -> str:
    """The robot panel's battery (HTML-safe): the charge, and what a low or critical level means."""
    b = getattr(robot, "battery", None)
    if b is None or not isinstance(b, (int, float)) or not math.isfinite(b):
        return "battery ?"
    level = battery_level(robot)
    if level == "critical":  # what the vehicle does: on the ground it stays there
        doing = "landing" if getattr(robot, "landed", None) is not True else "on the ground, do not take off"
        return f"<b style='color:#d62728'>battery {100 * b:.0f}% CRITICAL: {doing}</b>"
    if level == "low":
        return f"<b style='color:#e67e22'>battery {100 * b:.0f}% low: land or Return</b>"
    return f"battery {100 * b:.0f}%"


def own_failsafe(robot: RobotSnapshot) -> bool:
    """Whether the vehicle is already bringing itself down (its failsafe or a landing)."""
    return robot.mode in ("failsafe", "landing")


def battery_action(robot: RobotSnapshot | None, run: RunStatus, ws: Workspace) -> str | None:
    """What the console must do about a critical charge: ``"land"`` (in the air: end the run, land
    here), ``"end"`` (on the ground: end a run still active, e.g. paused after the vehicle's own
    failsafe landed it), or ``None`` (charge fine or unknown, nothing to end, or the vehicle's own
    failsafe already acts: aborting would cancel its landing)."""
    if robot is None or battery_level(robot) != "critical":
        return None
    if not airborne(robot, ws):
        return "end" if run.active else None
    if own_failsafe(robot) or run.state == "failsafe":
        return None
    return "land"


def robot_origin(robot: RobotSnapshot, ws: Workspace) -> Vec3 | None:
    """Where the next candidate starts: the floor under the robot, or its position in the air
    (world [m]); ``None`` when the robot is outside the workspace or its position is not known
    (:func:`position_blocker`)."""
    if position_blocker(robot) is not None:
        return None
    x, y, z = (float(v) for v in robot.pose.translation)
    p = (x, y, z) if airborne(robot, ws) else (x, y, ws.floor)
    return p if ws.contains(p) else None


def gap(a: Sequence[float], b: Sequence[float]) -> float:
    """3D distance between two world points [m]."""
    return math.dist(tuple(a)[:3], tuple(b)[:3])


def route_note(start: Vec3, origin: Vec3 | None, registered: int) -> str | None:
    """Why a route with ``registered`` segments does not start at the robot, or ``None``."""
    if origin is None or registered == 0:
        return None
    d = gap(start, origin)
    if d <= START_TOLERANCE:
        return None
    return (f"the route starts at {fmt_point(start)}, {d:.2f} m from the robot at {fmt_point(origin)}: "
            "re-plan it from the robot")


def execute_blocker(mission: Mission | None, robot: RobotSnapshot | None, run: RunStatus, has_runner: bool,
                    ws: Workspace) -> str | None:
    """Why Execute cannot run ``mission`` now, or ``None`` if it can."""
    if not has_runner:
        return "this robot link has no mission manager"
    if run.active:
        return "a mission is under way: pause or abort it first"
    if mission is None:
        return "no mission: register a path, then Build mission"
    if robot is None:
        return "no state from the robot yet"
    if not robot.healthy:
        return link_lost(robot)
    why = battery_blocker(robot) or position_blocker(robot) or readiness_blocker(robot)
    if why is not None:
        return why
    if not at_rest(robot):
        return f"the robot is {robot.mode.replace('_', ' ')}: wait until it stands or hovers"
    origin = robot_origin(robot, ws)
    if origin is None:
        return f"the robot at {fmt_point(robot.pose.translation)} is outside the workspace"
    first = mission.segments[0].start
    d = gap(first, origin)
    if d > START_TOLERANCE:
        return (f"the mission starts at {fmt_point(first)}, {d:.2f} m from the robot at {fmt_point(origin)}: "
                "re-plan it from the robot")
    return None


# --- route edits ---------------------------------------------------------------------------------
def route_edits(has_candidate: bool, registered: int, read_only: bool = False,
                run_state: str = "idle") -> dict[str, bool]:
    """Which route edit buttons have something to act on: Register / Discard need a candidate;
    Undo / Build mission need a registered segment; Clear either (it drops both); nothing in a
    read-only (replay) console; and only what the mission state allows (:mod:`console.session.mission_rules`:
    none while a mission runs, is paused or a failsafe acts)."""
    cand, reg = bool(has_candidate) and not read_only, registered > 0 and not read_only
    edits = {"register": cand, "discard": cand, "undo": reg, "clear": reg or cand, "build": reg}
    return {b: ok and mission_rules.allowed(b, run_state) for b, ok in edits.items()}


# --- vehicle commands ----------------------------------------------------------------------------
COMMANDS = ("hold", "land", "return", "disarm", "control")


@dataclass(frozen=True)
class CommandState:
    """One vehicle command as the operator sees it: shown, enabled, and why not."""

    shown: bool = False
    enabled: bool = False
    reason: str = ""


def vehicle_commands(robot: RobotSnapshot | None, run: RunStatus, ws: Workspace,
                     launch: Vec3 | None, grid: PlanningGrid | None = None) -> dict[str, CommandState]:
    """Hold / Land here / Return / Disarm / Take control for the robot's state.

    With ``grid`` (the session's planning grid), Land here is off over floor not seen free in the
    known space (:func:`unseen_floor_blocker`); without it (or with no known space) it is not checked.

    While the vehicle flies a mode it chose itself (``robot.vehicle_control``: a failsafe's RTL or
    LAND, another ground station, RC), only *Take control* is on: the others would command it.

    Shown whenever the robot is armed or off the ground and no mission is running (a running
    mission has Pause / Abort); Land here and Return need no mission under way; Disarm only on
    the ground.
    """
    off = {name: CommandState() for name in COMMANDS}
    taken = getattr(robot, "vehicle_control", "") if robot is not None else ""
    if taken:  # the vehicle flies a mode it chose (RTL, LAND, ...): the console commands nothing until the
        # operator takes control back, knowingly (a confirmation that says what the vehicle does)
        lost = "" if robot.healthy else link_lost(robot)
        why = f"the vehicle flies its own mode ({taken}): Take control first"
        out = {name: CommandState(True, False, why) for name in ("hold", "land", "return")}
        out["disarm"] = CommandState()
        out["control"] = CommandState(True, not lost, lost)
        return out
    if robot is None or run.state == "running":
        return off
    up = airborne(robot, ws)
    if not (robot.armed or up):
        return off
    busy = "the mission is paused: abort it first" if run.active else ""
    lost = "" if robot.healthy else link_lost(robot)
    if run.state == "failsafe":  # the manager holds or lands the robot: nothing may interfere
        busy = "the failsafe is acting (holding, then landing): wait for it or abort the mission"
        lost = lost or busy
    out = {"hold": CommandState(True, not lost, lost)}
    nowhere = position_blocker(robot) or ""  # Land here and Return plan from the position
    if up:
        why = lost or nowhere or busy
        if not why and grid is not None:
            why = unseen_floor_blocker(robot.pose.translation, grid) or ""
        out["land"] = CommandState(True, not why, why)
    else:
        out["land"] = CommandState()
    origin = robot_origin(robot, ws)
    if launch is None:
        why = "the launch spot is unknown (the robot was never seen on the ground)"
    elif lost or nowhere:
        why = lost or nowhere
    elif not up and (readiness_blocker(robot) or battery_blocker(robot)):  # Return from the ground takes off
        why = readiness_blocker(robot) or battery_blocker(robot) or ""
    elif origin is not None and not up and gap(origin, launch) <= START_TOLERANCE:
        why = "the robot is at the launch spot"
    elif origin is None:
        why = "the robot is outside the workspace"
    else:
        why = lost or busy
    out["return"] = CommandState(True, not why, why)
    if up:
        out["disarm"] = CommandState()
    else:
        why = lost or busy
        out["disarm"] = CommandState(True, not why, why)
    out["control"] = CommandState()  # the console has control
    return out


def unseen_floor(point: Sequence[float], grid: PlanningGrid) -> bool:
    """Whether any floor column under the robot's footprint at ``point`` (world [m]; x, y used) is not
    seen free (the landing rule's first item: :func:`planner.landing_spot.unseen_footprint`)."""
    return unseen_footprint(grid, point)


def unseen_floor_blocker(point: Sequence[float], grid: PlanningGrid) -> str | None:
    """Why the operator may not land at ``point`` (world [m]): the floor below has not been seen free
    (:func:`unseen_floor`), or ``None``. The planner's rule for landing spots, for Land here."""
    if not unseen_floor(point, grid):
        return None
    where = fmt_point((float(point[0]), float(point[1])))
    return f"Land here is off: the floor below {where} has not been seen: look down there first, or Return"


def landing_blocker(robot: RobotSnapshot, grid: PlanningGrid, forced: bool = False) -> str | None:
    """Why the robot cannot land straight down where it hovers (a mapped obstacle below), or ``None``.

    ``forced`` (the critical-battery landing): with known space, cells closed only because they
    were not seen (:attr:`Closed.UNKNOWN`, or the clearance around such cells) do not stop it."""
    ws = grid.workspace
    x, y, z = (float(v) for v in robot.pose.translation)
    top = ws.cell_of((x, y, min(z, ws.max[2])))
    if top is None:
        return f"the robot at {fmt_point((x, y, z))} is outside the workspace"
    known = grid.rule != "fully_known" and grid.reason is not None
    for k in range(top[2], -1, -1):
        cell = (top[0], top[1], k)
        if grid.state_at(cell) is CellState.OCCUPIED:
            owner = grid.owner_of(cell)
            why = grid.reason_at(cell)
            if why is Closed.EDGE:  # near the workspace's edge: going straight down brings it no nearer
                continue
            if known and (why is Closed.UNKNOWN or (why is Closed.CLEARANCE and owner is None)):
                if forced:
                    continue
                if why is Closed.UNKNOWN:
                    return (f"the space below the robot at {fmt_point((x, y))} has not been seen: "
                            "look down there first, or Return")
            return (f"{owner or 'an obstacle'} is below the robot at {fmt_point((x, y))}: "
                    "use Return, or plan a goal on free floor")
    why = landing_problem(grid, (x, y), forced)  # the whole footprint on the floor: the one landing rule
    return None if why is None or why.kind == "unseen" else f"{why}: use Return, or plan a goal on free floor"


def land_here_mission(robot: RobotSnapshot, ws: Workspace, mission_id: str) -> Mission:
    """A one-segment mission: land straight down from where the robot hovers."""
    x, y, z = (float(v) for v in robot.pose.translation)
    seg = MissionSegment(SegmentKind.LAND, ((x, y, max(z, ws.floor)), (x, y, ws.floor)))
    return Mission((seg,), ws.min, ws.max, id=mission_id)


# --- goals ---------------------------------------------------------------------------------------
def _box_distance(p_lo: np.ndarray, p_hi_z: float, obj_pos: Sequence[float], size: Sequence[float],
                  yaw: float) -> float:
    """Distance [m] from a vertical segment (x, y, z0..z1) to an upright box (centre, (w, h, l), yaw)."""
    w, h, l = size
    dx, dy = p_lo[0] - obj_pos[0], p_lo[1] - obj_pos[1]
    c, s = math.cos(yaw), math.sin(yaw)
    along, across = c * dx + s * dy, -s * dx + c * dy  # length axis, width axis
    ex = max(0.0, abs(along) - l / 2)
    ey = max(0.0, abs(across) - w / 2)
    z0, z1 = float(p_lo[2]), float(p_hi_z)
    b0, b1 = obj_pos[2] - h / 2, obj_pos[2] + h / 2
    ez = max(0.0, b0 - z1, z0 - b1)
    return math.sqrt(ex * ex + ey * ey + ez * ez)


def goal_clearance(goal: Sequence[float], scene: Scene, margin: float, ws: Workspace) -> str | None:
    """Why ``goal`` (world [m]) is too close to a mapped object for a robot of radius ``margin``
    [m], or ``None``. A goal on the floor counts the robot's body height (:data:`ROBOT_HEIGHT`)."""
    g = np.asarray(goal, dtype=np.float64)
    on_floor = g[2] - ws.floor <= ws.resolution / 2
    top = ws.floor + ROBOT_HEIGHT if on_floor else float(g[2])
    worst: tuple[float, str] | None = None
    for obj in scene.objects:
        if obj.frame != "world":
            continue
        d = _box_distance(g, top, obj.position, obj.size, obj.yaw)
        if d < margin and (worst is None or d < worst[0]):
            worst = (d, f"{obj.label.replace('_', ' ')} '{obj.id}'")
    if worst is None:
        return None
    d, name = worst
    where = "inside" if d <= 1e-9 else f"{d:.2f} m from"
    return (f"goal {fmt_point(g)} is {where} {name}; the robot needs {margin:.2f} m around it "
            "(its radius): choose a point further away")


# --- missions ------------------------------------------------------------------------------------
def ends_in_air(mission: Mission | None, ws: Workspace) -> float | None:
    """Height above the floor [m] at which ``mission`` ends if it ends in the air, else ``None``."""
    if mission is None:
        return None
    last = mission.segments[-1]
    if last.kind in (SegmentKind.FLY, SegmentKind.TAKEOFF):
        return float(last.end[2]) - ws.floor
    return None


def mission_from_path(cells: np.ndarray, grid: PlanningGrid, mission_id: str | None = None) -> Mission:
    """A cell path (K x 3, start..goal) as a mission; unlike :func:`planner.mission.mission_from_cells`
    it may start in the air (the robot hovers): it then flies to its first landing spot and lands.
    Raises :class:`MissionError` naming the problem."""
    cells = np.asarray(cells, dtype=np.int64).reshape(-1, 3)
    if len(cells) == 0:
        raise MissionError("the path is empty")
    ws = grid.workspace
    extra = {} if mission_id is None else {"id": mission_id}
    if cells[0, 2] == 0:
        m = mission_from_cells(cells, grid)
        return Mission(m.segments, m.bounds_min, m.bounds_max, **extra) if extra else m
    centres = ws.centers(cells)
    ground = np.nonzero(cells[:, 2] == 0)[0]
    k = int(ground[0]) if len(ground) else len(cells)
    air = [tuple(map(float, centres[t])) for t in range(k)]
    segs: list[MissionSegment] = []
    if k < len(cells):
        spot = (float(centres[k, 0]), float(centres[k, 1]), ws.floor)
        check_landing(grid, spot[:2])  # the one landing rule (free ground under the whole footprint)
        air.append((spot[0], spot[1], air[-1][2]))
    fly = simplify(np.array(air))
    if len(fly) > 1:
        segs.append(MissionSegment(SegmentKind.FLY, tuple(tuple(map(float, p)) for p in fly)))  # type: ignore[arg-type]
    if k < len(cells):
        segs.append(MissionSegment(SegmentKind.LAND, (tuple(map(float, fly[-1])), spot)))  # type: ignore[arg-type]
        if len(cells) - k > 1:
            segs.extend(mission_from_cells(cells[k:], grid).segments)
    if not segs:  # one air cell: hover where it is
        segs.append(MissionSegment(SegmentKind.FLY, (air[0],)))
    return Mission(tuple(segs), ws.min, ws.max, **extra)


def _samples(seg: MissionSegment, step: float) -> np.ndarray:
    pts = np.asarray(seg.waypoints, dtype=np.float64)
    if len(pts) == 1:
        return pts
    out = [pts[0]]
    for a, b in zip(pts[:-1], pts[1:]):
        n = max(1, int(math.ceil(float(np.linalg.norm(b - a)) / step)))
        out.extend(a + (b - a) * (i / n) for i in range(1, n + 1))
    return np.array(out)


def remaining_blocked(mission: Mission, from_segment: int, grid: PlanningGrid,
                      weights: CostWeights = CostWeights()) -> str | None:
    """Which obstacle the segments ``from_segment..`` of ``mission`` now cross on ``grid``, or ``None``.

    Points are sampled every half cell; a point in an impassable cell (occupied, or the take-off
    layer next to an obstacle away from the segment's own spot) blocks.
    """
    ws = grid.workspace
    cost = grid.cost(weights)
    for i in range(max(0, from_segment), len(mission.segments)):
        seg = mission.segments[i]
        for p in _samples(seg, ws.resolution / 2):
            cell = ws.cell_of(p)
            if cell is None:
                return f"segment {i + 1} ({kind_text(seg.kind)}) leaves the workspace at {fmt_point(p)}"
            state = grid.state_at(cell)
            if state is CellState.OCCUPIED or (seg.kind in (SegmentKind.WALK, SegmentKind.FLY)
                                               and not math.isfinite(cost[cell])):
                owner = grid.owner_of(cell)
                return f"segment {i + 1} ({kind_text(seg.kind)}) now crosses {owner or 'an obstacle'} at {fmt_point(p)}"
    return None


def goals_left(goals: Sequence[Vec3], path: np.ndarray, ends: Sequence[int], origin: Vec3) -> list[Vec3]:
    """The registered goals the robot has not reached yet.

    ``path`` is the registered path (K x 3 world points), ``ends[i]`` the index in it of goal ``i``;
    the robot's progress is the path point nearest to ``origin``. Goals within
    :data:`START_TOLERANCE` of the robot count as reached.
    """
    if len(path) == 0:
        return [g for g in goals if gap(g, origin) > START_TOLERANCE]
    here = int(np.argmin(np.linalg.norm(np.asarray(path) - np.asarray(origin), axis=1)))
    return [g for g, e in zip(goals, ends) if e > here and gap(g, origin) > START_TOLERANCE]
