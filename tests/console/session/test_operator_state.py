"""The operator stays in control (issue 8, without a browser): the route starts at the robot, one run
state for every tab, vehicle commands, goals in the robot's margin, missions that end in the air.

Live tests run the real stack: a session fed by the simulated robot's state stream (as the console
does), the mission manager and the vehicle commands. They wait on state, never on time.
"""

from __future__ import annotations

import math
import time
from pathlib import Path
from typing import Any, Callable

import numpy as np
import pytest

from console.session import operator_state as rules
from console.link.base import LinkError
from console.link.sim import SimConfig, SimRobot
from console.views.mission_view import make_runner
from console.session.session import RobotSnapshot, RunStatus, Session, SessionError
from console.session.vehicle_commands import VehicleCommands
from pipeline.camera.geometry import Pose
from pipeline.scene import Scene, SceneObject
from planner.grid import Workspace, build_grid
from planner.mission import SegmentKind

START = (2.5, 0.7, 0.0)
FAST = dict(walk_speed=0.8, fly_speed=1.2, climb_rate=1.0, descent_rate=1.0, spool_time=0.3, settle_time=0.2)


def wait_for(predicate: Callable[[], Any], timeout: float = 60.0, what: str = "") -> None:
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        if predicate():
            return
        time.sleep(0.02)
    assert predicate(), f"timed out waiting for {what or predicate}"


def _boxes(y: float = 4.0) -> Scene:
    """The paper's line of 1.2 m boxes across the room at ``y``."""
    return Scene(objects=tuple(SceneObject(f"box-{n}", "cardboard_box", (0.25 + 0.5 * n, y, 0.6), (0.5, 1.2, 0.5))
                               for n in range(10)))


def _hover(x: float, y: float, z: float, mode: str = "holding") -> RobotSnapshot:
    return RobotSnapshot(Pose.from_xyz_yaw(x, y, z), mode=mode, armed=True, landed=False)


def _ground(x: float, y: float, armed: bool = False) -> RobotSnapshot:
    return RobotSnapshot(Pose.from_xyz_yaw(x, y, 0.0), mode="idle", armed=armed, landed=True)


class Stack:
    """Session + simulated robot + mission manager + vehicle commands, wired like the console."""

    def __init__(self, folder: Path, world: Scene) -> None:
        self.robot = SimRobot(world=world, config=SimConfig(time_scale=6.0, **FAST), room=None)
        self.session = Session(folder, start=START, autosave=False)
        self.session.spawn(world)  # the operator's map matches the hidden world
        self.unsubscribe = self.robot.subscribe(self._on_state)
        self.robot.connect()
        self.runner = make_runner(self.robot, self.session, failsafe_after=3.0, failsafe_hold=5.0)
        self.commands = VehicleCommands(self.session, self.robot, self.runner)
        self.runs: list[RunStatus] = []
        self.session.subscribe(lambda t, p: self.runs.append(p) if t == "run" else None)

    def _on_state(self, st: Any) -> None:
        self.session.set_robot(RobotSnapshot(st.pose, mode=st.mode.value, armed=st.armed, healthy=st.link_ok,
                                             landed=st.landed))

    def plan(self, *goals: tuple[float, float, float]) -> None:
        for g in goals:
            res = self.session.add_goal(g)
            assert res.ok, res.message
            self.session.register()

    @property
    def pos(self) -> tuple[float, float, float]:
        return self.robot.latest_state().position

    def close(self) -> None:
        self.runner.close()
        self.unsubscribe()
        self.robot.close()


@pytest.fixture()
def stack(tmp_path: Path):
    s = Stack(tmp_path / "s", _boxes())
    yield s
    s.close()


def _near(a: Any, b: Any, tol: float = rules.START_TOLERANCE) -> bool:
    return math.dist(tuple(a)[:3], tuple(b)[:3]) <= tol


