"""Scene graph, summary and goals by object on hand-made scenes with known answers."""

from __future__ import annotations

import math
import random

import jsonschema
import numpy as np
import pytest

from pipeline.scene import Scene, SceneObject
from planner.grid import DANGER_BAND, CellState, Workspace, build_grid
from planner.object_goal import APPROACH_MAX, ObjectGoalError, Reachability, find_object, footprint_distance, goal_beside
from planner.route import Route
from planner.scene_graph import SceneGraphError, build_scene_graph, check_robot, direction
from planner.scene_graph_schema import SCENE_GRAPH_SCHEMA
from planner.scene_summary import MAX_CHARS, summarize

FACING_Y = (2.5, 0.5, 0.0, math.pi / 2)  # robot near the y = 0 wall, looking along +y (its left is -x)


def _obj(oid: str, label: str, x: float, y: float, size: tuple[float, float, float], z0: float = 0.0,
         yaw: float = 0.0, **kw) -> SceneObject:
    return SceneObject(oid, label, (x, y, z0 + size[1] / 2), size, yaw, **kw)


def _graph(objs, robot=FACING_Y, ws=Workspace(), margin=0.35):
    scene = Scene(objects=tuple(objs))
    grid = build_grid(scene, ws, margin)
    g = build_scene_graph(scene, robot, grid)
    jsonschema.validate(g, SCENE_GRAPH_SCHEMA)
    return g


def _rels(g) -> set[tuple[str, str, str]]:
    return {(r["subject"], r["relation"], r["object"]) for r in g["relations"]}


def _o(g, oid):
    return next(o for o in g["objects"] if o["id"] == oid)


# --- a box on a table ----------------------------------------------------------------------------


def test_box_on_a_table() -> None:
    table = _obj("table-1", "table", 2.5, 2.5, (0.8, 0.75, 1.2))
    box = _obj("box-1", "cardboard_box", 2.6, 2.4, (0.4, 0.4, 0.4), z0=0.75)
    g = _graph([table, box])
    assert _o(g, "box-1")["on"] == "table-1"
    assert _o(g, "table-1")["on"] == "floor"
    rels = _rels(g)
    assert ("box-1", "on_top_of", "table-1") in rels and ("table-1", "under", "box-1") in rels
    assert not any(k == "next_to" for _, k, _ in rels)  # standing on it is not "next to"
    # the box is reached by walking up to the table, beside its footprint
    reach = _o(g, "box-1")["reach"]
    assert reach["mode"] == "walk" and reach["planned"] == "walk"
    assert footprint_distance(table, np.array([reach["goal"][:2]]))[0] <= APPROACH_MAX
    text = summarize(g)
    assert "cardboard box (box-1)" in text and "on top of table (table-1)" in text


def test_object_in_the_air_is_flagged_as_floating() -> None:
    g = _graph([_obj("lamp", "lamp", 1.0, 2.0, (0.3, 0.3, 0.3), z0=1.0)])
    assert _o(g, "lamp")["on"] is None and _o(g, "lamp")["placement"] == "floating"
    assert any("float" in u for u in g["uncertainties"])
    assert "floating 1.00 m above the floor" in summarize(g)


# --- a dog behind a line of boxes ------------------------------------------------------------------


def _line_and_dog():
    boxes = [_obj(f"box-{n}", "cardboard_box", 1.7 + 0.4 * n, 3.0, (0.4, 0.6, 0.4)) for n in range(5)]
    dog = _obj("dog", "robot_dog", 2.5, 4.5, (0.28, 0.4, 0.645), yaw=math.pi / 2)
    return boxes + [dog]


