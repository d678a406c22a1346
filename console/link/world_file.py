"""World files for the simulator: the hidden room, its bounds, its walls and where the robot starts.

A world file is JSON (world frame, z up, metres; headings in degrees counter-clockwise from +x)::

    {
      "morphonavi_world": 1,
      "name": "the paper's room",
      "bounds": {"min": [0, 0, 0], "max": [5, 8, 3]},
      "room": {"min": [0, -1, 0], "max": [5, 9, 4]},
      "start": {"position": [2.5, 0.7, 0.0], "yaw_deg": 90},
      "scene": "paper_room.scene.json"
    }

- ``bounds``: the workspace: the planning grid and the robot's safety net (it never leaves it);
- ``room`` (optional, ``null`` for none): the walls, floor and ceiling drawn in the renders;
- ``start``: the robot's start on the floor (``position`` z must be the bounds' floor) and heading;
- ``scene``: the hidden objects, a scene JSON object in place or the path of a scene file
  (relative to the world file), as ``morphonavi map`` writes them; objects in the world frame.

:func:`load_world` validates everything and raises :class:`WorldError` naming the field
(``start.yaw_deg: must be a finite number``). The examples ship in ``examples/worlds/``.
"""

from __future__ import annotations

import json
import math
import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from pipeline.camera.geometry import Pose
from pipeline.scene import Scene, SceneError, scene_from_dict, scene_from_json
from planner.grid import Workspace

from console.link.sim_config import SimConfig
from console.link.sim_contact import BodyContact
from console.link.world import DEFAULT_START, ROOM_MAX, ROOM_MIN, paper_room

WORLD_VERSION = 1
Vec3 = tuple[float, float, float]


class WorldError(ValueError):
    """A world file is malformed; the message starts with the file and the field."""


@dataclass(frozen=True)
class World:
    """A simulator world (world frame [m]).

    Attributes:
        name: What the operator calls it.
        scene: The hidden objects.
        bounds_min: Workspace corner [m].
        bounds_max: Workspace corner [m].
        room: Walls / floor / ceiling box drawn in renders ``(min, max)`` [m], or ``None``.
        start: ``world <- robot`` at the start (on the floor).
        path: The file it came from, or ``None`` (built in).
    """

    name: str
    scene: Scene
    bounds_min: Vec3
    bounds_max: Vec3
    room: tuple[Vec3, Vec3] | None
    start: Pose
    path: Path | None = None

    def workspace(self, resolution: float = 0.25) -> Workspace:
        """The planning workspace of these bounds at ``resolution`` [m]."""
        return Workspace(self.bounds_min, self.bounds_max, resolution)

    def link_options(self, resolution: float = 0.25, config: SimConfig | None = None) -> dict[str, Any]:
        """Keyword options for :class:`~console.link.sim.SimRobot` (``open_link("sim", **options)``)."""
        from dataclasses import replace

        cfg = replace(config or SimConfig(), workspace=self.workspace(resolution))
        return {"world": self.scene, "start": self.start, "room": self.room, "config": cfg}


def paper_world() -> World:
    """The built-in world: the paper's room (:func:`console.link.world.paper_room`)."""
    return World("the paper's room", paper_room(), (0.0, 0.0, 0.0), (5.0, 8.0, 3.0), (ROOM_MIN, ROOM_MAX),
                 DEFAULT_START)


def _vec3(value: Any, field: str) -> Vec3:
    if (not isinstance(value, list) or len(value) != 3
            or not all(isinstance(c, (int, float)) and not isinstance(c, bool) and math.isfinite(c) for c in value)):
        raise WorldError(f"{field}: must be 3 finite numbers [m], got {value!r}")
    return (float(value[0]), float(value[1]), float(value[2]))


def _box(data: dict[str, Any], key: str) -> tuple[Vec3, Vec3]:
    raw = data.get(key)
    if not isinstance(raw, dict):
        raise WorldError(f"{key}: must be an object {{\"min\": [x, y, z], \"max\": [x, y, z]}} [m]")
    lo, hi = _vec3(raw.get("min"), f"{key}.min"), _vec3(raw.get("max"), f"{key}.max")
    for a, axis in enumerate("xyz"):
        if not hi[a] > lo[a]:
            raise WorldError(f"{key}.max: must exceed {key}.min on every axis ({axis}: {hi[a]} <= {lo[a]})")
        if hi[a] - lo[a] > 200.0:
            raise WorldError(f"{key}: {hi[a] - lo[a]:.0f} m along {axis} is not a room (at most 200 m)")
    return lo, hi


