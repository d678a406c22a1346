"""The mission manager on the simulated robot: segments, progress, geofence, pause, failures, failsafe."""

from __future__ import annotations

import math
import threading
import time

import numpy as np
import pytest

from console.link.base import Mode
from console.link.manager import GeofenceError, MissionManager, MissionStateError, MissionStatus
from console.link.sim import SimConfig, SimRobot
from console.link.world import DEFAULT_START, SEARCH_GOAL, paper_room
from planner.grid import Workspace, build_grid
from planner.mission import Mission, MissionSegment, SegmentKind

WALK, TAKEOFF, FLY, LAND = SegmentKind.WALK, SegmentKind.TAKEOFF, SegmentKind.FLY, SegmentKind.LAND
FAST = dict(walk_speed=1.0, fly_speed=1.5, climb_rate=1.0, descent_rate=1.0, spool_time=0.3, settle_time=0.2)


def _robot(time_scale: float = 8.0, **cfg: float) -> SimRobot:
    robot = SimRobot(config=SimConfig(time_scale=time_scale, **{**FAST, **cfg}))
    robot.connect()
    return robot


def _mission(walk_to: float = 3.0, height: float = 1.75) -> Mission:
    """Walk to the front of the box line, fly over it, land behind and walk to the dog."""
    return Mission((
        MissionSegment(WALK, ((2.5, 0.7, 0.0), (2.5, walk_to, 0.0))),
        MissionSegment(TAKEOFF, ((2.5, walk_to, 0.0), (2.5, walk_to, height))),
        MissionSegment(FLY, ((2.5, walk_to, height), (2.5, 4.0, height), (2.5, 5.0, height))),
        MissionSegment(LAND, ((2.5, 5.0, height), (2.5, 5.0, 0.0))),
        MissionSegment(WALK, ((2.5, 5.0, 0.0), SEARCH_GOAL)),
    ))


def _until(cond, what: str, timeout: float = 60.0) -> None:
    """Poll ``cond`` (every 5 ms) until true; fails, naming ``what``, after ``timeout`` [s] (never hangs)."""
    deadline = time.monotonic() + timeout
    while not cond():
        assert time.monotonic() < deadline, f"timed out waiting for {what}"
        time.sleep(0.005)


@pytest.fixture
def robot():
    r = _robot()
    yield r
    r.close()


def test_planned_mission_finds_the_dog_end_to_end() -> None:
    """Plan on the true map, run it segment by segment, and see the dog in the final photo."""
    pytest.importorskip("planner.astar")
    from planner.route import Route

    robot = _robot(time_scale=10.0)
    try:
        grid = build_grid(paper_room(), Workspace(), margin=0.35)
        route = Route(grid, DEFAULT_START.translation)
        assert route.propose(SEARCH_GOAL).ok
        route.register()
        mission = route.mission()
        assert mission.kinds() == ["walk", "takeoff", "fly", "land", "walk"]
        manager = MissionManager(robot)
        events = []
        manager.subscribe(events.append)
        manager.start(mission)
        assert manager.wait(60.0) is MissionStatus.DONE, [e.message for e in events]
        assert robot.latest_state().position == pytest.approx(mission.segments[-1].end, abs=1e-6)
        fractions = [e.progress.fraction for e in events]
        assert fractions == sorted(fractions) and fractions[-1] == 1.0
        switches = [e.message for e in events if e.message.startswith("switching")]
        assert switches == ["switching to ground control", "switching to flight control",
                            "switching to ground control"]
        shot = robot.capture()
        assert any(v.label == "robot_dog" and v.pixels > 1000 for v in shot.ground_truth.visible)
    finally:
        robot.close()


