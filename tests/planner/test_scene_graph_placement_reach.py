"""Scene graph: below the floor is not floating, and why an object is unreachable (each reason).

Small hand-made scenes in the default 5 x 8 x 3 m workspace (world frame, metres), robot near the
y = 0 wall facing +y, as in ``tests/planner/test_scene_graph.py``.
"""

from __future__ import annotations

import math
import re

import jsonschema
import pytest

from pipeline.scene import Scene, SceneObject
from planner.grid import Workspace, build_grid
from planner.object_goal import REASONS, ObjectGoalError, Reachability, goal_beside
from planner.scene_graph import build_scene_graph
from planner.scene_graph_schema import REASON_CODES, SCENE_GRAPH_SCHEMA, SCENE_GRAPH_SCHEMA_V1, schema_for
from planner.scene_summary import summarize

ROBOT = (2.5, 0.5, 0.0, math.pi / 2)
ALONG_Y = math.pi / 2  # yaw that lays an object's length along world y


def _obj(oid: str, label: str, x: float, y: float, size: tuple[float, float, float], z0: float = 0.0,
         yaw: float = 0.0) -> SceneObject:
    return SceneObject(oid, label, (x, y, z0 + size[1] / 2), size, yaw)


def _graph(objs, robot=ROBOT, ws=Workspace()):
    scene = Scene(objects=tuple(objs))
    g = build_scene_graph(scene, robot, build_grid(scene, ws, 0.35))
    jsonschema.validate(g, SCENE_GRAPH_SCHEMA)
    return g


def _o(g, oid):
    return next(o for o in g["objects"] if o["id"] == oid)


def _line(text: str, oid: str) -> str:
    return next(t for t in text.splitlines() if t.startswith("- ") and f"({oid})" in t)


def _reach(objs, target, start=ROBOT[:3]):
    scene = Scene(objects=tuple(objs))
    grid = build_grid(scene, Workspace(), 0.35)
    return Reachability(grid, start, objects=objs).approach(next(o for o in objs if o.id == target))


# --- below the floor is not floating ---------------------------------------------------------------


def test_sunken_object_is_below_the_floor_not_floating() -> None:
    g = _graph([_obj("table-1", "table", 2.5, 3.0, (0.8, 0.75, 1.2), z0=-0.44)])
    t = _o(g, "table-1")
    assert t["on"] is None and t["placement"] == "below_floor" and t["floor_gap"] == pytest.approx(-0.44)
    assert t["uncertain"] == ["sunk 0.44 m into the floor: likely a mapping error"]
    assert g["uncertainties"] == ["table-1: sunk 0.44 m into the floor: likely a mapping error"]
    text = summarize(g)
    line = _line(text, "table-1")
    assert "sunk 0.44 m into the floor (a mapping error?)" in line
    assert "float" not in text and not re.search(r"[\s(,]-\d", text)  # no "floating", no negative heights


def test_object_wholly_under_the_floor_is_said_to_be_below_it() -> None:
    g = _graph([_obj("chair-1", "office_chair", 2.5, 3.0, (0.6, 1.0, 0.6), z0=-71.23)])
    c = _o(g, "chair-1")
    assert c["placement"] == "below_floor" and c["floor_gap"] == pytest.approx(-71.23)
    assert c["uncertain"] == ["lies entirely below the floor (its top 70.23 m under it, its bottom 71.23 m): "
                              "likely a mapping error"]
    text = summarize(g)
    assert "entirely below the floor, its bottom 71.23 m under it" in _line(text, "chair-1")
    assert "float" not in text and not re.search(r"[\s(,]-\d", text)


def test_only_a_positive_gap_is_floating() -> None:
    g = _graph([_obj("lamp", "lamp", 1.0, 2.0, (0.3, 0.3, 0.3), z0=1.0),
                _obj("box", "cardboard_box", 4.0, 2.0, (0.4, 0.4, 0.4), z0=0.05),  # within 0.10 m: on the floor
                _obj("mat", "sports_mat", 2.5, 5.0, (1.0, 0.05, 2.0), z0=-0.08)])  # 0.08 m under: on the floor
    lamp = _o(g, "lamp")
    assert lamp["placement"] == "floating" and lamp["floor_gap"] == pytest.approx(1.0)
    assert lamp["uncertain"] == ["seems to float 1.00 m above the floor with nothing under it"]
    assert _o(g, "box")["placement"] == "on_floor" and _o(g, "mat")["placement"] == "on_floor"
    assert _o(g, "mat")["uncertain"] == []
    text = summarize(g)
    assert "floating 1.00 m above the floor" in _line(text, "lamp")
    assert "on the floor" in _line(text, "mat") and "sunk" not in text