# --- item 5: goals inside the robot's margin; a mission that ends in the air ------------------------------
def test_a_goal_inside_the_robots_margin_is_refused_with_the_reason(tmp_path: Path) -> None:
    s = Session(tmp_path / "s", start=START, margin=0.35, autosave=False)
    s.spawn(Scene(objects=(SceneObject("desk-1", "desk", (2.5, 3.0, 0.375), (1.2, 0.75, 0.6)),)))
    # the desk spans x 2.2..2.8 (its 0.6 m length along x), y 2.4..3.6 (1.2 m width): a goal 0.22 m in front
    res = s.add_goal((2.5, 2.18, 0.0))
    assert not res.ok
    assert "0.22 m from desk 'desk-1'" in res.message and "0.35 m" in res.message, res.message
    assert s.route_snapshot().candidate is None
    assert s.add_goal((2.5, 1.9, 0.0)).ok  # 0.5 m away: fine
    # in the air: a goal 0.2 m above the desk top is too close, 0.5 m above is fine
    assert "desk 'desk-1'" in s.add_goal((2.5, 3.0, 0.95)).message
    assert rules.goal_clearance((2.5, 3.0, 1.25), s.scene, 0.35, s.workspace) is None
    # a yawed object is measured in its own frame
    yawed = Scene(objects=(SceneObject("bar", "cardboard_box", (1.0, 1.0, 0.5), (0.2, 1.0, 2.0), yaw=math.pi / 2),))
    assert rules.goal_clearance((1.0, 2.2, 0.0), yawed, 0.35, s.workspace) is not None  # 0.2 m past its end
    assert rules.goal_clearance((1.4, 1.0, 0.0), yawed, 0.35, s.workspace) is not None  # 0.3 m beside it
    assert rules.goal_clearance((1.5, 1.0, 0.0), yawed, 0.35, s.workspace) is None  # 0.4 m beside it


def test_a_mission_ending_in_the_air_warns_and_a_landing_can_be_added(tmp_path: Path) -> None:
    s = Session(tmp_path / "s", start=START, autosave=False)
    s.set_robot(_ground(*START[:2]))
    assert s.add_goal((2.5, 3.0, 1.5)).ok
    s.register()
    m = s.build_mission()
    assert m.kinds()[-1] == "fly"
    assert s.operator_state().air_end == pytest.approx(1.625, abs=0.2)
    m2 = s.add_landing()
    assert m2.kinds()[-1] == "land" and m2.segments[-1].end[:2] == pytest.approx((2.625, 3.125), abs=0.2)
    assert s.mission is m2 and s.operator_state().air_end is None
    with pytest.raises(SessionError, match="does not end in the air"):
        s.add_landing()


# --- the route starts at the robot ----------------------------------------------------------------
def test_the_route_starts_in_the_air_cell_of_a_hovering_robot_and_its_mission_flies_first(tmp_path: Path) -> None:
    s = Session(tmp_path / "s", start=START, autosave=False)
    s.spawn(_boxes())
    s.set_robot(_hover(2.5, 3.0, 1.6))
    assert s.route_snapshot().start == pytest.approx((2.5, 3.0, 1.6))
    s.set_robot(_hover(2.5, 3.0, 1.0, mode="landing"))  # under way: the start waits until it rests
    assert s.route_snapshot().start == pytest.approx((2.5, 3.0, 1.6))
    s.set_robot(_hover(2.5, 3.0, 1.6))
    assert s.add_goal((2.5, 5.7, 0.0)).ok
    s.register()
    m = s.build_mission()
    assert m.kinds()[0] == "fly" and "land" in m.kinds() and m.kinds()[-1] in ("land", "walk")
    assert _near(m.segments[0].start, (2.5, 3.0, 1.6))
    assert s.operator_state().execute_blocker is None


