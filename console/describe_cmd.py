"""``morphonavi describe SCENE.json [--robot x,y,z,yaw_deg] [--json]``: the scene graph or its summary.

Registered by :mod:`console.cli`. The scene must be in the world frame; the robot pose is
``x,y[,z[,yaw_deg]]`` (world [m], heading in degrees from +x, counter-clockwise) and defaults to
the pose of the scene's latest capture, if it has one. The grid options are those of ``plan``
(reachability uses the same grid and costs). User mistakes (missing or malformed file, a bad
``--robot`` value, a bad grid option) print ``morphonavi describe: error: ...`` naming the field
and exit with status 2.
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


def parse_robot(text: str) -> tuple[float, float, float, float]:
    """``"x,y[,z[,yaw_deg]]"`` -> ``(x, y, z, yaw [rad])`` (world frame); raises naming the field."""
    names = ("x", "y", "z", "yaw_deg")
    parts = [p.strip() for p in str(text).split(",")]
    if not 2 <= len(parts) <= 4 or not all(parts):
        raise DescribeError(f"--robot: expected 'x,y[,z[,yaw_deg]]' (metres, degrees), got {text!r}")
    values = []
    for name, part in zip(names, parts):
        try:
            v = float(part)
        except ValueError:
            raise DescribeError(f"--robot.{name}: must be a number, got {part!r}") from None
        if not math.isfinite(v):
            raise DescribeError(f"--robot.{name}: must be finite, got {part!r}")
        values.append(v)
    values += [0.0] * (4 - len(values))
    return (values[0], values[1], values[2], math.radians(values[3]))


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


def describe(args: argparse.Namespace) -> tuple[str, dict[str, Any]]:
    """The summary text and the graph for parsed ``describe`` arguments (raises :class:`DescribeError`)."""
    from pipeline.scene import Scene, SceneError
    from planner.grid import CostWeights, GridError, Workspace, build_grid
    from planner.route import Route
    from planner.scene_graph import SceneGraphError, build_scene_graph
    from planner.scene_summary import summarize

    robot = parse_robot(args.robot) if args.robot is not None else None
    try:
        scene = Scene.load(args.scene)
    except SceneError as exc:
        raise DescribeError(f"{args.scene}: {exc}") from None
    except RecursionError:
        raise DescribeError(f"{args.scene}: JSON nested too deeply") from None
    except OSError as exc:
        raise DescribeError(f"{args.scene}: cannot read: {exc.strerror or exc}") from None
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
    from .cli import _add_planner_args

    p = subparsers.add_parser(
        "describe", help="describe a scene: objects, relations, groups, reachability (text or JSON scene graph)",
        description="Print a short summary of a world-frame scene for people and language models, or its scene "
                    "graph (--json, schema version 1: --schema prints it).")
    p.add_argument("scene", type=Path, nargs="?", default=None, help="scene JSON (world frame)")
    p.add_argument("--robot", default=None, metavar="X,Y[,Z[,YAW_DEG]]",
                   help="robot pose in the world frame [m, degrees from +x]; default: the latest capture's")
    p.add_argument("--json", action="store_true", help="print the scene graph as JSON instead of the summary")
    p.add_argument("--schema", action="store_true", help="print the JSON schema of the scene graph and exit")
    _add_planner_args(p)
    p.set_defaults(func=cmd_describe)
    return p


__all__ = ["DescribeError", "add_describe_parser", "cmd_describe", "describe", "parse_robot", "robot_from_captures"]
