"""World files: the simulator's hidden room from a file (validated, field named), and --world for the console."""

from __future__ import annotations

import json
import math
from pathlib import Path

import pytest

from console.app import ConsoleApp, ConsoleConfig, wait_until
from console.cli.morphonavi import main
from console.link.base import RunStatus
from console.link.sim import SimRobot
from console.link.world import paper_room
from console.link.world_file import WorldError, load_world, world_from_dict
from planner.mission import MissionSegment, SegmentKind

EXAMPLES = Path(__file__).resolve().parents[3] / "examples" / "worlds"


def _world(**changes: object) -> dict:
    data = json.loads((EXAMPLES / "gap_line.world.json").read_text())
    data.update(changes)
    return data


def test_the_shipped_examples_load_and_the_paper_room_is_the_built_in_one() -> None:
    names = {p.name: load_world(p) for p in sorted(EXAMPLES.glob("*.world.json"))}
    assert {"paper_room.world.json", "gap_line.world.json", "office.world.json"} <= set(names)
    paper = names["paper_room.world.json"]
    assert [o.id for o in paper.scene.objects] == [o.id for o in paper_room().objects]
    assert paper.bounds_max == (5.0, 8.0, 3.0) and paper.start.yaw == pytest.approx(math.pi / 2)
    office = names["office.world.json"]
    assert office.workspace(0.25).shape == (24, 28, 10)


@pytest.mark.parametrize("changes, message", [
    ({"morphonavi_world": 2}, r"^morphonavi_world: must be 1"),
    ({"bounds": {"min": [0, 0, 0], "max": [6, 0, 2]}}, r"^bounds\.max: must exceed bounds\.min on every axis \(y"),
    ({"bounds": {"min": [0, 0], "max": [6, 6, 2]}}, r"^bounds\.min: must be 3 finite numbers"),
    ({"room": {"min": [0, 0, 0], "max": [6, 6, "high"]}}, r"^room\.max: must be 3 finite numbers"),
    ({"start": {"position": [3.0, 0.7, 0.0], "yaw_deg": float("inf")}}, r"^start\.yaw_deg: must be a finite number"),
    ({"start": {"position": [3.0, 9.0, 0.0]}}, r"^start\.position: .* is outside the bounds"),
    ({"start": {"position": [3.0, 0.7, 1.0]}}, r"^start\.position: z must be the floor"),
    ({"start": {"position": [3.0, 5.3, 0.0]}}, r"^start\.position: the robot's body .* touches robot_dog 'robot_dog-1'"),
    ({"start": {"position": [5.9, 0.7, 0.0]}}, r"^start\.position: the robot's body \(0\.25 m radius\) at \(5\.9, 0\.7\) "
                                               r"touches the room's wall"),
    ({"scene": 5}, r"^scene: must be a scene JSON object or the path"),
    ({"scene": {"version": 1, "objects": [{"id": "a", "label": "desk", "frame": "world", "position": [1, 1, "x"],
                                          "size": [1, 1, 1]}]}}, r"^scene\.objects\[0\]\.position"),
    ({"colour": "red"}, r"^colour: unknown field"),
])
def test_a_bad_world_names_the_field(changes: dict, message: str) -> None:
    with pytest.raises(WorldError, match=message):
        world_from_dict(_world(**changes), EXAMPLES)


def test_file_errors_name_the_file(tmp_path: Path) -> None:
    bad = tmp_path / "bad.world.json"
    bad.write_text("{ nope")
    with pytest.raises(WorldError, match=r"bad\.world\.json: not valid JSON \(line 1"):
        load_world(bad)
    with pytest.raises(WorldError, match="no such world file"):
        load_world(tmp_path / "missing.json")
    ref = tmp_path / "ref.world.json"
    ref.write_text(json.dumps(_world(scene="missing.scene.json")))
    with pytest.raises(WorldError, match=r"ref\.world\.json: scene: .*missing\.scene\.json"):
        load_world(ref)


def test_the_simulator_runs_in_a_world_from_a_file() -> None:
    world = load_world(EXAMPLES / "gap_line.world.json")
    robot = SimRobot(manual_clock=True, **world.link_options(0.25))
    robot.connect()
    st = robot.latest_state()
    assert st.position == pytest.approx((3.0, 0.7, 0.0)) and st.yaw == pytest.approx(math.pi / 2)
    assert {v.label for v in robot.capture().ground_truth.visible} >= {"cardboard_box"}  # renders this world
    # its bounds are the safety net: x = 5.5 is inside this 6 m room (outside the paper's 5 m one)
    run = robot.run_segment(MissionSegment(SegmentKind.WALK, ((3.0, 0.7, 0.0), (5.5, 0.7, 0.0))))
    t0 = robot.sim_time
    while not run.done and robot.sim_time - t0 < 30:
        robot.step(0.02)
    assert run.status is RunStatus.DONE, run.error
    out = robot.run_segment(MissionSegment(SegmentKind.WALK, ((5.5, 0.7, 0.0), (6.5, 0.7, 0.0))))
    assert out.status is RunStatus.FAILED and "outside the workspace" in out.error


def test_console_world_option(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    bad = tmp_path / "w.json"
    bad.write_text(json.dumps(_world(start={"position": [3.0, 0.7, 0.0], "yaw_deg": "north"})))
    assert main(["console", "--world", str(bad), "--session", str(tmp_path / "s")]) == 2
    assert "--world " in (err := capsys.readouterr().err) and "start.yaw_deg: must be a finite number" in err
    assert main(["console", "--world", str(bad), "--robot", "mavlink:udpin:127.0.0.1:0",
                 "--session", str(tmp_path / "s")]) == 2
    assert "--world is the simulator's room" in capsys.readouterr().err
    app = ConsoleApp(ConsoleConfig(session_dir=tmp_path / "s2", port=0, fresh=True, record=False,
                                   world=load_world(EXAMPLES / "office.world.json"))).start()
    try:
        assert app.session.workspace.max == (6.0, 7.0, 2.5)
        assert wait_until(lambda: app.session.robot is not None, 30)
        assert tuple(app.session.robot.pose.translation[:2]) == pytest.approx((3.0, 0.5), abs=1e-6)
        assert "hidden" in app.link.description and "office_cabinet" not in app.link.description
    finally:
        app.stop()
