"""``morphonavi describe SCENE.json [--pose x,y,z,yaw_deg] [--json]``: the scene graph or its summary.

Registered by :mod:`console.cli.morphonavi`. The scene must be in the world frame; the robot pose is
``x,y[,z[,yaw_deg]]`` (world [m], heading in degrees from +x, counter-clockwise) and defaults to
the pose of the scene's latest capture, if it has one. The grid options are those of ``plan``
(reachability uses the same grid and costs). User mistakes (missing or malformed file, a bad
``--pose`` value, a bad grid option) print ``morphonavi describe: error: ...`` naming the field
and exit with status 2. When objects lie outside the planning workspace (``--bounds``, default the
paper's 5 x 8 x 3 m room) the summary ends with a note saying so and suggesting ``--bounds`` that
hold them all.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path
from typing import Any


class DescribeError(Exception):
    """A user-facing error of ``describe`` (exit status 2)."""


def _robot_limits() -> dict[str, tuple[float, str]]:
    from pipeline.option_values import POSE_XY_LIMIT_M, POSE_YAW_LIMIT_DEG, POSE_Z_LIMIT_M

    return {"x": (POSE_XY_LIMIT_M, "m"), "y": (POSE_XY_LIMIT_M, "m"), "z": (POSE_Z_LIMIT_M, "m"),
            "yaw_deg": (POSE_YAW_LIMIT_DEG, "deg")}


_ROBOT_LIMITS = _robot_limits()


def parse_robot(text: str) -> tuple[float, float, float, float]:
    """``"x,y[,z[,yaw_deg]]"`` -> ``(x, y, z, yaw [rad])`` (world frame); raises naming the field."""
    names = ("x", "y", "z", "yaw_deg")
    parts = [p.strip() for p in str(text).split(",")]
    if not 2 <= len(parts) <= 4 or not all(parts):
        raise DescribeError(f"--pose: expected 'x,y[,z[,yaw_deg]]' (metres, degrees), got {text!r}")
    values = []
    for name, part in zip(names, parts):
        try:
            v = float(part)
        except ValueError:
            raise DescribeError(f"--pose.{name}: must be a number, got {part!r}") from None
        if not math.isfinite(v):
            raise DescribeError(f"--pose.{name}: must be finite, got {part!r}")
        limit, unit = _ROBOT_LIMITS[name]
        if abs(v) > limit:
            raise DescribeError(f"--pose.{name}: must be within {-limit:g}..{limit:g} {unit} (the range of "
                                f"map --pose), got {v:g}")
        values.append(v)
    values += [0.0] * (4 - len(values))
    return (values[0], values[1], values[2], math.radians(values[3]))


MAX_GRID_CELLS = 2_000_000
"""Largest grid a ``--bounds`` suggestion may ask for (cells); a larger one comes with a coarser ``--resolution``."""


def robot_from_captures(scene: Any) -> tuple[float, float, float, float] | None:
    """The robot pose ``(x, y, z, yaw [rad])`` of the scene's latest capture that has one."""
    best = None
    for c in scene.captures:
        p = c.robot_pose
        if all(k in p for k in ("x", "y")) and (best is None or c.timestamp >= best.timestamp):
            best = c
    if best is None:
        return None
    p = best.robot_pose
    vals = (float(p["x"]), float(p["y"]), float(p.get("z", 0.0)), float(p.get("yaw", 0.0)))
    return vals if all(math.isfinite(v) for v in vals) else None


def bounds_hint(graph: dict[str, Any], scene: Any, pad: float) -> str:
    """A note when the robot or objects the graph marks ``outside_workspace`` lie outside the
    planning workspace: which, and ``--bounds`` (world [m], rounded out to whole metres, ``pad``
    [m] around every object and the robot, the z range kept or stretched to the robot) that hold
    them all; ``""`` when nothing lies outside."""
    ws = graph.get("workspace")
    if not ws:
        return ""
    out = [o["id"] for o in graph["objects"] if (o.get("reach") or {}).get("code") == "outside_workspace"]
    robot = (graph.get("robot") or {}).get("position")
    robot_out = robot is not None and not all(ws["min"][a] <= robot[a] <= ws["max"][a] for a in range(3))
    if not out and not robot_out:
        return ""
    lo, hi = list(ws["min"]), list(ws["max"])
    for ctr, r in [(o.position, math.hypot(o.size[0], o.size[2]) / 2 + pad) for o in scene.objects] + \
            ([(robot, pad)] if robot is not None else []):
        for a in (0, 1):
            lo[a], hi[a] = min(lo[a], ctr[a] - r), max(hi[a], ctr[a] + r)
    if robot_out and not ws["min"][2] <= robot[2] <= ws["max"][2]:
        lo[2], hi[2] = min(lo[2], robot[2] - pad), max(hi[2], robot[2] + pad)
    b = [math.floor(lo[0]), math.floor(lo[1]), lo[2] if lo[2] == ws["min"][2] else math.floor(lo[2]),
         math.ceil(hi[0]), math.ceil(hi[1]), hi[2] if hi[2] == ws["max"][2] else math.ceil(hi[2])]
    n = len(out) + robot_out
    w = (f"x {ws['min'][0]:g} to {ws['max'][0]:g} m, y {ws['min'][1]:g} to {ws['max'][1]:g} m, "
         f"z {ws['min'][2]:g} to {ws['max'][2]:g} m")
    ids = ", ".join(out[:5]) + (", ..." if len(out) > 5 else "")
    objects = f"{len(out)} object{'' if len(out) == 1 else 's'} ({ids})" if out else ""
    subject = " and ".join(x for x in ("the robot" if robot_out else "", objects) if x)
    res = float(ws.get("resolution") or 0.25)
    cells = math.prod(max(1, round((b[a + 3] - b[a]) / res)) for a in range(3))
    coarser = ""
    if cells > MAX_GRID_CELLS:  # the suggestion must be one describe accepts: a coarser grid with it
        res = math.ceil(res * (cells / MAX_GRID_CELLS) ** (1 / 3) * 100) / 100
        coarser = f" --resolution {res:g}"
    return (f"({subject} {'lies' if n == 1 else 'lie'} outside the planning workspace ({w}): "
            f"give one that holds {'it' if n == 1 else 'them'} with --bounds xmin,ymin,zmin,xmax,ymax,zmax, "
            f"e.g. --bounds={','.join(f'{v:g}' for v in b)}{coarser})")