def test_targets_outside_the_geofence_are_refused_before_moving(robot: SimRobot) -> None:
    bad = Mission((MissionSegment(WALK, ((2.5, 0.7, 0.0), (2.5, 2.0, 0.0))),
                   MissionSegment(TAKEOFF, ((2.5, 2.0, 0.0), (2.5, 2.0, 3.5)))),
                  bounds_min=(0.0, 0.0, 0.0), bounds_max=(5.0, 8.0, 3.0))
    manager = MissionManager(robot)
    with pytest.raises(GeofenceError, match=r"segment 2 \(take-off\) waypoint 2 \(2.50, 2.00, 3.50\)"):
        manager.start(bad)
    assert manager.progress().status is MissionStatus.IDLE
    assert robot.latest_state().position == pytest.approx(DEFAULT_START.translation)
    # a margin widens the fence
    MissionManager(robot, geofence_margin=0.6).check_geofence(bad)


def test_start_refuses_a_mission_planned_elsewhere(robot: SimRobot) -> None:
    far = Mission((MissionSegment(WALK, ((1.0, 1.5, 0.0), (1.0, 2.0, 0.0))),))
    with pytest.raises(MissionStateError, match="robot is at"):
        MissionManager(robot).start(far)


def test_pause_holds_and_resume_continues_from_where_it_stopped() -> None:
    # real time: the flight past y = 3.5 lasts 1 s, a window a loaded machine's test thread does not miss
    robot = _robot(time_scale=1.0)
    try:
        _pause_and_resume(robot)
    finally:
        robot.close()


def _pause_and_resume(robot: SimRobot) -> None:
    manager = MissionManager(robot)
    ys: list[tuple[SegmentKind | None, float]] = []
    robot.subscribe(lambda s: ys.append((manager.progress().kind, s.position[1])))
    manager.start(_mission())
    _until(lambda: manager.progress().kind is FLY and robot.latest_state().position[1] > 3.5, "flying past y 3.5")
    manager.pause()
    assert manager.wait(30.0) is MissionStatus.PAUSED
    held = robot.latest_state()
    assert held.mode is Mode.HOLDING and not held.landed
    time.sleep(0.3)
    assert robot.latest_state().position == pytest.approx(held.position)
    with pytest.raises(MissionStateError):
        manager.start(_mission())  # one mission at a time
    manager.resume()
    # a second pause in the same flight, past its middle waypoint
    _until(lambda: robot.latest_state().position[1] >= 4.3, "past y 4.3")
    manager.pause()
    assert manager.wait(30.0) is MissionStatus.PAUSED
    manager.resume()
    assert manager.wait(60.0) is MissionStatus.DONE
    assert robot.latest_state().position == pytest.approx(SEARCH_GOAL)
    # the flight never went back towards its start after the pauses
    fly = [y for k, y in ys if k is FLY]
    assert np.all(np.diff(fly) >= -1e-9)
    with pytest.raises(MissionStateError):
        manager.resume()


def test_abort_stops_for_good() -> None:
    robot = _robot(time_scale=1.0)  # real time: the take-off lasts 2 s, a window the test thread does not miss
    try:
        _abort_in_the_takeoff(robot)
    finally:
        robot.close()


def _abort_in_the_takeoff(robot: SimRobot) -> None:
    manager = MissionManager(robot)
    manager.start(_mission())
    _until(lambda: manager.progress().kind is TAKEOFF, "the take-off")
    manager.abort()
    assert manager.wait(30.0) is MissionStatus.ABORTED
    # the robot's next state samples say it stopped (waited for: a loaded machine publishes late)
    _until(lambda: robot.latest_state().mode in (Mode.HOLDING, Mode.IDLE)
           and robot.latest_state().speed == pytest.approx(0.0, abs=1e-9), "the robot stopped")
    st = robot.latest_state()
    with pytest.raises(MissionStateError):
        manager.resume()
    manager.start(Mission((MissionSegment(WALK, (st.position, st.position)),), id="next"))  # a new one is fine


def test_a_blocked_path_pauses_the_mission_with_the_reason(robot: SimRobot) -> None:
    # the operator's map missed the boxes: the plan walks straight through them
    through = Mission((MissionSegment(WALK, ((2.5, 0.7, 0.0), (2.5, 3.0, 0.0), (2.5, 5.5, 0.0))),))
    manager = MissionManager(robot)
    manager.start(through)
    assert manager.wait(30.0) is MissionStatus.PAUSED
    p = manager.progress()
    assert "walking stopped: contact with an unmapped obstacle ahead at (" in p.message and "paused" in p.message
    assert "cardboard_box" not in p.message
    assert p.segment == 0 and p.mission_id == through.id and 0.2 < p.fraction < 0.8
    manager.abort()
    assert manager.wait(30.0) is MissionStatus.ABORTED