def test_dog_behind_a_line_of_boxes_as_seen_from_the_robot() -> None:
    g = _graph(_line_and_dog())
    [grp] = g["groups"]
    assert grp["kind"] == "line" and grp["members"] == [f"box-{n}" for n in range(5)]
    assert grp["length"] == pytest.approx(2.0, abs=0.01) and not grp["crosses_workspace"]
    rels = _rels(g)
    assert ("dog", "behind", grp["id"]) in rels and (grp["id"], "in_front_of", "dog") in rels
    assert not any(s.startswith("box-") or o.startswith("box-") for s, _, o in rels)  # stated against the group
    dog = _o(g, "dog")
    assert dog["visibility"] == "hidden" and dog["from_robot"]["direction"] == "ahead"
    assert dog["from_robot"]["distance"] == pytest.approx(4.0, abs=0.01)
    assert dog["reach"]["mode"] == "walk"  # the line is short: walk around it
    assert "hidden behind the line of 5 cardboard boxes (group-box-0)" in summarize(g)


def test_seen_from_the_other_side_the_dog_is_in_front_of_the_line() -> None:
    g = _graph(_line_and_dog(), robot=(2.5, 7.0, 0.0, -math.pi / 2))
    rels = _rels(g)
    assert ("dog", "in_front_of", "group-box-0") in rels and ("dog", "behind", "group-box-0") not in rels
    assert _o(g, "dog")["visibility"] == "visible"


# --- an object inside a closed ring -----------------------------------------------------------------


def _ring(height: float, inner: float, cx: float = 2.5, cy: float = 4.0, t: float = 0.25):
    """Four walls of thickness ``t`` around an ``inner`` x ``inner`` m square [m]."""
    a = inner / 2 + t / 2
    span = inner + 2 * t
    return [
        _obj("wall-s", "office_cabinet", cx, cy - a, (t, height, span)),
        _obj("wall-n", "office_cabinet", cx, cy + a, (t, height, span)),
        _obj("wall-w", "office_cabinet", cx - a, cy, (t, height, span), yaw=math.pi / 2),
        _obj("wall-e", "office_cabinet", cx + a, cy, (t, height, span), yaw=math.pi / 2),
    ]


def test_object_inside_a_closed_ring_to_the_ceiling_is_unreachable() -> None:
    objs = _ring(3.0, 2.0) + [_obj("dog", "robot_dog", 2.5, 4.0, (0.28, 0.4, 0.645))]
    g = _graph(objs)
    reach = _o(g, "dog")["reach"]
    assert reach["mode"] == "none" and reach["goal"] is None and "closed in" in reach["reason"]
    assert reach["code"] == "closed_in"
    assert "unreachable" in summarize(g)
    with pytest.raises(ObjectGoalError, match="cannot be reached"):
        goal_beside(Scene(objects=tuple(objs)), build_grid(Scene(objects=tuple(objs))), "dog", FACING_Y[:3])


def test_low_ring_too_tight_to_land_in_is_unreachable_but_a_wide_one_is_reached_by_flying() -> None:
    dog = _obj("dog", "robot_dog", 2.5, 4.0, (0.28, 0.4, 0.645))
    tight = _graph(_ring(0.6, 1.0) + [dog])
    assert _o(tight, "dog")["reach"]["mode"] == "none"
    # landing keeps the radius and the danger band (0.35 + 0.25 m) from the walls and the dog: a 2.5 m ring
    # was wide enough while the radius was only a cost; 3 m is now
    wide = _graph(_ring(0.6, 3.0) + [dog])
    reach = _o(wide, "dog")["reach"]
    assert reach["mode"] == "fly" and reach["planned"] == "walk+fly"
    land = reach["landing"]
    assert 2.5 - 1.5 < land[0] < 2.5 + 1.5 and 4.0 - 1.5 < land[1] < 4.0 + 1.5  # inside the ring


# --- two chairs next to a desk ----------------------------------------------------------------------