def test_a_restored_route_elsewhere_is_shown_and_replanned_from_the_robot_in_one_action(tmp_path: Path) -> None:
    a = Session(tmp_path / "s", start=START)
    a.spawn(_boxes())
    a.set_robot(_ground(2.62, 5.75))
    assert a.add_goal((1.0, 6.5, 0.0)).ok
    a.register()
    a.build_mission()

    b = Session(tmp_path / "s", start=START)
    b.restore_last()
    assert b.mission is not None
    b.set_robot(_ground(2.5, 0.7))  # the robot is back at its start
    view = b.operator_state()
    assert view.route_note is not None and "from the robot" in view.route_note and "(2.62, 5.75" in view.route_note
    assert view.execute_blocker is not None and "mission starts at (2.62, 5.88" in view.execute_blocker
    assert b.route_snapshot().start[:2] == pytest.approx((2.62, 5.75))  # not silently changed
    note = b.replan_from_robot()
    assert "re-planned from the robot" in note and "mission rebuilt" in note
    assert b.route_snapshot().start == pytest.approx((2.5, 0.7, 0.0))
    assert b.route_snapshot().goals[-1][:2] == pytest.approx((1.125, 6.625))
    assert _near(b.mission.segments[0].start, (2.5, 0.7, 0.0)) and b.mission.kinds()[0] == "walk"
    assert b.operator_state().route_note is None and b.operator_state().execute_blocker is None


def test_execute_says_why_it_is_off() -> None:
    ws = Workspace()
    idle = RunStatus()
    assert rules.execute_blocker(None, None, idle, True, ws).startswith("no mission")
    from planner.mission import Mission, MissionSegment

    m = Mission((MissionSegment(SegmentKind.WALK, ((2.5, 0.7, 0.0), (2.5, 2.0, 0.0))),))
    assert rules.execute_blocker(m, None, idle, False, ws) == "this robot link has no mission manager"
    assert "no state" in rules.execute_blocker(m, None, idle, True, ws)
    assert rules.execute_blocker(m, _ground(2.5, 0.7), idle, True, ws) is None
    lost = RobotSnapshot(Pose.from_xyz_yaw(2.5, 0.7, 0.0), mode="idle", healthy=False)
    assert "link is lost" in rules.execute_blocker(m, lost, idle, True, ws)
    walking = RobotSnapshot(Pose.from_xyz_yaw(2.5, 0.7, 0.0), mode="walking")
    assert "walking" in rules.execute_blocker(m, walking, idle, True, ws)
    assert "1.00 m from the robot" in rules.execute_blocker(m, _ground(2.5, 1.7), idle, True, ws)
    assert "1.50 m from the robot" in rules.execute_blocker(m, _hover(2.5, 0.7, 1.5), idle, True, ws)
    assert "under way" in rules.execute_blocker(m, _ground(2.5, 0.7), RunStatus("paused"), True, ws)


def test_vehicle_commands_follow_the_robot_state() -> None:
    ws, idle, launch = Workspace(), RunStatus(), (2.5, 0.7, 0.0)

    def shown(robot: RobotSnapshot | None, run: RunStatus = idle, home: Any = launch) -> dict[str, tuple[bool, bool]]:
        return {n: (c.shown, c.enabled) for n, c in rules.vehicle_commands(robot, run, ws, home).items()}

    nothing = {n: (False, False) for n in rules.COMMANDS}
    assert shown(None) == nothing and shown(_ground(2.5, 0.7)) == nothing  # standing, disarmed
    assert shown(_hover(2.5, 3.0, 1.5), RunStatus("running")) == nothing  # the mission has Pause / Abort
    assert shown(_hover(2.5, 3.0, 1.5)) == {"hold": (True, True), "land": (True, True), "return": (True, True),
                                            "disarm": (False, False), "control": (False, False)}
    paused = shown(_hover(2.5, 3.0, 1.5), RunStatus("paused"))
    assert paused["hold"] == (True, True) and paused["land"] == (True, False) and paused["return"] == (True, False)
    assert "abort it first" in rules.vehicle_commands(_hover(2.5, 3.0, 1.5), RunStatus("paused"), ws, launch)["land"].reason
    assert not any(e for _, e in shown(_hover(2.5, 3.0, 1.5), RunStatus("failsafe")).values())  # never against the failsafe
    lost = RobotSnapshot(Pose.from_xyz_yaw(2.5, 3.0, 1.5), mode="holding", armed=True, healthy=False, landed=False)
    assert "link is lost" in rules.vehicle_commands(lost, idle, ws, launch)["hold"].reason
    armed = shown(_ground(2.5, 3.0, armed=True))
    assert armed["disarm"] == (True, True) and armed["land"] == (False, False) and armed["return"] == (True, True)
    assert shown(_ground(2.5, 0.7, armed=True))["return"] == (True, False)  # already home
    assert "unknown" in rules.vehicle_commands(_hover(2.5, 3.0, 1.5), idle, ws, None)["return"].reason


