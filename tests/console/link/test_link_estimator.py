"""Estimator trust: a position step the vehicle cannot have flown (an EKF reset, a GPS glitch) and
EKF_STATUS_REPORT / ESTIMATOR_STATUS fault flags or variances hold the robot and pause the mission
with the reason; the state shows the jump."""

from __future__ import annotations

import math
import time

import pytest

from console.link.base import RunStatus
from console.link.manager import MissionStatus
from console.link.mavlink_authority import EstimatorWatch
from mav_helpers import config, eventually, events, mission_manager, vehicle
from planner.mission import Mission, MissionSegment, SegmentKind

TAKEOFF, FLY = SegmentKind.TAKEOFF, SegmentKind.FLY
BOUNDS = dict(bounds_min=(0.0, 0.0, 0.0), bounds_max=(10.0, 12.0, 3.0))


def _airborne(link, height: float = 1.5) -> None:
    run = link.run_segment(MissionSegment(TAKEOFF, ((2.5, 0.7, 0.0), (2.5, 0.7, height))))
    assert run.wait(60.0) is RunStatus.DONE, run.error


@pytest.mark.parametrize("north, east, glitch, words", [
    (0.0, 4.0, False, "position jumped"),  # the 4 m reset, no flag at all
    (3.0, 0.0, True, "position jumped"),  # a reset with the GPS-glitch flag
    (0.0, 0.0, True, "GPS glitch"),  # flags and variances only, no step
])
def test_an_estimator_fault_holds_and_pauses_with_the_reason(north, east, glitch, words) -> None:
    with vehicle(config(fly_speed=1.0)) as (link, emu):
        _airborne(link)
        manager = mission_manager(link, failsafe_after=1.5, failsafe_hold=0.5)
        manager.start(Mission((MissionSegment(FLY, ((2.5, 0.7, 1.5), (2.5, 9.0, 1.5))),), **BOUNDS))
        assert eventually(lambda: emu.pos[0] > 1.0)
        emu.ekf_reset(north, east, glitch)
        assert manager.wait(30.0) is MissionStatus.PAUSED, events(manager)
        message = manager.progress().message
        assert "the robot's position estimate is not trusted" in message and words in message, message
        assert "robot held, mission paused" in message
        if north or east:  # the step said, in metres (+ what the vehicle flew in those 40 ms)
            said = float(message.split("position jumped ")[1].split(" m")[0])
            assert said == pytest.approx(math.hypot(north, east), abs=0.1), message
        assert emu.record.modes[-1] == "BRAKE"
        st = link.latest_state()
        if north or east:
            assert st.position_jump == pytest.approx(math.hypot(north, east), abs=0.1)  # + the flight in 40 ms
            assert st.estimator_resets >= 1 and words in st.estimator
        assert st.health.startswith("estimator not trusted") or not glitch


def test_fast_but_possible_motion_is_not_a_jump_and_the_watch_uses_the_vehicle_clock() -> None:
    w = EstimatorWatch(max_speed=15.0, margin=0.5)
    assert w.position((0.0, 0.0, 0.0), 10.0) is None
    assert w.position((1.4, 0.0, 0.0), 10.1) is None  # 14 m/s: possible
    assert w.position((1.4, 4.0, 0.0), 10.14) is not None  # 4 m in 40 ms: a reset
    assert w.resets == 1 and "4.00 m in 0.04 s (100 m/s" in w.jump
    w.forget()
    assert w.position((50.0, 0.0, 0.0), 11.0) is None  # after a reboot: a new track


def test_estimator_status_flags_and_ratios_are_faults_too() -> None:
    assert "GPS glitch" in EstimatorWatch.estimator_fault(1024, {})
    assert "accelerometer error" in EstimatorWatch.estimator_fault(2048, {})
    assert "position 1.30" in EstimatorWatch.estimator_fault(0, {"position": 1.3, "velocity": 0.2})
    assert EstimatorWatch.estimator_fault(0, {"position": 0.3}) == ""
    assert "variance above 0.8 (compass 0.95)" in EstimatorWatch.ekf_fault(31, {"compass": 0.95})
    w = EstimatorWatch(15.0)
    assert w.flags("GPS glitch") == "GPS glitch" and w.flags("GPS glitch") is None  # counted once
    assert w.resets == 1 and w.flags("") is None and w.fault == ""
