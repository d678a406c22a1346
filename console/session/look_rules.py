"""One rule per Map-folder button (Capture & map, Look around, Look at goal, Go look, Undo, Redo): whether it
is on, and if not, why; and its hover text (what it does, and why it is off).

The views disable a button and show the reason on hover from these functions, and refuse a click that
comes anyway (a second tab that has not redrawn yet) with the *same* words, as the vehicle-command buttons do
(:mod:`console.session.button_rules`). The jobs refuse what these rules do not see (a capture starting in
the same instant): :meth:`~console.session.look.LookJob.look_at`, :meth:`~console.session.go_look.GoLookJob.start`.

- **Capture & map** is off while a look runs (it captures itself) or a capture is being mapped.
- **Look around** is off while a look, a Go look, a capture or a mission is under way, and while the robot's
  state or position is not known.
- **Look at goal** and **Go look**: as Look around, and while the Goal x / y fields are not numbers or are
  within one grid cell (horizontally) of the robot: :data:`NO_GOAL`. The fields start at the robot's own
  position, so before a goal is typed or clicked there is nothing to face.
- **Undo** / **Redo** are off when there is nothing to undo / redo.

Frames and units: world frame (z up) [m].
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Sequence

from console.session.operator_state import CommandState
from console.session.session_types import RobotSnapshot

NO_GOAL = "no goal yet: type or click a goal"
"""Why Look at goal and Go look are off while the Goal x / y fields are at the robot."""

DOES = {
    "capture": "Ask the robot for a photo and its pose, detect objects and add them to the map",
    "around": "Turn in place through {n} headings, capturing and mapping at each (a full circle)",
    "look_at": "Turn to face the point in the Goal x / y fields and capture & map",
    "go_look": ("For the goal in the Goal x / y fields, refused as unseen: go to the suggested look (a mission "
                "you see), face the goal, capture & map, and plan the goal again (or offer the next look)"),
    "undo": "Undo the last map edit: spawn, move, delete, capture or load (Ctrl+Z)",
    "redo": "Put back the edit Undo took away (Ctrl+Shift+Z); a new edit clears it",
}
"""What each button does, the first part of its hover text (``{n}``: Look around's heading count)."""

LABELS = {"capture": "Capture & map", "around": "Look around", "look_at": "Look at goal", "go_look": "Go look",
          "undo": "Undo", "redo": "Redo"}


@dataclass(frozen=True)
class Busy:
    """What is under way (each ``True`` while it runs)."""

    look: bool = False
    go_look: bool = False
    mapping: bool = False
    mission: bool = False


def _on() -> CommandState:
    return CommandState(True, True, "")


def _off(why: str) -> CommandState:
    return CommandState(True, False, why)


def capture(busy: Busy) -> CommandState:
    """Capture & map: off while a look runs or a capture is being mapped (the click's refusals)."""
    if busy.look:
        return _off("a look is running: pause or stop it first")
    if busy.mapping:
        return _off("a capture is already being mapped")
    return _on()


def robot_blocker(robot: RobotSnapshot | None) -> str | None:
    """Why the robot cannot turn to look now (no state, link lost, position unknown), or ``None``."""
    if robot is None:
        return "no state from the robot: is the link connected?"
    if not getattr(robot, "healthy", True):
        return "the robot link is lost"
    if not getattr(robot, "position_valid", True):
        return "the robot's position is unknown: it cannot turn to look yet"
    return None


def look_around(busy: Busy, robot: RobotSnapshot | None) -> CommandState:
    """Look around: off while anything that moves the robot or maps runs, or the robot is not known."""
    if busy.look or busy.go_look:
        return _off("a look is already running: pause or stop it first")
    if busy.mapping:
        return _off("a capture is being mapped: wait for it")
    if busy.mission:
        return _off("a mission is under way (running or paused): abort it before looking around")
    why = robot_blocker(robot)
    return _on() if why is None else _off(why)


def goal_blocker(typed: Sequence[str], robot: RobotSnapshot | None, resolution: float) -> str | None:
    """Why the Goal x / y fields give nothing to look at, or ``None``.

    Args:
        typed: The Goal x, y (and z) fields as typed (text) [m], world frame; empty: no fields yet.
        robot: The robot (its pose's x, y), ``None`` when not known (then only the numbers are checked).
        resolution: The planning grid's cell [m]: a goal nearer the robot than this (horizontally) is
            taken as no goal (the fields start at the robot's position, to 2 decimals).
    """
    if len(typed) < 2:
        return NO_GOAL
    try:
        x, y = float(typed[0]), float(typed[1])
    except (ValueError, TypeError):
        shown = ", ".join(repr(str(v)) for v in list(typed)[:2])
        return f"Goal x / y must be numbers [m], got {shown}"
    if not (math.isfinite(x) and math.isfinite(y)):
        return f"Goal x / y must be finite numbers [m], got {x}, {y}"
    if robot is None:
        return None
    rx, ry = float(robot.pose.translation[0]), float(robot.pose.translation[1])
    d = math.hypot(x - rx, y - ry)
    if d < resolution:
        return f"{NO_GOAL} (Goal x / y ({x:.2f}, {y:.2f}) is where the robot stands, {d:.2f} m away)"
    return None


def look_at_goal(busy: Busy, robot: RobotSnapshot | None, typed: Sequence[str], resolution: float) -> CommandState:
    """Look at goal (and Go look): as :func:`look_around`, then :func:`goal_blocker`."""
    base = look_around(busy, robot)
    if not base.enabled:
        return base
    why = goal_blocker(typed, robot, resolution)
    return base if why is None else _off(why)


def history(what: str | None, verb: str) -> CommandState:
    """Undo (``verb`` ``undo``) / Redo (``redo``): off when there is nothing to undo / redo (``what`` is ``None``)."""
    return _on() if what is not None else _off(f"nothing to {verb}")


def hover(name: str, state: CommandState, headings: int = 6) -> str:
    """A Map-folder button's hover text: what it does (:data:`DOES`), then ``· {label} is off: {reason}`` when off."""
    does = DOES[name].format(n=headings)
    if state.enabled or not state.reason:
        return does
    return f"{does} · {LABELS[name]} is off: {state.reason}"


__all__ = ["Busy", "DOES", "LABELS", "NO_GOAL", "capture", "goal_blocker", "history", "hover", "look_around",
           "look_at_goal", "robot_blocker"]