def test_an_air_start_path_becomes_fly_land_walk_and_blocked_remainders_are_found(tmp_path: Path) -> None:
    grid = build_grid(_boxes(), Workspace(), 0.35)
    # hovering above (2.625, 3.125) at 1.625 m, coming down behind the line and walking on
    cells = np.array([(10, 12, 6), (10, 14, 6), (10, 17, 6), (10, 20, 6), (10, 22, 6), (10, 23, 0), (10, 24, 0),
                      (8, 26, 0)])
    m = rules.mission_from_path(cells, grid)
    assert m.kinds() == ["fly", "land", "walk"]
    assert m.segments[1].end == pytest.approx((2.625, 5.875, 0.0))
    assert rules.remaining_blocked(m, 0, grid) is None
    moved = build_grid(Scene(objects=_boxes().objects + (SceneObject("crate", "cardboard_box", (2.6, 6.3, 0.3),
                                                                           (0.5, 0.6, 0.5)),)), Workspace(), 0.35)
    why = rules.remaining_blocked(m, 0, moved)
    # the landing spot (2.625, 5.875) is 0.175 m from the crate: within the robot's radius, so the landing is
    # blocked before the walk (until the radius became a hard limit, only the walk through the crate was)
    assert why is not None and "segment 2 (land)" in why and "crate" in why
    assert rules.remaining_blocked(m, 3, moved) is None  # nothing left after the last segment
    assert rules.goals_left([(1.0, 1.0, 0.0), (2.0, 2.0, 0.0)], np.array([[0, 0, 0], [1, 1, 0], [2, 2, 0.0]]),
                            [1, 2], (1.4, 1.4, 0.0)) == [(2.0, 2.0, 0.0)]


def test_the_simulator_disarms_on_the_ground_only() -> None:
    from planner.mission import MissionSegment

    robot = SimRobot(world=Scene(), config=SimConfig(**FAST), room=None, manual_clock=True)
    robot.connect()
    robot.disarm()  # already disarmed: nothing to do
    run = robot.run_segment(MissionSegment(SegmentKind.TAKEOFF, ((2.5, 0.7, 0.0), (2.5, 0.7, 1.0))))
    robot.run_for(0.3)  # the spool-up: armed, still on the floor
    robot.hold()
    st = robot.latest_state()
    assert st.armed and st.landed and run.done
    robot.disarm()
    assert not robot.latest_state().armed
    run = robot.run_segment(MissionSegment(SegmentKind.TAKEOFF, ((2.5, 0.7, 0.0), (2.5, 0.7, 1.0))))
    robot.run_for(2.0)
    assert run.done and not robot.latest_state().landed
    with pytest.raises(LinkError, match="cannot disarm in the air"):
        robot.disarm()
    robot.close()