FAILSAFE_AFTER = 2.0
"""The manager's failsafe_after in the link-loss tests [s]: far above how long a loaded machine's simulator
thread goes without publishing (0.3 s dropped a resumed mission into a false failsafe under load); the
outages themselves start on a state and end when the test says so, not after a duration."""


def _drop_link_when(robot: SimRobot, cond) -> threading.Event:
    """Start an outage (until :func:`_restore_link`) from the simulator's own thread at the first state
    with ``cond(state)``; returns the event set when it started."""
    dropped = threading.Event()

    def watch(s) -> None:
        if not dropped.is_set() and cond(s):
            robot.drop_link(3600.0)
            dropped.set()

    robot.subscribe(watch)
    return dropped


def _restore_link(robot: SimRobot) -> None:
    robot.drop_link(0.0)  # the outage ends now (simulated time)


def test_link_loss_runs_the_failsafe_and_the_mission_survives() -> None:
    # time_scale 1 so the robot's own link-loss hold and landing (simulated seconds) follow the manager's clock
    robot = _robot(time_scale=1.0, fly_speed=0.6, climb_rate=3.0, link_loss_hold=0.2, link_loss_land=0.6,
                   descent_rate=3.0)
    hop = Mission((
        MissionSegment(TAKEOFF, ((2.5, 0.7, 0.0), (2.5, 0.7, 1.5))),
        MissionSegment(FLY, ((2.5, 0.7, 1.5), (2.5, 2.2, 1.5))),
        MissionSegment(LAND, ((2.5, 2.2, 1.5), (2.5, 2.2, 0.0))),
        MissionSegment(WALK, ((2.5, 2.2, 0.0), (2.5, 2.9, 0.0))),
    ))
    try:
        manager = MissionManager(robot, failsafe_after=FAILSAFE_AFTER, failsafe_hold=0.3)
        dropped = _drop_link_when(robot, lambda s: s.position[2] > 1.4 and s.position[1] > 0.9)  # in the flight
        manager.start(hop)
        assert manager.wait(60.0, until=[MissionStatus.FAILSAFE]) is MissionStatus.FAILSAFE, \
            [e.message for e in manager.events]
        assert dropped.is_set()
        # the failsafe's hold and landing are not delivered (no link); it ends; the robot lands by itself
        _until(lambda: any("FAILSAFE landing not delivered" in e.message for e in manager.events)
               and not manager._failsafe_acting, "the failsafe's end")
        _restore_link(robot)
        _until(lambda: robot.latest_state().link_ok and robot.latest_state().landed, "the link back, landed")
        msgs = [e.message for e in manager.events]
        assert any(m.startswith("FAILSAFE: robot not heard for") for m in msgs)
        assert any("not delivered" in m for m in msgs)  # no link: the robot's own failsafe landed it
        st = robot.latest_state()
        assert st.landed and st.link_ok and 0.8 < st.position[1] < 2.0
        p = manager.progress()
        assert p.status is MissionStatus.FAILSAFE and p.segment == 1 and p.mission_id == hop.id
        manager.resume()  # takes off again where it landed and finishes the flight
        assert manager.wait(60.0) is MissionStatus.DONE, [e.message for e in manager.events]
        assert robot.latest_state().position == pytest.approx((2.5, 2.9, 0.0))
        assert any("recovery" in m for m in (e.message for e in manager.events))
    finally:
        robot.close()


class _SlowHold(SimRobot):
    """A robot whose hold command takes long to confirm (a MAVLink BRAKE waiting out its ACK retries): it
    returns when the test sets ``release``."""

    def __init__(self, **kw) -> None:
        super().__init__(**kw)
        self.holding = threading.Event()
        self.release = threading.Event()
        self.hold_sent_at = math.inf

    def hold(self) -> None:
        self.hold_sent_at = time.monotonic()  # after the failsafe set its failsafe_hold deadline
        self.holding.set()
        assert self.release.wait(120.0), "the test never released the hold"
        super().hold()


