"""Speeds that hold on ArduCopter: the emulator resets the speed to WPNAV_SPEED when GUIDED enters
position control (ArduCopter/mode_guided.cpp); the link sends the speed after that entry, again after
every mode change, watches the measured speed, and pauses / segments end within the stopping distance."""

from __future__ import annotations

import math
import time

from pymavlink import mavutil

from console.link.base import RunStatus
from console.link.manager import MissionStatus
from mav_helpers import config, eventually, events, mission_manager, vehicle
from planner.mission import Mission, MissionSegment, SegmentKind

mav = mavutil.mavlink
WALK, TAKEOFF, FLY = SegmentKind.WALK, SegmentKind.TAKEOFF, SegmentKind.FLY
BOUNDS = dict(bounds_min=(0.0, 0.0, 0.0), bounds_max=(10.0, 12.0, 3.0))
# ArduCopter-like: WPNAV_SPEED 2.5 m/s, accelerating at 1.5 m/s^2, braking at 0.8 m/s^2
REAL = dict(fly_speed=2.5, accel=1.5, brake_decel=0.8)
SPEED = 0.5  # commanded [m/s]
BRAKE = 0.8  # the emulator's braking [m/s^2]


def _airborne(link, height: float = 1.5) -> None:
    run = link.run_segment(MissionSegment(TAKEOFF, ((2.5, 0.7, 0.0), (2.5, 0.7, height))))
    assert run.wait(60.0) is RunStatus.DONE, run.error


def test_the_emulator_resets_the_speed_when_guided_enters_position_control() -> None:
    """The firmware behaviour itself: a speed sent before the first position target is lost."""
    with vehicle(config(fly_speed=SPEED), **REAL) as (link, emu):
        _airborne(link)
        link.set_mode("BRAKE")
        link.set_mode("GUIDED")
        assert link.commander.change_speed(1, SPEED)  # ACCEPTED, yet ...
        link.send_position_target((2.5, 6.0, 1.5))  # ... the first target starts position control: WPNAV_SPEED
        assert eventually(lambda: math.hypot(*emu.vel[:2]) > 3 * SPEED, 20.0)
        assert emu.record.speed_resets >= 1


def test_the_commanded_speed_holds_and_a_pause_stops_within_the_stopping_distance() -> None:
    with vehicle(config(fly_speed=SPEED, brake_decel=BRAKE), **REAL) as (link, emu):
        _airborne(link)
        emu.record.max_speed = 0.0
        manager = mission_manager(link, failsafe_after=1.5, failsafe_hold=0.5)
        manager.start(Mission((MissionSegment(FLY, ((2.5, 0.7, 1.5), (2.5, 9.0, 1.5))),), **BOUNDS))
        assert eventually(lambda: emu.pos[0] > 1.5, 60.0)
        flown = emu.record.max_speed
        with emu.lock:
            pressed, v0 = list(emu.pos), math.hypot(*emu.vel[:2])
        manager.pause()
        assert manager.wait(30.0) is MissionStatus.PAUSED, events(manager)
        stop = math.dist(emu.pos[:2], pressed[:2])
        print(f"measured max {flown:.3f} m/s for {SPEED} commanded (WPNAV_SPEED 2.5); "
              f"pause at {v0:.2f} m/s stopped {stop:.3f} m past the press "
              f"(stopping distance {link.config.stopping_distance(SPEED):.3f} m)")
        assert emu.record.speed_resets >= 1  # the firmware did reset it ...
        assert flown <= SPEED * 1.1, flown  # ... and the speed sent after that held
        # v^2/2a at the commanded speed, plus the hold's way to the vehicle (<= 0.5 s at 0.5 m/s loaded)
        assert stop <= link.config.stopping_distance(SPEED) + 0.25, stop
        # resume: BRAKE -> GUIDED enters position control again; the speed is sent again and holds
        emu.record.max_speed = 0.0
        manager.resume()
        assert manager.wait(60.0) is MissionStatus.DONE, events(manager)
        assert emu.record.max_speed <= SPEED * 1.1, emu.record.max_speed
        end = (9.0 - 0.7, 0.0)  # NED of the world target (2.5, 9.0)
        beyond = emu.pos[0] - end[0]
        print(f"segment end: {beyond:+.3f} m along the path from its target")
        assert beyond <= link.config.stopping_distance(SPEED), beyond


def test_walking_speed_holds_too() -> None:
    """Neighbour: the ground-motion command set (position targets at floor height) in GUIDED."""
    from mav_helpers import CFG
    from dataclasses import replace
    with vehicle(config(ground=replace(CFG.ground, speed=0.4)), walk_speed=2.0, accel=2.0) as (link, emu):
        manager = mission_manager(link, failsafe_after=1.5, failsafe_hold=0.5)
        manager.start(Mission((MissionSegment(WALK, ((2.5, 0.7, 0.0), (2.5, 3.5, 0.0))),), **BOUNDS))
        assert manager.wait(60.0) is MissionStatus.DONE, events(manager)
        assert emu.record.speed_resets >= 1 and emu.record.max_speed <= 0.4 * 1.1, emu.record.max_speed


def test_a_vehicle_faster_than_commanded_gets_the_speed_again_then_is_stopped() -> None:
    """A vehicle that accepts the speed but does not apply it: warned (speed sent again), then stopped
    (BRAKE) and the segment fails naming both speeds; the mission pauses."""
    with vehicle(config(fly_speed=SPEED), faults={"speed_ignored": True}, **REAL) as (link, emu):
        _airborne(link)
        manager = mission_manager(link, failsafe_after=1.5, failsafe_hold=0.5)
        manager.start(Mission((MissionSegment(FLY, ((2.5, 0.7, 1.5), (2.5, 11.0, 1.5))),), **BOUNDS))
        assert manager.wait(60.0) is MissionStatus.PAUSED, events(manager)
        text = manager.progress().message
        assert "although 0.50 m/s was commanded (twice): stopped" in text, text
        assert any("speed sent again" in w for w in link.latest_state().warnings)
        assert emu.record.modes[-1] == "BRAKE"
        assert eventually(lambda: math.hypot(*emu.vel[:2]) < 0.1, 20.0)
        assert emu.pos[0] < 10.3 - 2.0  # stopped well before the target


def test_a_lost_speed_ack_never_pauses_the_mission() -> None:
    """Item 7's optional command: DO_CHANGE_SPEED never answered is a warning; the mission completes
    (a refused one too, as before); the measured speed is still watched."""
    with vehicle(config(fly_speed=1.0), faults={"ignore_commands": {mav.MAV_CMD_DO_CHANGE_SPEED}}) as (link, emu):
        _airborne(link)
        started = time.monotonic()
        run = link.run_segment(MissionSegment(FLY, ((2.5, 0.7, 1.5), (2.5, 2.5, 1.5))))
        assert run.wait(60.0) is not RunStatus.RUNNING
        # the emulator (WPNAV 4 m/s) flies faster than 1 m/s without the speed: held for overspeed, not an ACK
        assert "no COMMAND_ACK" not in (run.error or ""), run.error
        assert any("continuing; the measured speed is watched" in w for w in link.latest_state().warnings)
        assert time.monotonic() - started < 60.0