# --- live: missions, aborts, edits and vehicle commands on the simulated robot -----------------------------
def test_abort_in_the_air_then_land_here_puts_the_robot_down_and_the_route_at_it(stack: Stack) -> None:
    s = stack.session
    stack.plan((2.5, 5.7, 0.0))
    mission = s.build_mission()
    assert "fly" in mission.kinds()
    stack.runner.execute(mission)
    wait_for(lambda: stack.robot.latest_state().mode.value == "flying", what="flying")
    stack.runner.abort()
    wait_for(lambda: s.run.state == "aborted", what="aborted")
    st = stack.robot.latest_state()
    assert not st.landed and st.armed  # holding in the air
    wait_for(lambda: _near(s.route_snapshot().start, stack.pos), what="route start at the hovering robot")
    assert s.mission is None  # the aborted mission is retired
    assert s.route_snapshot().goals[-1][:2] == pytest.approx((2.625, 5.625))  # the goal is kept, re-planned
    view = s.operator_state()
    assert view.commands["land"].enabled and view.commands["return"].enabled
    assert not view.commands["hold"].enabled and "nothing to hold" in view.commands["hold"].reason  # hovering still
    from_air = s.build_mission()  # planning from the hover pose works
    assert from_air.kinds()[0] == "fly" and _near(from_air.segments[0].start, stack.pos)
    assert s.operator_state().execute_blocker is None

    assert "land here" in stack.commands.run("land")
    assert s.operator_state().running == "Land here"
    wait_for(lambda: s.run.state == "done" and stack.robot.latest_state().landed, what="landed")
    wait_for(lambda: not stack.robot.latest_state().armed, what="disarmed after landing")
    floor = (stack.pos[0], stack.pos[1], 0.0)
    wait_for(lambda: _near(s.route_snapshot().start, floor, 0.01), what="route start on the floor under the robot")
    assert s.route_snapshot().goals[-1][:2] == pytest.approx((2.625, 5.625))
    assert s.mission is not None and _near(s.mission.segments[0].start, floor)  # rebuilt from the robot
    assert s.operator_state().execute_blocker is None
    # disarmed on the floor (the session hears of the disarming at its next robot sample)
    wait_for(lambda: not any(c.shown for c in s.operator_state().commands.values()), what="no command once disarmed")
    stack.runner.execute(s.mission)
    wait_for(lambda: s.run.state == "done" and s.route_snapshot().registered == (), what="mission done")
    assert math.dist(stack.pos[:2], (2.625, 5.625)) < 0.3


def test_return_flies_back_to_the_launch_spot_and_lands(stack: Stack) -> None:
    s = stack.session
    stack.plan((2.5, 5.7, 0.0))
    stack.runner.execute(s.build_mission())
    wait_for(lambda: stack.robot.latest_state().mode.value == "flying", what="flying")
    wait_for(lambda: s.robot is not None and s.robot.mode == "flying", what="the session sees it flying")
    launch = s.operator_state().launch
    assert launch is not None and launch[1] > 1.5  # where it took off, not where the mission began
    stack.runner.abort()
    wait_for(lambda: s.run.state == "aborted" and s.operator_state().commands["return"].enabled, what="return")
    stack.commands.run("return")
    wait_for(lambda: s.run.state == "done" and stack.robot.latest_state().landed, what="returned")
    assert math.dist(stack.pos[:2], launch[:2]) < 0.3
    wait_for(lambda: _near(s.route_snapshot().start, (*stack.pos[:2], 0.0), 0.01), what="route at the robot")


def test_abort_on_the_ground_after_an_early_stop_replans_from_the_robot(stack: Stack) -> None:
    s = stack.session
    stack.plan((2.5, 2.5, 0.0), (1.5, 3.0, 0.0))
    stack.runner.execute(s.build_mission())
    wait_for(lambda: stack.pos[1] > 1.4, what="walking")
    stack.runner.pause()
    wait_for(lambda: s.run.state == "paused", what="paused")
    stack.runner.abort()
    wait_for(lambda: s.run.state == "aborted", what="aborted")
    here = (stack.pos[0], stack.pos[1], 0.0)
    wait_for(lambda: _near(s.route_snapshot().start, here, 0.01), what="route start at the robot")
    assert [g[:2] for g in s.route_snapshot().goals] == [pytest.approx((2.625, 2.625)), pytest.approx((1.625, 3.125))]
    m = s.build_mission()
    assert _near(m.segments[0].start, here) and s.operator_state().execute_blocker is None