def test_two_chairs_next_to_a_desk() -> None:
    desk = _obj("desk", "desk", 2.5, 3.0, (0.7, 0.75, 1.4))  # length along x
    left = _obj("chair-a", "office_chair", 2.1, 2.2, (0.5, 1.0, 0.5))
    right = _obj("chair-b", "office_chair", 2.9, 2.2, (0.5, 1.0, 0.5))
    g = _graph([desk, right, left])
    rels = _rels(g)
    for chair in ("chair-a", "chair-b"):
        assert ("chair-a" if chair == "chair-a" else "chair-b", "next_to", "desk") in rels \
            or ("desk", "next_to", chair) in rels
        assert (chair, "in_front_of", "desk") in rels
        assert _o(g, chair)["from_robot"]["direction"] == "ahead"
    assert ("chair-a", "left_of", "chair-b") in rels and ("chair-b", "right_of", "chair-a") in rels
    assert g["groups"] == []  # two are not a group
    text = summarize(g)
    assert text.count("next to desk (desk)") == 2


# --- the paper's room --------------------------------------------------------------------------------


def test_paper_room_summary_and_go_to_robot_dog() -> None:
    from console.link.world import DEFAULT_START, SEARCH_GOAL, paper_room

    scene = paper_room()
    grid = build_grid(scene, Workspace(), 0.35)
    x, y, z = DEFAULT_START.translation
    g = build_scene_graph(scene, (x, y, z, math.pi / 2), grid)
    jsonschema.validate(g, SCENE_GRAPH_SCHEMA)
    [line] = g["groups"]
    assert line["kind"] == "line" and len(line["members"]) == 33 and line["crosses_workspace"]
    dog = _o(g, "robot_dog-1")
    assert dog["reach"]["mode"] == "fly" and dog["visibility"] == "hidden"
    text = summarize(g)
    dog_line = next(t for t in text.splitlines() if "(robot_dog-1)" in t and t.startswith("- robot dog"))
    assert "behind the line of 33 cardboard boxes" in dog_line and "reachable only by flying" in dog_line
    assert "crosses the workspace wall to wall" in text
    # "go to robot dog": take off, fly over the line, land behind it and stop beside the dog
    route = Route(grid, (x, y, 0.0))
    obj, app = goal_beside(scene, grid, "robot dog", route.start, route)
    assert obj.id == "robot_dog-1" and app.mode == "fly"
    res = route.propose(app.goal)
    assert res.ok, res.message
    route.register()
    mission = route.mission()
    assert mission.kinds() == ["walk", "takeoff", "fly", "land", "walk"]
    fly, land = mission.segments[2], mission.segments[3]
    assert min(w[1] for w in fly.waypoints) < 4.0 < max(w[1] for w in fly.waypoints)
    assert max(w[2] for w in fly.waypoints) > 1.2  # above the boxes
    assert land.spot[1] > 4.0 + 0.2  # lands behind the line, on the dog's side
    assert grid.state_at(grid.workspace.cell_of(land.spot)) is CellState.FREE
    end = mission.segments[-1].end
    # beside the dog: the landing spot keeps the radius and the danger band, within half a cell
    assert footprint_distance(obj, np.array([end[:2]]))[0] <= grid.margin + DANGER_BAND + 0.125
    assert math.dist(end[:2], SEARCH_GOAL[:2]) < 1.5


# --- bounds, schema, inputs ------------------------------------------------------------------------


def test_summary_is_bounded_for_many_objects() -> None:
    rng = random.Random(7)
    labels = ["office_chair", "desk", "suitcase", "cardboard_box", "plant", "bin"]
    objs = []
    for n in range(45):
        lab = labels[n % len(labels)]
        objs.append(_obj(f"{lab}-{n}", lab, rng.uniform(0.3, 4.7), rng.uniform(1.5, 7.7), (0.3, 0.5, 0.3),
                         score=rng.uniform(0.2, 1.0)))
    g = _graph(objs)
    assert len(g["objects"]) == 45
    text = summarize(g)
    assert len(text) <= MAX_CHARS and len(text.splitlines()) <= 30
    single = sorted((o for o in g["objects"] if o["group"] is None), key=lambda o: o["from_robot"]["distance"])
    assert f"({single[0]['id']})" in text  # the nearest is always named
    assert "more" in text  # the rest are counted, not listed


