"""Click picking in the 3D view: where a click ray meets a horizontal plane, and the goal it picks;
what a click means (goal through objects, or select), typed goals, the top view, goal drop lines.

World frame (z up) [m].
"""

from __future__ import annotations

import math
from typing import Any, Sequence

import numpy as np

from planner.grid import Workspace

from console.session.session_types import SessionError, Vec3, fmt_point


def ray_plane(origin: Sequence[float], direction: Sequence[float], z: float) -> Vec3 | None:
    """Where a ray meets the horizontal plane at height ``z`` [m] (world), or ``None``.

    ``None`` when the ray is parallel to the plane or the plane lies behind the origin.
    """
    o = np.asarray(origin, dtype=np.float64)
    d = np.asarray(direction, dtype=np.float64)
    if o.shape != (3,) or d.shape != (3,) or not (np.all(np.isfinite(o)) and np.all(np.isfinite(d))):
        return None
    if abs(d[2]) < 1e-9:
        return None
    t = (z - o[2]) / d[2]
    if t <= 0:
        return None
    p = o + t * d
    return (float(p[0]), float(p[1]), float(z))


def goal_on_plane(origin: Sequence[float], direction: Sequence[float], z: float, workspace: Workspace) -> Vec3:
    """The goal a click ray picks: its hit with the plane at height ``z`` (world [m]).

    Raises :class:`SessionError` when the ray misses the plane or the hit lies outside the
    workspace's x-y bounds.
    """
    p = ray_plane(origin, direction, z)
    if p is None:
        raise SessionError(f"the click does not hit the plane z = {z:.2f} m; click on the floor or a grid layer")
    ws = workspace
    if not (ws.min[0] <= p[0] <= ws.max[0] and ws.min[1] <= p[1] <= ws.max[1]):
        raise SessionError(f"goal {fmt_point(p[:2])} is outside the workspace {fmt_point(ws.min[:2])}..{fmt_point(ws.max[:2])}")
    return p


TOP_DOWN_DEG = 10.0
"""A 3D view looking within this angle [deg] of straight down counts as a top view for clicks."""


def looks_down(position: Sequence[float], look_at: Sequence[float], tolerance_deg: float = TOP_DOWN_DEG) -> bool:
    """Whether a camera at ``position`` looking at ``look_at`` (world [m]) looks (nearly) straight down."""
    d = np.asarray(look_at, dtype=np.float64) - np.asarray(position, dtype=np.float64)
    n = float(np.linalg.norm(d)) if d.shape == (3,) and np.all(np.isfinite(d)) else 0.0
    if n < 1e-9:
        return False
    return float(-d[2] / n) >= math.cos(math.radians(tolerance_deg))


def click_goal(origin: Sequence[float], direction: Sequence[float], z: float, workspace: Workspace,
               top_down: bool = False) -> Vec3:
    """The goal a click ray picks at height ``z`` (world [m]).

    In a view from the side the goal is where the ray meets the plane at ``z`` (where the altitude layer
    is drawn). In a top view (``top_down``, :func:`looks_down`) the operator points at the floor plan:
    the goal is the floor point under the cursor, raised to ``z`` (the plane at ``z`` lies nearer the
    camera, so its hit would land off the spot, towards the view's centre). Raises :class:`SessionError`
    as :func:`goal_on_plane`.
    """
    floor = float(workspace.floor)
    if top_down and z > floor:
        x, y, _ = goal_on_plane(origin, direction, floor, workspace)
        return (x, y, float(z))
    return goal_on_plane(origin, direction, z, workspace)


SELECT_MODIFIER = "shift"
"""Held while clicking an object, it selects the object even in goal mode."""


def click_intent(click_to_goal: bool, modifier: str | None, on_object: bool) -> str | None:
    """What a click in the 3D view does: ``"goal"``, ``"select"`` or ``None`` (nothing).

    In goal mode (``click_to_goal``) a plain click goes *through* objects: its ray is a goal on
    the floor or the altitude plane even when an object is under the cursor, so the floor just
    behind a box can be clicked. Objects are selected by a plain click in select mode, or by a
    click with :data:`SELECT_MODIFIER` held in either mode. Other modifiers do nothing.

    Args:
        click_to_goal: Goal mode (``True``) or select mode (``False``).
        modifier: The modifier keys held (viser's canonical form, e.g. ``"shift"``), or ``None``.
        on_object: Whether the click landed on an object.
    """
    if modifier == SELECT_MODIFIER:
        return "select" if on_object else None
    if modifier is not None:
        return None
    if click_to_goal:
        return "goal"
    return "select" if on_object else None