def test_a_link_back_during_a_slow_hold_pauses_instead_of_landing() -> None:
    robot = _SlowHold(config=SimConfig(time_scale=1.0, **{**FAST, "fly_speed": 0.3, "link_loss_land": 30.0}))
    robot.connect()
    hop = Mission((
        MissionSegment(TAKEOFF, ((2.5, 0.7, 0.0), (2.5, 0.7, 1.5))),
        MissionSegment(FLY, ((2.5, 0.7, 1.5), (2.5, 2.2, 1.5))),
    ))
    try:
        manager = MissionManager(robot, failsafe_after=FAILSAFE_AFTER, failsafe_hold=0.3)
        _drop_link_when(robot, lambda s: s.position[2] > 1.4 and s.position[1] > 0.8)  # in the flight
        manager.start(hop)
        assert robot.holding.wait(60.0), [e.message for e in manager.events]  # the failsafe's hold is sent
        # the link returns while the hold is still unconfirmed, after failsafe_hold (counted from the
        # failsafe, before the hold was sent) has run out
        _until(lambda: time.monotonic() > robot.hold_sent_at + manager.failsafe_hold, "failsafe_hold over")
        _restore_link(robot)
        _until(lambda: robot.link_age_now() < FAILSAFE_AFTER / 2, "the link back")
        robot.release.set()
        assert manager.wait(30.0, until=[MissionStatus.PAUSED]) is MissionStatus.PAUSED, \
            [e.message for e in manager.events]
        msgs = [e.message for e in manager.events]
        assert any(m.startswith("FAILSAFE: robot not heard for") for m in msgs)
        assert any(m.startswith("link restored during the failsafe hold") for m in msgs)
        assert not any("landing" in m for m in msgs)
        time.sleep(0.3)  # an observation window: nothing lands it afterwards
        assert not robot.latest_state().landed
    finally:
        robot.release.set()
        robot.close()


def test_manager_rejects_nonsense_settings(robot: SimRobot) -> None:
    with pytest.raises(ValueError, match="failsafe_after"):
        MissionManager(robot, failsafe_after=0)
    with pytest.raises(ValueError, match="geofence_margin"):
        MissionManager(robot, geofence_margin=-1)
    with pytest.raises(MissionStateError, match="cannot pause"):
        MissionManager(robot).pause()
    assert math.isfinite(MissionManager(robot).failsafe_hold)


def test_resume_pressed_on_the_failsafe_s_last_word_waits_for_its_end(monkeypatch: pytest.MonkeyPatch) -> None:
    """The failsafe says "landed ... resume once the link is back" just before it ends: a resume at that
    moment waits for the end (it was refused with "still acting" on a loaded machine), one during a
    hold or landing that lasts is still refused."""
    import threading
    from dataclasses import replace

    from console.link import manager as mgr

    link = SimRobot(manual_clock=True)
    link.connect()
    try:
        m = MissionManager(link)
        with m._cond:
            m._progress = replace(m._progress, status=MissionStatus.FAILSAFE)
            m._failsafe_acting = True
        ended = threading.Event()

        def end_soon() -> None:
            with m._cond:
                m._failsafe_acting = False
                m._cond.notify_all()
            ended.set()

        monkeypatch.setattr(mgr, "FAILSAFE_WRAP_UP_S", 60.0)  # however late the end comes on a loaded machine
        threading.Timer(0.05, end_soon).start()
        m.resume()  # the link is heard (simulator): it waited for the end, then resumed
        assert ended.is_set() and m.progress().status is MissionStatus.RUNNING
        with m._cond:
            m._progress = replace(m._progress, status=MissionStatus.FAILSAFE)
            m._failsafe_acting = True
        monkeypatch.setattr(mgr, "FAILSAFE_WRAP_UP_S", 0.05)
        with pytest.raises(MissionStateError, match="still acting"):
            m.resume()  # a failsafe that goes on (a hold, a landing) is not waited for
    finally:
        link.close()
