"""Failsafe on live facts and no late commands: the failsafe never lands in the instant heartbeats
return without a fresh position; what is said after the link returns is built from telemetry received
after it returned; on TCP nothing is written into a blocked connection (it would arrive late)."""

from __future__ import annotations

import math
import time

from pymavlink import mavutil

from console.link.base import RunStatus
from console.link.manager import MissionStatus
from mav_helpers import config, eventually, events, mission_manager, vehicle
from planner.mission import Mission, MissionSegment, SegmentKind

mav = mavutil.mavlink
TAKEOFF, FLY = SegmentKind.TAKEOFF, SegmentKind.FLY
BOUNDS = dict(bounds_min=(0.0, 0.0, 0.0), bounds_max=(10.0, 12.0, 3.0))
FAILSAFE_AFTER = 3.0
"""[s] far above a loaded machine's scheduling gaps: the failsafe starts on the fault injected, never before."""
PATIENT = dict(ack_timeout=1.0, command_max_age=10.0)
"""For the tests not about command time-outs: an ACK slower than the helpers' 0.25 s x 3 within 2 s (a loaded
machine) is not a refusal."""
HEARD_BEFORE_THE_END = 1.5
"""[s] before the failsafe hold ends the heartbeats come back: room for a late wake-up of the test thread."""


def _airborne(link, height: float = 1.5) -> None:
    run = link.run_segment(MissionSegment(TAKEOFF, ((2.5, 0.7, 0.0), (2.5, 0.7, height))))
    assert run.wait(60.0) is RunStatus.DONE, run.error


def _flight(y: float = 9.0) -> Mission:
    return Mission((MissionSegment(FLY, ((2.5, 0.7, 1.5), (2.5, y, 1.5))),), **BOUNDS)


def _frozen_until_the_hold_ends(link, emu, manager, position_back_after: float | None) -> None:
    """Freeze the vehicle; :data:`HEARD_BEFORE_THE_END` before the failsafe hold ends give the heartbeat
    back; the position stream ``position_back_after`` [s] after the hold has ended (or never). The hold's
    end is counted from the failsafe's own event (wall clock), not from when this thread heard of it."""
    emu.frozen = True
    assert manager.wait(30.0, until=[MissionStatus.FAILSAFE]) is MissionStatus.FAILSAFE, events(manager)
    failsafe_at = next(e.time for e in manager.events if e.message.startswith("FAILSAFE: robot not heard"))
    hold_end = failsafe_at + manager.failsafe_hold
    time.sleep(max(0.0, hold_end - HEARD_BEFORE_THE_END - time.time()))
    emu.telemetry_enabled = False
    emu.frozen = False  # heartbeats only
    if position_back_after is not None:
        time.sleep(max(0.0, hold_end + position_back_after - time.time()))
        emu.telemetry_enabled = True


def test_heartbeats_returning_without_a_position_are_not_a_moment_to_land() -> None:
    """The issue's case: the heartbeat is back, no fresh position yet, the hold ends: the console waits
    for the position (it arrives 0.5 s after the hold's end, within FRESH_WAIT = 2 s) and reports the
    vehicle as it is: no LAND."""
    with vehicle(config(fly_speed=1.0, **PATIENT)) as (link, emu):
        _airborne(link)
        manager = mission_manager(link, failsafe_after=FAILSAFE_AFTER, failsafe_hold=3.0, poll=0.01)
        manager.start(_flight())
        assert eventually(lambda: emu.pos[0] > 1.0)
        _frozen_until_the_hold_ends(link, emu, manager, position_back_after=0.5)
        assert manager.wait(30.0, until=[MissionStatus.PAUSED]) is MissionStatus.PAUSED, events(manager)
        assert emu.flushed()  # the commands sent so far have reached the vehicle: a LAND among them would show
        assert "LAND" not in emu.record.modes, emu.record.modes
        told = next(m for m in events(manager) if m.startswith("link restored"))
        assert "in the air" in told and "autopilot mode BRAKE" in told, told
        assert not any("FAILSAFE: link still lost" in m for m in events(manager)), events(manager)