def typed_xyz(values: Sequence[Any], field: str) -> list[float]:
    """Three typed numbers ``(x, y, z)`` [m] of the field ``field`` (``goal``, ``centre`` ...).

    Raises :class:`SessionError` naming the bad one (``centre.x: must be a number [m], got 'abc'``);
    booleans, text, NaN and infinities are refused."""
    try:
        items = list(values)
    except TypeError:
        raise SessionError(f"{field}: must be three numbers x, y, z [m], got {values!r}") from None
    if len(items) != 3:
        raise SessionError(f"{field}: must be three numbers x, y, z [m], got {len(items)}")
    return [typed_number(v, f"{field}.{name}", "m") for name, v in zip("xyz", items)]


def typed_number(value: Any, field: str, unit: str) -> float:
    """One typed number of the field ``field`` in ``unit``; :class:`SessionError` names the field
    (``yaw: must be a number [deg], got 'abc'``) for booleans, text, NaN and infinities."""
    if isinstance(value, bool):
        raise SessionError(f"{field}: must be a number [{unit}], got {value!r}")
    try:
        f = float(value)
    except (TypeError, ValueError):
        raise SessionError(f"{field}: must be a number [{unit}], got {value!r}") from None
    if not math.isfinite(f):
        raise SessionError(f"{field}: must be a finite number [{unit}], got {value!r}")
    return f


def typed_goal(values: Sequence[Any], workspace: Workspace) -> Vec3:
    """A goal typed as ``(x, y, z)`` (world [m], z = height of the goal; the floor is ``workspace.floor``).

    Raises :class:`SessionError` naming the bad field (``goal.y: must be a finite number``) or
    saying which bound the point leaves.
    """
    out = typed_xyz(values, "goal")
    ws = workspace
    for axis, name in enumerate("xyz"):
        lo, hi = float(ws.min[axis]), float(ws.max[axis])
        if not lo <= out[axis] <= hi:
            raise SessionError(f"goal.{name}: {out[axis]:.2f} m is outside the workspace ({lo:.2f} to {hi:.2f} m)")
    return (out[0], out[1], out[2])


def top_view(workspace: Workspace, vfov: float, aspect: float, margin: float = 1.1) -> tuple[Vec3, Vec3, Vec3]:
    """A camera looking straight down at the whole workspace: ``(position, look_at, up)`` (world [m]).

    The whole flight volume is in the picture, not only the floor: its top rectangle, nearer the
    camera, looks bigger than the floor, so the camera is put far enough above the *top* (a robot
    hovering at 2.1 m by a wall stays in the picture).

    Args:
        workspace: The workspace to frame (its whole box).
        vfov: The camera's vertical field of view [rad], in (0, pi).
        aspect: Its width / height, > 0.
        margin: How much room to leave around the workspace (1.1 = 10 %).

    The camera sits above the workspace centre; ``up`` is world +z as the orbit controls expect,
    so the view is tilted by a hair (1e-3 of the height) towards -y: the picture has +y up.
    """
    if not (math.isfinite(vfov) and 0.0 < vfov < math.pi):
        raise SessionError(f"camera fov must be in (0, pi) rad, got {vfov!r}")
    if not (math.isfinite(aspect) and aspect > 0.0):
        raise SessionError(f"camera aspect must be > 0, got {aspect!r}")
    ws = workspace
    cx, cy = (ws.min[0] + ws.max[0]) / 2, (ws.min[1] + ws.max[1]) / 2
    half_w, half_h = (ws.max[0] - ws.min[0]) / 2 * margin, (ws.max[1] - ws.min[1]) / 2 * margin
    tan_v = math.tan(vfov / 2)
    dist = max(half_h / tan_v, half_w / (tan_v * aspect))
    height = float(ws.max[2]) + max(dist, 0.5)  # the top rectangle fits; so does the floor, farther away
    return ((cx, cy - 1e-3 * height, height), (cx, cy, float(ws.floor)), (0.0, 0.0, 1.0))


def drop_lines(points: Sequence[Sequence[float]], floor: float, min_height: float = 0.05) -> np.ndarray:
    """Vertical segments (N x 2 x 3) from each point above the floor down to it (world [m]).

    Points within ``min_height`` of the floor get none: they already stand on it.
    """
    p = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    p = p[p[:, 2] - floor > min_height]
    if not len(p):
        return np.zeros((0, 2, 3))
    foot = p.copy()
    foot[:, 2] = floor
    return np.stack([p, foot], axis=1)