def test_an_edit_across_the_rest_of_a_paused_mission_retires_it_everywhere(stack: Stack) -> None:
    s = stack.session
    s.spawn(Scene(objects=(SceneObject("crate", "cardboard_box", (0.6, 7.0, 0.3), (0.5, 0.6, 0.5)),)))
    stack.plan((2.5, 3.3, 0.0))
    mission = s.build_mission()
    stack.runner.execute(mission)
    wait_for(lambda: stack.pos[1] > 1.2, what="walking")
    stack.runner.pause()
    wait_for(lambda: s.run.state == "paused", what="paused")
    s.move_object("crate", (0.6, 6.5, 0.3))  # nowhere near the rest of the walk: the mission stays resumable
    assert s.mission is mission and s.run.state == "paused" and s.operator_state().resume_blocker is None
    s.move_object("crate", (2.6, 2.6, 0.3))  # onto the rest of the walk
    assert s.mission is None
    wait_for(lambda: s.run.state == "aborted", what="the retired run ends")
    assert s.operator_state().resume_blocker is None and not s.run.active  # no Resume anywhere
    here = (stack.pos[0], stack.pos[1], 0.0)
    wait_for(lambda: _near(s.route_snapshot().start, here, 0.01), what="re-planned from the robot")
    assert s.route_snapshot().goals[-1][:2] == pytest.approx((2.625, 3.375))
    assert s.build_mission().segments[0].start == pytest.approx(here, abs=rules.START_TOLERANCE)


# --- the views only draw the rules ------------------------------------------------------------------
def test_the_panels_show_the_vehicle_commands_replan_and_landing_actions_the_rules_allow(tmp_path: Path) -> None:
    import viser

    from console.views.mission_view import MissionView
    from console.views.robot_view import RobotView

    server = viser.ViserServer(host="127.0.0.1", port=0, verbose=False)
    try:
        s = Session(tmp_path / "s", start=START, autosave=False)
        robot_view = RobotView(server, s, "sim", commands=VehicleCommands(s, None, None))
        mission_view = MissionView(server, s, None)
        buttons = robot_view._buttons

        def usable() -> dict[str, bool]:
            return {n: b.visible and not b.disabled for n, b in buttons.items()}

        s.set_robot(_ground(2.5, 0.7))
        assert not any(b.visible for b in buttons.values())
        s.set_robot(_hover(2.5, 2.0, 1.5, mode="flying"))  # under way without a mission of the console's: Hold stops it
        assert usable() == {"hold": True, "land": True, "return": True, "disarm": False, "control": False}
        s.set_robot(_hover(2.5, 2.0, 1.5))  # hovering still: nothing to hold (off, with the reason on hover)
        assert usable() == {"hold": False, "land": True, "return": True, "disarm": False, "control": False}
        assert "nothing to hold" in buttons["hold"].hint
        s.set_run(RunStatus("paused", 0, 0.2))
        assert usable() == {"hold": False, "land": False, "return": False, "disarm": False, "control": False}
        assert buttons["land"].visible and "abort it first" in robot_view._why_not.content
        s.set_run(RunStatus("running", 0, 0.3))
        assert not any(b.visible for b in buttons.values())  # the mission's Pause / Abort drive it
        s.set_run(RunStatus("aborted", 0, 0.3))
        with pytest.raises(SessionError, match="no mission manager"):  # the view's call says why
            VehicleCommands(s, None, None).run("land")

        s.set_robot(_ground(2.5, 0.7))
        assert s.add_goal((2.5, 2.5, 1.5)).ok
        s.register()
        s.build_mission()
        assert mission_view._landing.visible and "ends hovering" in mission_view._why.content
        s.add_landing()
        assert not mission_view._landing.visible
        s.set_robot(_ground(1.0, 1.0))  # moved with a registered route: stale, one action
        assert mission_view._replan.visible and "from the robot" in mission_view._why.content
        s.replan_from_robot()
        assert not mission_view._replan.visible
    finally:
        server.stop()