def test_stacked_objects_below_the_floor_are_both_flagged() -> None:
    base = _obj("crate-1", "crate", 2.5, 3.0, (0.6, 0.4, 0.6), z0=-1.0)
    top = _obj("box-1", "cardboard_box", 2.5, 3.0, (0.4, 0.8, 0.4), z0=-0.6)  # on the crate, bottom 0.6 m under
    table = _obj("table-1", "table", 1.0, 5.0, (0.8, 0.75, 1.2))
    cup = _obj("cup-1", "cup", 1.0, 5.0, (0.1, 0.1, 0.1), z0=0.75)
    g = _graph([base, top, table, cup])
    assert _o(g, "box-1")["on"] == "crate-1" and _o(g, "box-1")["placement"] == "below_floor"
    assert _o(g, "crate-1")["placement"] == "below_floor"
    assert _o(g, "cup-1")["placement"] == "on_object" and _o(g, "cup-1")["floor_gap"] == pytest.approx(0.75)
    assert "sunk 0.60 m into the floor" in _line(summarize(g), "box-1")


def test_schema_v1_graphs_still_validate_and_summarize() -> None:
    g = _graph([_obj("table-1", "table", 2.5, 3.0, (0.8, 0.75, 1.2), z0=-0.44),
                _obj("lamp", "lamp", 1.0, 2.0, (0.3, 0.3, 0.3), z0=1.0),
                _obj("car", "car", 58.0, 3.0, (1.8, 1.5, 4.5))])
    assert g["version"] == 2 and schema_for(g) is SCENE_GRAPH_SCHEMA
    v1 = {**g, "version": 1, "objects": [
        {k: v for k, v in o.items() if k not in ("placement", "floor_gap")}
        | {"reach": {k: v for k, v in o["reach"].items() if k != "code"}} for o in g["objects"]]}
    assert schema_for(v1) is SCENE_GRAPH_SCHEMA_V1
    jsonschema.validate(v1, SCENE_GRAPH_SCHEMA_V1)
    with pytest.raises(jsonschema.ValidationError):
        jsonschema.validate(v1, SCENE_GRAPH_SCHEMA)  # the new fields are required in version 2
    with pytest.raises(jsonschema.ValidationError):
        jsonschema.validate(g, SCENE_GRAPH_SCHEMA_V1)  # and unknown to version 1
    assert summarize(v1) == summarize(g)  # a version-1 graph is worded the same, placement from bottom
    assert set(REASON_CODES) == set(REASONS)


# --- why an object cannot be reached ----------------------------------------------------------------


def _ring(height: float, inner: float, cx: float = 2.5, cy: float = 4.0, t: float = 0.25):
    a = inner / 2 + t / 2
    span = inner + 2 * t
    return [_obj("wall-s", "office_cabinet", cx, cy - a, (t, height, span)),
            _obj("wall-n", "office_cabinet", cx, cy + a, (t, height, span)),
            _obj("wall-w", "office_cabinet", cx - a, cy, (t, height, span), yaw=ALONG_Y),
            _obj("wall-e", "office_cabinet", cx + a, cy, (t, height, span), yaw=ALONG_Y)]


DOG = _obj("dog", "robot_dog", 2.5, 4.0, (0.28, 0.4, 0.645))


def test_far_objects_are_outside_the_workspace_not_closed_in() -> None:
    cars = [_obj("car-1", "car", 58.0, 3.0, (1.8, 1.5, 4.5)), _obj("car-2", "car", 74.0, -2.0, (1.8, 1.5, 4.5))]
    g = _graph(cars)
    for oid in ("car-1", "car-2"):
        r = _o(g, oid)["reach"]
        assert r["mode"] == "none" and r["code"] == "outside_workspace"
        assert "outside the planning workspace (x 0.00 to 5.00 m, y 0.00 to 8.00 m" in r["reason"]
        assert "closed in" not in r["reason"]
    assert "unreachable: it lies outside the planning workspace" in _line(summarize(g), "car-1")
    with pytest.raises(ObjectGoalError, match="outside the planning workspace"):
        scene = Scene(objects=tuple(cars))
        goal_beside(scene, build_grid(scene), "car-1", ROBOT[:3])
    # a workspace that holds them: walked to
    wide = _graph(cars, ws=Workspace((0.0, -5.0, 0.0), (80.0, 8.0, 3.0), 0.5))
    assert all(o["reach"]["mode"] == "walk" and o["reach"]["code"] is None for o in wide["objects"])