def test_schema_rejects_a_malformed_graph() -> None:
    g = _graph(_line_and_dog())
    bad = {**g, "objects": [{**g["objects"][0], "reach": {"mode": "teleport"}}]}
    with pytest.raises(jsonschema.ValidationError):
        jsonschema.validate(bad, SCENE_GRAPH_SCHEMA)
    with pytest.raises(jsonschema.ValidationError):
        jsonschema.validate({**g, "version": 3}, SCENE_GRAPH_SCHEMA)
    with pytest.raises(jsonschema.ValidationError):
        jsonschema.validate({**g, "version": 1}, SCENE_GRAPH_SCHEMA)  # a version-1 graph has no placement


def test_graph_without_robot_or_grid_is_valid_and_says_what_is_missing() -> None:
    scene = Scene(objects=tuple(_line_and_dog()))
    g = build_scene_graph(scene)
    jsonschema.validate(g, SCENE_GRAPH_SCHEMA)
    assert g["robot"] is None and all(o["reach"] is None and o["from_robot"] is None for o in g["objects"])
    assert not any(r["relation"] in ("behind", "in_front_of") for r in g["relations"])
    assert "Robot pose unknown" in summarize(g)
    assert summarize(build_scene_graph(Scene())).endswith("nothing has been mapped yet.")


def test_graph_does_not_depend_on_object_order() -> None:
    objs = _line_and_dog()
    a = _graph(objs)
    b = _graph(list(reversed(objs)))
    assert a == b


def test_robot_pose_is_validated_naming_the_field() -> None:
    with pytest.raises(SceneGraphError, match=r"robot.yaw: must be finite"):
        check_robot((1.0, 2.0, 0.0, float("nan")))
    with pytest.raises(SceneGraphError, match=r"robot.x: must be a number"):
        check_robot(("a", 2.0, 0.0, 0.0))
    with pytest.raises(SceneGraphError, match="expected x, y, z, yaw"):
        check_robot((1.0, 2.0))


def test_direction_sectors() -> None:
    assert direction(0.0) == "ahead" and direction(math.radians(90)) == "left"
    assert direction(math.radians(-90)) == "right" and direction(math.radians(180)) == "behind"
    assert direction(math.radians(40)) == "ahead-left" and direction(math.radians(-130)) == "behind-right"


def test_find_object_by_id_label_and_plural() -> None:
    scene = Scene(objects=(
        _obj("chair-1", "office_chair", 1.0, 2.0, (0.5, 1.0, 0.5)),
        _obj("chair-2", "office_chair", 4.0, 6.0, (0.5, 1.0, 0.5)),
        _obj("dog", "robot_dog", 2.5, 6.0, (0.28, 0.4, 0.645)),
    ))
    assert find_object(scene, "chair-2").id == "chair-2"
    assert find_object(scene, "DOG").id == "dog"
    assert find_object(scene, "Robot Dog").id == "dog"
    assert find_object(scene, "office-chairs", near=(4.0, 5.0)).id == "chair-2"  # nearest of two
    assert find_object(scene, "office chair", near=(0.0, 0.0)).id == "chair-1"
    with pytest.raises(ObjectGoalError, match="no object with id or label 'sofa'.*office_chair, robot_dog"):
        find_object(scene, "sofa")
    with pytest.raises(ObjectGoalError, match="empty"):
        find_object(scene, "  ")


def test_robot_inside_an_obstacle_gives_unknown_reachability() -> None:
    objs = _line_and_dog()
    grid = build_grid(Scene(objects=tuple(objs)))
    # the robot's own cells are free by definition: a box mapped where it stands no longer strands it
    r = Reachability(grid, (2.5, 3.0, 0.0))  # inside box-2
    assert r.approach(objs[-1]).mode in ("walk", "fly")
    assert "box-2" in r.route.start_warning and "its own cells are taken as free" in r.route.start_warning
    # a start outside the workspace still cannot be planned from
    assert Reachability(grid, (2.5, 9.0, 0.0)).approach(objs[-1]).mode == "unknown"
    g = build_scene_graph(Scene(objects=tuple(objs)), (2.5, 9.0, 0.0, 0.0), grid)
    assert any("reachability unknown" in u for u in g["uncertainties"])


