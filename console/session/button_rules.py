"""One rule per vehicle-command button: whether it is on, and if not, why (the same words the session refuses with).

The robot panel disables a button and shows the reason on hover from these functions; the session
(:meth:`~console.session.operator_session.OperatorRules.land_mission`, ``return_mission``) and
:class:`~console.session.vehicle_commands.VehicleCommands` refuse a click, an MCP call or a test's call
with the reason from the *same* function, so the button and the refusal can never disagree.

The base rules (link lost, position unknown or stale, a mission under way, the failsafe, the vehicle flying
its own mode, unseen floor) are :func:`console.session.operator_state.vehicle_commands`; this module adds
what a button would otherwise be refused for after the click:

- **Land here** is off over a mapped obstacle (``desk 'desk-1' is below the robot at (2.50, 3.00)``) and over
  space below the robot that the known space has not seen (:func:`~console.session.operator_state.landing_blocker`),
  and, with its reason, on the ground (``the robot is not flying: nothing to land``; the button is hidden
  there, but a call is refused with these words).
- **Hold** is off while the robot stands or hovers: it is holding already (``nothing to hold``).
- **Return** is off at critical charge (``battery 8 %: critical (below 10 %), the robot must land here, not fly
  back``: like ArduPilot's critical battery failsafe with action Land). It says where it lands
  (:func:`return_hint`): at the take-off spot, not where the operator started the last mission; or, when the
  robot may not land there (within its radius of a wall, an object on the spot), at the nearest spot it fits, with how far and why -- from :func:`planner.landing_spot.return_spots`,
  the function the session's Return plans to (:meth:`~console.session.operator_session.OperatorRules.return_mission`).
  With no such spot, Return is off with the reason.

Frames and units: world frame (z up) [m].
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Mapping, Sequence

from planner.grid import PlanningGrid, Workspace
from planner.landing_spot import return_spots

from console.session import operator_state as rules
from console.session.operator_state import CommandState
from console.session.session_types import RobotSnapshot, RunStatus, Vec3, fmt_point

HELD_MODES = frozenset({"idle", "holding"})
"""Robot modes in which it is not moving (standing, or hovering in place): Hold has nothing to stop."""


def _why_hidden(state: CommandState, robot: RobotSnapshot | None, run: RunStatus) -> CommandState:
    """A hidden command keeps a reason for a call that comes anyway (the MCP door, a second tab)."""
    if state.shown or state.reason:
        return state
    if robot is None:
        return CommandState(False, False, "no state from the robot yet")
    if run.state == "running":
        return CommandState(False, False, "a mission is running: use Pause or Abort")
    return state


def land_here(robot: RobotSnapshot | None, run: RunStatus, ws: Workspace, launch: Vec3 | None,
              grid: PlanningGrid | None, forced: bool = False) -> CommandState:
    """Land here: shown while the robot is in the air; off (with the reason) when the session would refuse it.

    ``forced`` (the critical-battery landing only): floor or space below that was not seen does not stop it
    (a forced landing beats a crash); a mapped obstacle below still does.
    """
    base = rules.vehicle_commands(robot, run, ws, launch, None if forced else grid)["land"]
    if robot is not None and not base.shown and not rules.airborne(robot, ws):
        return CommandState(False, False, "the robot is not flying: nothing to land")
    if not base.shown:
        return _why_hidden(base, robot, run)
    if not base.enabled or grid is None:
        return base
    why = rules.landing_blocker(robot, grid, forced)
    if why is not None:
        return CommandState(True, False, f"cannot land here: {why}")
    return base


def hold(robot: RobotSnapshot | None, run: RunStatus, ws: Workspace, launch: Vec3 | None) -> CommandState:
    """Hold: off while the robot already stands or hovers in place (``nothing to hold``)."""
    base = _why_hidden(rules.vehicle_commands(robot, run, ws, launch)["hold"], robot, run)
    if robot is None or not base.shown or not base.enabled:
        return base
    mode = str(robot.mode)
    if mode in HELD_MODES:
        doing = "hovers in place" if rules.airborne(robot, ws) else "stands still"
        return CommandState(True, False, f"the robot already {doing}: nothing to hold")
    return base


@dataclass(frozen=True)
class ReturnTarget:
    """Where Return lands (world frame, z up [m]).

    Attributes:
        spot: The first spot Return plans to (the take-off spot, or the nearest floor cell centre the
            landing rule fits), ``None`` when no floor spot fits.
        why: Why not at the take-off spot (``too near the wall``, the landing rule's words), ``""`` when
            it lands on it.
    """

    spot: tuple[float, float, float] | None
    why: str


_last_target: tuple[Any, tuple[float, float, float], ReturnTarget] | None = None
"""The last :func:`return_target` answer with its grid and take-off spot: the robot panel asks on every robot
report, and a :class:`~planner.grid.PlanningGrid` (frozen) changes only by being replaced."""


def return_target(grid: PlanningGrid | None, launch: Sequence[float]) -> ReturnTarget:
    """Where Return lands from take-off spot ``launch`` (world [m]): the first of
    :func:`planner.landing_spot.return_spots`, the spots the session's Return plans to in order (a later
    one only when the planner cannot reach the first). No grid: the take-off spot."""
    global _last_target
    home = (float(launch[0]), float(launch[1]), float(launch[2]) if len(launch) > 2 else 0.0)
    if grid is None:
        return ReturnTarget(home, "")
    last = _last_target
    if last is not None and last[0] is grid and last[1] == home:
        return last[2]
    spots, why = return_spots(grid, home)
    target = ReturnTarget(spots[0] if spots else None, why)
    _last_target = (grid, home, target)
    return target


def no_return_spot(launch: Sequence[float], why: str) -> str:
    """The reason Return is off (and refused) when no floor spot fits the landing rule."""
    return (f"cannot plan the return: no floor spot fits the landing rule (the take-off spot "
            f"{fmt_point((float(launch[0]), float(launch[1])))}: {why})")


def return_home(robot: RobotSnapshot | None, run: RunStatus, ws: Workspace, launch: Vec3 | None,
                grid: PlanningGrid | None = None) -> CommandState:
    """Return: off when there is nothing to return to (launch spot unknown, at it already), when no floor
    spot near the take-off spot fits the landing rule (with ``grid``: :func:`return_target`), or when it
    would be refused otherwise."""
    base = _why_hidden(rules.vehicle_commands(robot, run, ws, launch)["return"], robot, run)
    if base.enabled and rules.battery_level(robot) == "critical":  # like BATT_FS_CRT_ACT=Land: no flying back
        return CommandState(base.shown, False, f"{rules.battery_blocker(robot)} here, not fly back")
    if not base.enabled or launch is None or grid is None:
        return base
    target = return_target(grid, launch)
    if target.spot is None:
        return CommandState(base.shown, False, no_return_spot(launch, target.why))
    return base


def return_hint(launch: Vec3 | None, grid: PlanningGrid | None = None,
                end: Sequence[float] | None = None) -> str:
    """What Return does, for its hover text, the mission panel and its notice: where it lands.

    Args:
        launch: The take-off spot (world [m]), ``None`` when not known yet.
        grid: The planning grid; ``None``: the take-off spot is taken as fit for landing.
        end: Where a Return already planned ends (its mission's last point, world [m]); ``None``: where
            :func:`return_target` says it will land.

    Example: ``Return: lands at (0.38, 0.62), 0.19 m from the take-off spot (0.20, 0.70), where the robot
    cannot land: too near the wall``.
    """
    if launch is None:
        return "Return: lands at the take-off spot (not known yet: the robot was never seen standing disarmed)"
    home = fmt_point((float(launch[0]), float(launch[1])))
    target = return_target(grid, launch)
    if not target.why:
        return f"Return: lands at the take-off spot {home}"
    spot = end if end is not None else target.spot
    if spot is None:
        return f"Return: no floor spot near the take-off spot {home} fits the landing rule ({target.why})"
    d = math.hypot(float(spot[0]) - float(launch[0]), float(spot[1]) - float(launch[1]))
    return (f"Return: lands at {fmt_point((float(spot[0]), float(spot[1])))}, {d:.2f} m from the take-off spot "
            f"{home}, where the robot cannot land: {target.why}")


def vehicle_commands(robot: RobotSnapshot | None, run: RunStatus, ws: Workspace, launch: Vec3 | None,
                     grid: PlanningGrid | None = None) -> dict[str, CommandState]:
    """Every vehicle command's state (``hold``, ``land``, ``return``, ``disarm``, ``control``) by the rules above."""
    out = dict(rules.vehicle_commands(robot, run, ws, launch, grid))
    out["hold"] = hold(robot, run, ws, launch)
    out["land"] = land_here(robot, run, ws, launch, grid)
    out["return"] = return_home(robot, run, ws, launch, grid)
    return out


def hover_text(name: str, label: str, state: CommandState, launch: Vec3 | None, hint: str | None = None) -> str:
    """A vehicle-command button's hover text: what it does, and why it is off (the session's own words).

    ``hint``: Return's line where the session computed it with the grid (``OperatorView.return_hint``);
    ``None``: :func:`return_hint` without the grid."""
    does = (hint or return_hint(launch)) if name == "return" else f"Vehicle command: {label}"
    if state.enabled or not state.reason:
        return does
    why = state.reason if state.reason.startswith(f"{label} is off") else f"{label} is off: {state.reason}"
    return f"{does} · {why}"


def refusal(name: str, label: str, states: Mapping[str, Any]) -> str | None:
    """Why the session refuses command ``name`` now (the words its button shows), or ``None`` when it applies."""
    state = states.get(name)
    if state is None:
        return f"{label} is not a vehicle command"
    if state.enabled:
        return None
    if not state.shown:
        return state.reason or f"{label} applies only while the robot is armed or off the ground"
    return f"{label} is not possible now: {state.reason}"


__all__ = ["HELD_MODES", "ReturnTarget", "hold", "hover_text", "land_here", "no_return_spot", "refusal", "return_hint",
           "return_home", "return_target", "vehicle_commands"]