def world_from_dict(data: Any, base: Path | None = None, body: SimConfig | None = None) -> World:
    """Validate a parsed world file and build the :class:`World`; ``base`` is the folder a relative
    ``scene`` path is read from. Raises :class:`WorldError` naming the field."""
    if not isinstance(data, dict):
        raise WorldError("the world file must be a JSON object")
    version = data.get("morphonavi_world")
    if version != WORLD_VERSION:
        raise WorldError(f"morphonavi_world: must be {WORLD_VERSION} (the world file format), got {version!r}")
    known = {"morphonavi_world", "name", "bounds", "room", "start", "scene", "description"}
    extra = sorted(set(data) - known)
    if extra:
        raise WorldError(f"{extra[0]}: unknown field (a world file has {', '.join(sorted(known))})")
    name = data.get("name", "unnamed world")
    if not isinstance(name, str) or not name.strip() or len(name) > 200:
        raise WorldError(f"name: must be a non-empty text of at most 200 characters, got {name!r}")
    lo, hi = _box(data, "bounds")
    room = None if data.get("room") is None else _box(data, "room")
    start_raw = data.get("start")
    if not isinstance(start_raw, dict):
        raise WorldError("start: must be an object {\"position\": [x, y, z], \"yaw_deg\": heading}")
    pos = _vec3(start_raw.get("position"), "start.position")
    yaw = start_raw.get("yaw_deg", 0.0)
    if not (isinstance(yaw, (int, float)) and not isinstance(yaw, bool) and math.isfinite(yaw)):
        raise WorldError(f"start.yaw_deg: must be a finite number [deg], got {yaw!r}")
    if not all(lo[a] <= pos[a] <= hi[a] for a in range(3)):
        raise WorldError(f"start.position: ({pos[0]}, {pos[1]}, {pos[2]}) is outside the bounds "
                         f"{list(lo)}..{list(hi)}")
    if abs(pos[2] - lo[2]) > 1e-6:
        raise WorldError(f"start.position: z must be the floor (bounds.min z = {lo[2]}): the robot starts standing, "
                         f"got {pos[2]}")
    scene = _scene(data.get("scene"), base)
    for i, o in enumerate(scene.objects):
        if o.frame != "world":
            raise WorldError(f"scene.objects[{i}].frame: must be world, got {o.frame!r}")
    cfg = body or SimConfig()
    contact = BodyContact(scene.objects, cfg.body_radius, cfg.body_height, room)
    if contact.touches_wall(pos):
        raise WorldError(f"start.position: the robot's body ({cfg.body_radius:.2f} m radius) at ({pos[0]}, {pos[1]}) "
                         "touches the room's wall: start it at least that far inside the room")
    if contact.touches(pos):
        near = min(scene.objects, key=lambda o: math.dist(o.position[:2], pos[:2]))
        raise WorldError(f"start.position: the robot's body ({cfg.body_radius:.2f} m radius) at ({pos[0]}, {pos[1]}) "
                         f"touches {near.label} '{near.id}': start it elsewhere")
    return World(name.strip(), scene, lo, hi, room, Pose.from_xyz_yaw(pos[0], pos[1], pos[2], math.radians(yaw)))


def _scene(raw: Any, base: Path | None) -> Scene:
    if isinstance(raw, str):
        path = Path(raw)
        if not path.is_absolute() and base is not None:
            path = base / path
        try:
            return scene_from_json(path.read_text(encoding="utf-8"))
        except FileNotFoundError:
            raise WorldError(f"scene: {path}: no such scene file") from None
        except (OSError, UnicodeDecodeError) as exc:
            raise WorldError(f"scene: {path}: cannot read it: {exc}") from None
        except SceneError as exc:
            raise WorldError(f"scene: {path}: {exc}") from None
    if isinstance(raw, dict):
        try:
            return scene_from_dict(raw)
        except SceneError as exc:
            raise WorldError(f"scene.{exc}" if exc.field else f"scene: {exc}") from None
    raise WorldError("scene: must be a scene JSON object or the path of a scene file")


def load_world(path: str | os.PathLike[str], body: SimConfig | None = None) -> World:
    """Read and validate a world file; raises :class:`WorldError` starting with the file's name."""
    p = Path(path)
    try:
        text = p.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise WorldError(f"{p}: no such world file") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise WorldError(f"{p}: cannot read it: {exc}") from None
    try:
        data = json.loads(text)
    except json.JSONDecodeError as exc:
        raise WorldError(f"{p}: not valid JSON (line {exc.lineno}, column {exc.colno}): {exc.msg}") from None
    except RecursionError:
        raise WorldError(f"{p}: not usable JSON: nested too deeply") from None
    try:
        world = world_from_dict(data, p.parent, body)
    except WorldError as exc:
        raise WorldError(f"{p}: {exc}") from None
    return World(world.name, world.scene, world.bounds_min, world.bounds_max, world.room, world.start, p)


__all__ = ["World", "WorldError", "load_world", "world_from_dict", "paper_world", "WORLD_VERSION"]
