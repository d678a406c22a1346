"""``morphonavi describe`` and ``morphonavi plan --goal-object``: output, schema and user mistakes."""

from __future__ import annotations

import json
import math
from pathlib import Path

import jsonschema
import pytest

from console.cli.morphonavi import main
from console.link.world import paper_room
from pipeline.scene import Capture, Scene, SceneObject, save_scene
from planner.mission import Mission
from planner.scene_graph_schema import SCENE_GRAPH_SCHEMA

ROBOT = "2.5,0.7,0,90"


@pytest.fixture(scope="module")
def room(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return save_scene(paper_room(), tmp_path_factory.mktemp("scene") / "room.json")


def _run(capsys: pytest.CaptureFixture[str], *argv: str) -> tuple[int, str, str]:
    code = main(list(argv))
    out, err = capsys.readouterr()
    return code, out, err


def test_describe_prints_the_summary_of_the_paper_room(room: Path, capsys: pytest.CaptureFixture[str]) -> None:
    code, out, err = _run(capsys, "describe", str(room), "--robot", ROBOT)
    assert code == 0, err
    dog = next(line for line in out.splitlines() if line.startswith("- robot dog (robot_dog-1)"))
    assert "5.6 m ahead" in dog and "behind the line of 33 cardboard boxes" in dog
    assert "reachable only by flying" in dog
    assert out.index("compressor-1") < out.index("robot_dog-1") < out.index("Groups:")  # nearest first, then groups


def test_describe_json_follows_the_schema(room: Path, capsys: pytest.CaptureFixture[str]) -> None:
    code, out, _ = _run(capsys, "describe", str(room), "--robot", ROBOT, "--json")
    assert code == 0
    graph = json.loads(out)
    jsonschema.validate(graph, SCENE_GRAPH_SCHEMA)
    assert graph["robot"] == {"position": [2.5, 0.7, 0.0], "yaw_deg": 90.0}
    assert len(graph["objects"]) == 43
    code, out, _ = _run(capsys, "describe", "--schema")
    assert code == 0 and json.loads(out) == SCENE_GRAPH_SCHEMA


def test_describe_takes_the_robot_pose_from_the_latest_capture(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    scene = Scene(
        objects=(SceneObject("chair-1", "office_chair", (2.5, 3.0, 0.5), (0.6, 1.0, 0.6)),),
        captures=(Capture("old", 1.0, robot_pose={"x": 2.5, "y": 6.0, "z": 0.0, "yaw": 0.0}),
                  Capture("new", 2.0, robot_pose={"x": 2.5, "y": 1.0, "z": 0.0, "yaw": math.pi / 2})),
    )
    path = save_scene(scene, tmp_path / "s.json")
    code, out, _ = _run(capsys, "describe", str(path))
    assert code == 0
    assert "2.0 m ahead" in out and "robot pose from the scene's latest capture" in out
    code, out, _ = _run(capsys, "describe", str(path), "--robot", "2.5,5,0,-90")  # an explicit pose wins
    assert "2.0 m ahead" in out and "latest capture" not in out


@pytest.mark.parametrize("argv, field", [
    (["describe", "{missing}"], "scene file not found"),
    (["describe", "{bad}"], "not valid JSON"),
    (["describe", "{badfield}"], "objects[0].size[1]"),
    (["describe", "{room}", "--robot", "2.5,0.7,0,nan"], "--pose.yaw_deg: must be finite"),
    (["describe", "{room}", "--robot", "2.5,inf"], "--pose.y: must be finite"),
    (["describe", "{room}", "--robot", "2.5,abc,0"], "--pose.y: must be a number"),
    (["describe", "{room}", "--robot", "1"], "--pose: expected 'x,y[,z[,yaw_deg]]'"),
    (["describe", "{room}", "--robot", "1,2,3,4,5"], "--pose: expected"),
    (["describe"], "give a scene JSON file"),
])
def test_describe_bad_input_names_the_field_and_exits_2(argv: list[str], field: str, room: Path, tmp_path: Path,
                                                        capsys: pytest.CaptureFixture[str]) -> None:
    (tmp_path / "bad.json").write_text("{not json")
    data = json.loads(room.read_text())
    data["objects"][0]["size"][1] = -1.0
    (tmp_path / "badfield.json").write_text(json.dumps(data))
    paths = {"missing": tmp_path / "nope.json", "bad": tmp_path / "bad.json", "badfield": tmp_path / "badfield.json",
             "room": room}
    code, out, err = _run(capsys, *[a.format(**paths) for a in argv])
    assert code == 2 and out == ""
    assert field in err and err.startswith("morphonavi describe: error:") and "Traceback" not in err


def test_plan_goal_object_flies_over_the_line_to_the_robot_dog(room: Path, tmp_path: Path,
                                                               capsys: pytest.CaptureFixture[str]) -> None:
    out_file = tmp_path / "mission.json"
    code, out, err = _run(capsys, "plan", str(room), "--start", "2.5,0.7,0", "--goal-object", "robot dog",
                          "--out", str(out_file))
    assert code == 0, err
    assert "robot_dog-1" in out and "only by flying" in out
    mission = Mission.load(out_file)
    assert mission.kinds() == ["walk", "takeoff", "fly", "land", "walk"]
    fly = mission.segments[2]
    assert min(w[1] for w in fly.waypoints) < 4.0 < max(w[1] for w in fly.waypoints)
    assert mission.segments[3].spot[1] > 4.2  # lands behind the line
    dog = paper_room().object("robot_dog-1")
    end = mission.segments[-1].end
    # beside the dog: the landing spot keeps the robot's radius and the danger band (0.35 + 0.25 m) from it, within
    # half a cell (was 0.5 m while the radius was only a cost and landing 0.35 m away was allowed)
    assert abs(end[0] - dog.position[0]) < 0.14 + 0.725 and abs(end[1] - dog.position[1]) < 0.33 + 0.725


def test_plan_mixes_goals_and_goal_objects_in_order(room: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out_file = tmp_path / "m.json"
    code, out, err = _run(capsys, "plan", str(room), "--start", "2.5,0.7,0", "--goal", "2.5,2.0,0",
                          "--goal-object", "compressor-1", "--out", str(out_file))
    assert code == 0, err
    assert out.index("goal (2.50, 2.00, 0.00)") < out.index("goal object 'compressor-1'")
    mission = Mission.load(out_file)
    assert mission.kinds() == ["walk"]
    end = mission.segments[-1].end
    comp = paper_room().object("compressor-1")
    assert math.dist(end[:2], comp.position[:2]) < 0.8


@pytest.mark.parametrize("argv, message", [
    (["--goal-object", "sofa"], "--goal-object 'sofa': no object with id or label 'sofa'"),
    ([], "give at least one stop"),
])
def test_plan_goal_object_errors(argv: list[str], message: str, room: Path, tmp_path: Path,
                                 capsys: pytest.CaptureFixture[str]) -> None:
    code, _, err = _run(capsys, "plan", str(room), "--start", "2.5,0.7,0", "--out", str(tmp_path / "m.json"), *argv)
    assert code == 2 and message in err and "Traceback" not in err
    assert not (tmp_path / "m.json").exists()


def test_describe_piped_into_a_reader_that_leaves_early_prints_no_traceback(room: Path) -> None:
    """``morphonavi describe --json | head -1``: the reader closing the pipe is not an error."""
    import subprocess
    import sys

    code = ("import sys; from console.cli.morphonavi import main; sys.exit(main(['describe', sys.argv[1], '--json', "
            "'--robot', '2.5,0.7,0,90']))")
    proc = subprocess.Popen([sys.executable, "-c", code, str(room)], stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    assert proc.stdout is not None and proc.stderr is not None
    first = proc.stdout.read(1)  # read one byte, then leave as `head -c 1` does
    proc.stdout.close()
    err = proc.stderr.read().decode()
    assert proc.wait(timeout=120) == 0, err
    assert first == b"{" and "Traceback" not in err and "BrokenPipeError" not in err, err


def test_describe_far_objects_points_to_bounds_and_sunk_ones_are_below_the_floor(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """A street scene (cars 57 and 73 m off) in the default 5 x 8 x 3 m workspace, a table 0.44 m sunk."""
    scene = Scene(objects=(
        SceneObject("car-1", "car", (58.0, 3.0, 0.75), (1.8, 1.5, 4.5)),
        SceneObject("car-2", "car", (74.0, -2.0, 0.75), (1.8, 1.5, 4.5)),
        SceneObject("table-1", "table", (2.5, 3.0, 0.375 - 0.44), (0.8, 0.75, 1.2)),
    ))
    path = save_scene(scene, tmp_path / "street.json")
    code, out, err = _run(capsys, "describe", str(path), "--robot", "1,1,0,0")
    assert code == 0, err
    for car in ("car-1", "car-2"):
        line = next(t for t in out.splitlines() if f"({car})" in t and t.startswith("- "))
        assert "unreachable: it lies outside the planning workspace" in line and "closed in" not in line
    table = next(t for t in out.splitlines() if t.startswith("- table (table-1)"))
    assert "sunk 0.44 m into the floor" in table and "float" not in out
    hint = out.splitlines()[-1]
    assert "2 objects (car-1, car-2) lie outside the planning workspace" in hint and "--bounds" in hint
    bounds = hint.split("--bounds=")[1].rstrip(")")
    code, out, err = _run(capsys, "describe", str(path), "--robot", "1,1,0,0", f"--bounds={bounds}", "--json")
    assert code == 0, err
    graph = json.loads(out)
    jsonschema.validate(graph, SCENE_GRAPH_SCHEMA)
    cars = [o for o in graph["objects"] if o["label"] == "car"]
    assert [o["reach"]["mode"] for o in cars] == ["walk", "walk"]  # the suggested bounds hold them
    table = next(o for o in graph["objects"] if o["id"] == "table-1")
    assert table["placement"] == "below_floor" and table["floor_gap"] == pytest.approx(-0.44)


def test_describe_robot_outside_the_workspace_points_to_bounds(tmp_path: Path,
                                                              capsys: pytest.CaptureFixture[str]) -> None:
    scene = Scene(objects=(SceneObject("chair-1", "office_chair", (2.5, 3.0, 0.5), (0.6, 1.0, 0.6)),))
    path = save_scene(scene, tmp_path / "s.json")
    code, out, err = _run(capsys, "describe", str(path), "--robot", "-3,1,0,0")
    assert code == 0, err
    assert "reachability unknown: robot (-3.00, 1.00, 0.00) is outside the workspace" in out
    hint = out.splitlines()[-1]
    assert hint.startswith("(the robot lies outside the planning workspace") and "--bounds=" in hint
    bounds = hint.split("--bounds=")[1].rstrip(")")
    code, out, err = _run(capsys, "describe", str(path), "--robot", "-3,1,0,0", f"--bounds={bounds}")
    assert code == 0, err
    assert "reachable by walking" in out and "outside the planning workspace" not in out
    code, out, _ = _run(capsys, "describe", str(path), "--robot", "2.5,1,0,90")  # inside: no note
    assert "--bounds" not in out and "outside" not in out


def test_plan_goal_object_outside_the_workspace_names_bounds(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    scene = Scene(objects=(SceneObject("car-1", "car", (58.0, 3.0, 0.75), (1.8, 1.5, 4.5)),))
    path = save_scene(scene, tmp_path / "street.json")
    code, _, err = _run(capsys, "plan", str(path), "--start", "1,1,0", "--goal-object", "car",
                        "--out", str(tmp_path / "m.json"))
    assert code == 2 and "outside the planning workspace" in err and "widen the workspace with --bounds" in err, err
    assert not (tmp_path / "m.json").exists()