def describe(args: argparse.Namespace) -> tuple[str, dict[str, Any]]:
    """The summary text and the graph for parsed ``describe`` arguments (raises :class:`DescribeError`)."""
    from pipeline.file_kind import FileKindError, load_scene_file
    from pipeline.scene import SceneError
    from planner.grid import CostWeights, GridError, Workspace, build_grid
    from planner.object_goal import APPROACH_MAX
    from planner.route import Route
    from planner.scene_graph import SceneGraphError, build_scene_graph
    from planner.scene_summary import summarize

    robot = parse_robot(args.robot) if args.robot is not None else None
    try:
        scene = load_scene_file(args.scene)
    except FileKindError as exc:
        raise DescribeError(str(exc)) from None
    except SceneError as exc:
        raise DescribeError(f"{args.scene}: {exc}") from None
    note = ""
    if robot is None:
        robot = robot_from_captures(scene)
        if robot is not None:
            note = "robot pose from the scene's latest capture"
    for name in ("resolution", "margin", "w_ground", "w_takeoff", "w_flight", "w_danger"):
        v = getattr(args, name)
        if not math.isfinite(v):
            raise DescribeError(f"--{name.replace('_', '-')}: must be finite, got {v}")
    try:
        ws = Workspace(args.bounds[0], args.bounds[1], args.resolution)
        weights = CostWeights(args.w_ground, args.w_takeoff, args.w_flight, args.w_danger)
        grid = build_grid(scene, ws, args.margin)
        route = Route(grid, robot[:3] if robot else ws.min, weights)
        graph = build_scene_graph(scene, robot, grid, route=route if robot else None)
    except (GridError, SceneGraphError) as exc:
        raise DescribeError(str(exc)) from None
    text = summarize(graph)
    hint = bounds_hint(graph, scene, APPROACH_MAX + args.margin)
    if hint:
        text += f"\n{hint}"
    if note:
        text += f"\n({note})"
    return text, graph


def cmd_describe(args: argparse.Namespace) -> int:
    if args.schema:
        from planner.scene_graph_schema import SCENE_GRAPH_SCHEMA

        print(json.dumps(SCENE_GRAPH_SCHEMA, indent=1))
        return 0
    if args.scene is None:
        print("morphonavi describe: error: give a scene JSON file (or --schema)", file=sys.stderr)
        return 2
    try:
        text, graph = describe(args)
    except DescribeError as exc:
        print(f"morphonavi describe: error: {exc}", file=sys.stderr)
        return 2
    print(json.dumps(graph, indent=1) if args.json else text)
    return 0


def add_describe_parser(subparsers: Any) -> argparse.ArgumentParser:
    """Register ``morphonavi describe``."""
    from console.cli.cli_args import _add_planner_args

    p = subparsers.add_parser(
        "describe", help="describe a scene: objects, relations, groups, reachability (text or JSON scene graph)",
        description="Print a short summary of a world-frame scene for people and language models, or its scene "
                    "graph (--json, schema version 2: --schema prints it).")
    p.add_argument("scene", type=Path, nargs="?", default=None, help="scene JSON (world frame)")
    p.add_argument("--pose", "--robot", dest="robot", default=None, metavar="X,Y[,Z[,YAW_DEG]]",
                   help="robot pose in the world frame [m, degrees from +x], as map --pose; default: the latest "
                        "capture's (--robot is the old name: console --robot names the robot link)")
    p.add_argument("--json", action="store_true", help="print the scene graph as JSON instead of the summary")
    p.add_argument("--schema", action="store_true", help="print the JSON schema of the scene graph and exit")
    _add_planner_args(p)
    p.set_defaults(func=cmd_describe)
    return p


__all__ = ["DescribeError", "add_describe_parser", "bounds_hint", "cmd_describe", "describe", "parse_robot",
           "robot_from_captures"]