def test_just_beyond_the_wall_is_reachable_from_inside() -> None:
    r = _reach([_obj("crate", "crate", 5.3, 4.0, (0.4, 0.4, 0.4))], "crate")  # centre 0.3 m outside
    assert r.mode == "walk" and r.code == "" and r.goal[0] <= 5.0


def test_partly_outside_and_closed_in_says_both() -> None:
    wall = _obj("wall", "office_cabinet", 4.1, 4.0, (0.2, 3.0, 8.0), yaw=ALONG_Y)  # wall to wall, to the ceiling
    r = _reach([wall, _obj("crate", "crate", 5.3, 4.0, (0.4, 0.4, 0.4))], "crate")
    assert r.mode == "none" and r.code == "closed_in"
    assert "closed in" in r.reason and "its centre (5.30, 4.00) lies outside the planning workspace" in r.reason


def test_closed_in_by_a_ring_to_the_ceiling() -> None:
    r = _reach(_ring(3.0, 2.0) + [DOG], "dog")
    assert r.mode == "none" and r.code == "closed_in" and "closed in by obstacles" in r.reason
    assert "outside" not in r.reason


def test_no_free_floor_beside_a_box_in_the_middle_of_a_big_table() -> None:
    table = _obj("table", "table", 2.5, 4.0, (3.0, 0.75, 3.0))
    box = _obj("box", "cardboard_box", 2.5, 4.0, (0.3, 0.3, 0.3), z0=0.75)
    r = _reach([table, box], "box")
    assert r.mode == "none" and r.code == "no_free_floor" and "no free floor within 1.0 m" in r.reason
    # the same box near the table's edge is reached from the floor beside the table
    edge = _obj("box", "cardboard_box", 2.5, 2.8, (0.3, 0.3, 0.3), z0=0.75)
    assert _reach([table, edge], "box").mode == "walk"


def test_cramped_in_a_narrow_corridor() -> None:
    left = _obj("wall-l", "office_cabinet", 1.8, 4.0, (0.8, 3.0, 4.0), yaw=ALONG_Y)  # 0.6 m gap at x 2.2 .. 2.8
    right = _obj("wall-r", "office_cabinet", 3.2, 4.0, (0.8, 3.0, 4.0), yaw=ALONG_Y)
    r = _reach([left, right, DOG], "dog")
    assert r.mode == "none" and r.code == "cramped" and "0.35 m radius" in r.reason and "too cramped" in r.reason


def test_walled_off_by_a_low_ring_too_tight_to_land_in() -> None:
    g = _graph(_ring(0.6, 1.0) + [DOG])
    r = _o(g, "dog")["reach"]
    assert r["mode"] == "none" and r["code"] == "walled_off" and "another object stands between" in r["reason"]


def test_robot_cut_off_from_the_floor() -> None:
    cabinet = _obj("cab", "office_cabinet", 2.5, 4.0, (2.0, 1.5, 2.0))  # fills the ring up to 1.5 m
    crate = _obj("crate", "crate", 2.5, 1.0, (0.4, 0.4, 0.4))
    r = _reach(_ring(3.0, 2.0) + [cabinet, crate], "crate", start=(2.5, 4.0, 2.5))  # above it, in the ring
    assert r.mode == "none" and r.code == "start_cut_off" and "cut off from the floor" in r.reason


def test_robot_inside_an_obstacle_walks_out_and_outside_the_workspace_is_start_unusable() -> None:
    # the robot's own cells are free by definition (a box mapped over it is a mapping error): it walks out
    g = _graph([DOG, _obj("box", "cardboard_box", 2.5, 2.0, (0.6, 0.6, 0.6))], robot=(2.5, 2.0, 0.0, 0.0))
    assert _o(g, "dog")["reach"]["mode"] == "walk"
    g = _graph([DOG], robot=(2.5, -1.0, 0.0, 0.0))
    r = _o(g, "dog")["reach"]
    assert r["mode"] == "unknown" and r["code"] == "start_unusable" and "outside the workspace" in r["reason"]