def test_map_uncertainties_are_stated() -> None:
    from dataclasses import replace

    from pipeline.scene import Sighting, Source

    def seen(sig: float) -> Sighting:
        return Sighting("c1", (1.0, 2.0, 0.5), 0.0, (0.6, 1.0, 0.6), (sig, sig / 2, 0.1))

    base = _obj("chair", "office_chair", 1.0, 2.0, (0.6, 1.0, 0.6), score=0.3, size_known=False,
                source=Source("c1", "depth"))
    vague = replace(base, history=(seen(0.6), seen(0.6)), flags=("set on the floor: was 0.30 m up",))
    sure = replace(base, id="chair-2", position=(3.5, 2.0, 0.5), history=(seen(0.1),))
    g = _graph([vague, sure])
    u = _o(g, "chair")["uncertain"]
    assert "low detector score 0.30" in u and "size estimated, not from the catalog" in u
    assert "position from the depth map only" in u
    assert "position uncertain by about 0.42 m (1 sigma)" in u  # two sightings of 0.6 m: 0.6 / sqrt(2)
    assert "map fusion: set on the floor: was 0.30 m up" in u
    assert not any("position uncertain" in t for t in _o(g, "chair-2")["uncertain"])
    pinned = _graph([replace(vague, pinned=True)])
    assert not any("position uncertain" in t for t in _o(pinned, "chair")["uncertain"])
    assert "Uncertain:" in summarize(g) and "chair: low detector score 0.30" in summarize(g)


def test_polygon_gap_between_footprints() -> None:
    from planner.object_goal import footprint
    from planner.view_geometry import polygon_gap

    a = footprint(_obj("a", "x", 0.0, 0.0, (1.0, 1.0, 1.0)))  # unit square at the origin
    assert polygon_gap(a, footprint(_obj("b", "x", 2.0, 0.0, (1.0, 1.0, 1.0)))) == pytest.approx(1.0)
    assert polygon_gap(a, footprint(_obj("c", "x", 2.0, 2.0, (1.0, 1.0, 1.0)))) == pytest.approx(math.sqrt(2))
    assert polygon_gap(a, footprint(_obj("d", "x", 1.0, 0.0, (1.0, 1.0, 1.0)))) == 0.0  # touching
    plus = footprint(_obj("e", "x", 0.0, 0.0, (0.2, 1.0, 3.0)))  # a long thin bar across: no corner inside
    thin = footprint(_obj("f", "x", 0.0, 0.0, (3.0, 1.0, 0.2)))
    assert polygon_gap(plus, thin) == 0.0
    turned = footprint(_obj("g", "x", 2.0, 0.0, (1.0, 1.0, 1.0), yaw=math.pi / 4))  # a corner points at a
    assert polygon_gap(a, turned) == pytest.approx(1.5 - math.sqrt(0.5))


def test_a_robot_in_the_air_counts_from_the_floor_under_it() -> None:
    objs = _line_and_dog()
    grid = build_grid(Scene(objects=tuple(objs)))
    dog = objs[-1]
    assert Reachability(grid, (2.5, 1.0, 1.5), objects=objs).approach(dog).mode == "walk"  # above open floor
    wall = [_obj(f"w{n}", "cardboard_box", 0.25 + 0.5 * n, 3.0, (0.5, 1.2, 0.5)) for n in range(10)]  # wall to wall
    g2 = build_grid(Scene(objects=tuple(wall + [dog])))
    app = Reachability(g2, (2.5, 1.0, 1.5), objects=wall + [dog]).approach(dog)
    assert app.mode == "fly" and app.planned == "walk+fly"
