"""The mission watchdog and the link's own time-outs follow one rule (console/link/closing_speed.py): a
vehicle that walks slower than the speeds the watchdog assumes is timed on its measured closing speed
while it still closes in, and held (mission paused) once it has stopped."""

from __future__ import annotations


from console.link.manager import MissionStatus
from mav_helpers import config, eventually, events, mission_manager, vehicle
from planner.mission import Mission, MissionSegment, SegmentKind

WALK = SegmentKind.WALK
SLOW = 0.5
"""The vehicle's own walking speed [m/s] (its DO_CHANGE_SPEED is accepted and ignored); the watchdog
assumes 2 m/s: 2 m in 2 m / 2 m/s x 1 + 1 s = 2 s, the walk takes 4 s."""


def _walk() -> Mission:
    return Mission((MissionSegment(WALK, ((2.5, 0.7, 0.0), (2.5, 2.7, 0.0))),))


def test_a_vehicle_slower_than_the_watchdog_expects_is_not_stopped_while_it_closes_in() -> None:
    with vehicle(faults={"speed_ignored": True}, walk_speed=SLOW) as (link, emu):
        manager = mission_manager(link, failsafe_after=1.5, failsafe_hold=0.5, watchdog_speeds=(2.0, 2.0, 2.0),
                                  watchdog_factor=1.0, watchdog_slack=1.0)
        manager.start(_walk())
        assert manager.wait(60.0) is MissionStatus.DONE, events(manager)
        msgs = events(manager)
        assert any("slower than the watchdog expected: its deadline follows the measured speed" in m
                   for m in msgs), msgs
        assert not any("overran its deadline" in m for m in msgs)


def test_a_slow_vehicle_that_stops_is_held_and_the_mission_paused() -> None:
    # the link's own time-out (the same rule) is given 60 s of slack: the watchdog is what stops it here
    with vehicle(config(timeout_slack=60.0), faults={"speed_ignored": True}, walk_speed=SLOW) as (link, emu):
        manager = mission_manager(link, failsafe_after=1.5, failsafe_hold=0.5, watchdog_speeds=(2.0, 2.0, 2.0),
                                  watchdog_factor=1.0, watchdog_slack=1.0)
        manager.start(_walk())
        assert eventually(lambda: link.latest_state().position[1] > 1.0)  # under way (slowly)
        with emu.lock:
            emu.freeze_motion = True  # stopped short of the goal
        assert manager.wait(60.0) is MissionStatus.PAUSED, events(manager)
        message = manager.progress().message
        assert "walk overran its deadline of 2 s (2.0 m): robot held, mission paused" in message, message
        assert link.latest_state().position[1] < 2.6