def test_heartbeats_without_a_position_for_long_still_land() -> None:
    """Neighbour: heartbeats back but the position never comes: after the wait the link is still
    stale, and the failsafe lands."""
    with vehicle(config(fly_speed=1.0, **PATIENT)) as (link, emu):
        _airborne(link)
        manager = mission_manager(link, failsafe_after=FAILSAFE_AFTER, failsafe_hold=3.0, poll=0.01)
        manager.start(_flight())
        assert eventually(lambda: emu.pos[0] > 1.0)
        _frozen_until_the_hold_ends(link, emu, manager, position_back_after=None)
        assert eventually(lambda: any("FAILSAFE: link still lost" in m for m in events(manager)), 30.0), \
            events(manager)
        assert eventually(lambda: "LAND" in emu.record.modes, 30.0)


def test_fresh_state_is_only_built_from_telemetry_received_after_the_call() -> None:
    with vehicle(config(fly_speed=1.0)) as (link, emu):
        emu.frozen = True
        assert eventually(lambda: link.link_age_now() > 2.0)  # what was sent before the freeze has been read
        assert link.fresh_state(time.monotonic(), 0.5) is None  # old samples do not count
        emu.frozen = False
        st = link.fresh_state(time.monotonic(), 5.0)
        assert st is not None and st.position_valid and st.autopilot_mode


def test_on_tcp_nothing_reaches_the_vehicle_late_after_a_block() -> None:
    """The issue's case: the TCP port blocked for 6 s while flying; the failsafe wants BRAKE and LAND.
    Nothing is written while the vehicle is silent, so no command arrives late; the console says what
    the vehicle really does once it is back (from fresh telemetry)."""
    import socket

    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    from console.link.mavlink import MavlinkLink
    from mav_emulator import ArduCopterEmulator

    emu = ArduCopterEmulator(0, url=f"tcpin:127.0.0.1:{port}").start()
    # nothing is written after min(pose_timeout, heartbeat_timeout) of silence: 2 s, above a loaded machine's
    # pauses (0.6 s seen with the helpers' 0.5 s) and below the failsafe's 3 s, so its BRAKE and LAND are held back
    link = MavlinkLink(f"tcp:127.0.0.1:{port}", config(fly_speed=1.0, pose_timeout=2.0,
                                                              heartbeat_timeout=2.0, **PATIENT))
    try:
        link.connect(timeout=20.0)
        assert eventually(lambda: link.latest_state() is not None and link.latest_state().health == "ok", 30.0)
        _airborne(link)
        manager = mission_manager(link, failsafe_after=FAILSAFE_AFTER, failsafe_hold=0.6)
        manager.start(_flight())
        assert eventually(lambda: emu.pos[0] > 1.0)
        emu.blocked = True
        assert manager.wait(30.0, until=[MissionStatus.FAILSAFE]) is MissionStatus.FAILSAFE
        assert eventually(lambda: any("FAILSAFE landing not" in m for m in events(manager)), 30.0), events(manager)
        time.sleep(max(0.0, 6.0 - 2.0))
        emu.blocked = False
        assert eventually(lambda: any("link restored after the failsafe" in m for m in events(manager)), 30.0), \
            events(manager)
        late = [(kind, round(d, 2)) for kind, d in emu.record.late_commands]
        commands = [d for kind, d in late if kind.startswith("COMMAND_LONG")]
        print(f"handled after the block: {late}; gated sends: {link.transport.gated}")
        assert link.transport.gated > 0
        assert commands == [], late  # no command reaches the vehicle late
        # targets sent before the silence showed (<= QUIET_S at 10 Hz): the target the vehicle already had
        assert len(late) <= 4, late
        assert "LAND" not in emu.record.modes and emu.mode == "GUIDED", emu.record.modes
        told = next(m for m in events(manager) if "link restored after the failsafe" in m)
        assert "autopilot mode GUIDED" in told and "in the air" in told, told
        manager.close()
    finally:
        link.close()
        emu.stop()
