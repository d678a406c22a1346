"""Mode authority: the vehicle's own mode changes (battery / GCS failsafe RTL or LAND, a fence's BRAKE,
a second ground station, the pilot's switch) end the console's control at once: no more targets, no
mode command, the mission paused naming the mode and the vehicle's reason; resume only after the
operator takes control; the console's LAND checks the mode first; flight above the workspace is warned."""

from __future__ import annotations

import time

import pytest
from pymavlink import mavutil

from console.link.base import LinkError, RunStatus
from console.link.manager import MissionStateError, MissionStatus
from mav_helpers import config, eventually, events, mission_manager, vehicle
from planner.mission import Mission, MissionSegment, SegmentKind

mav = mavutil.mavlink
TAKEOFF, FLY, LAND = SegmentKind.TAKEOFF, SegmentKind.FLY, SegmentKind.LAND
BOUNDS = dict(bounds_min=(0.0, 0.0, 0.0), bounds_max=(10.0, 12.0, 3.0))


def _airborne(link, height: float = 1.5) -> None:
    run = link.run_segment(MissionSegment(TAKEOFF, ((2.5, 0.7, 0.0), (2.5, 0.7, height))))
    assert run.wait(60.0) is RunStatus.DONE, run.error


def _flight(y: float = 9.0) -> Mission:
    return Mission((MissionSegment(FLY, ((2.5, 0.7, 1.5), (2.5, y, 1.5))),), **BOUNDS)


FAILSAFE_AFTER = 3.0
"""[s] far above a loaded machine's scheduling gaps: the link failsafe starts on the fault injected, never before."""
STEADY = dict(ack_timeout=1.0, command_max_age=10.0, pose_timeout=2.0, heartbeat_timeout=3.0)
"""Command and telemetry time-outs a loaded machine's pauses do not reach (none is under test here): an ACK
slower than 0.25 s x 3, or a 0.5 s pause in the position stream (resume reads the state sample: 'not heard
from'), is not a fault of the vehicle's."""


def _console_commands_after(emu, t0: float) -> tuple[int, list[str]]:
    """Position targets and console mode changes the vehicle handled after ``t0`` (monotonic [s])."""
    targets = sum(1 for t in emu.record.target_times if t > t0)
    modes = [m for (m, t), (_, by) in zip(emu.record.mode_times, emu.record.mode_sources) if t > t0 and by == "gcs"]
    return targets, modes


def _targets_sent_after_it_knew(link, emu) -> int:
    """Position targets the console sent after its link saw the vehicle's own mode (monotonic [s] of the
    heartbeat that said so). The vehicle dates each target by the last TIMESYNC it handled before it (sent
    after that one: one socket, read in order): waits for two TIMESYNCs sent from now on to be handled, so
    targets still streaming would be dated for about a second, whatever a loaded machine's delays."""
    knew = link.telemetry.authority.taken.time
    assert emu.flushed() and emu.flushed()
    return sum(1 for after in emu.record.target_sent_after if after > knew * 1e9)


def _pause_message(manager) -> str:
    """What the latest pause said (a later warning, e.g. the workspace's, replaces progress().message)."""
    evs = manager.events
    starts = [e for i, e in enumerate(evs) if e.progress.status is MissionStatus.PAUSED
              and (i == 0 or evs[i - 1].progress.status is not MissionStatus.PAUSED)]
    return starts[-1].message if starts else ""


def test_a_battery_failsafe_rtl_pauses_the_mission_naming_mode_and_reason_and_the_climb_is_warned() -> None:
    # the RTL descends home at 0.1 m/s (the console's DO_CHANGE_SPEED sets it too): still above the workspace at
    # the resume below, however long the checks take on a loaded machine
    with vehicle(config(fly_speed=1.0, descent_rate=0.1, **STEADY), fly_speed=2.0, accel=3.0, brake_decel=3.0,
                 descent_rate=0.1) as (link, emu):
        emu.params["RTL_ALT"] = 600.0  # 6 m, in a 3 m high workspace
        _airborne(link)
        manager = mission_manager(link, failsafe_after=FAILSAFE_AFTER, failsafe_hold=0.5)
        manager.start(_flight())
        assert eventually(lambda: emu.pos[0] > 1.0)
        emu.battery_failsafe("RTL")
        took = time.monotonic()
        assert manager.wait(30.0) is MissionStatus.PAUSED, events(manager)
        paused_after = time.monotonic() - took
        message = _pause_message(manager)
        assert "vehicle took control: mode RTL (Battery 1 is low 10.40V used 4200 mAh)" in message, message
        assert link.latest_state().vehicle_control.startswith("vehicle took control: mode RTL")
        # the vehicle flies its RTL: climbs to RTL_ALT above the workspace, warned
        assert eventually(lambda: any("outside the workspace (autopilot mode RTL)" in m for m in events(manager)),
                          30.0), events(manager)
        assert eventually(lambda: emu.record.max_height > 5.9, 30.0)
        targets = _targets_sent_after_it_knew(link, emu)
        _, modes = _console_commands_after(emu, took)
        print(f"paused {paused_after:.2f} s after the RTL; targets after: {targets}; console modes after: {modes}")
        assert targets == 0 and modes == [], (targets, modes)
        # resume is refused until the operator takes control; pause / abort send nothing
        with pytest.raises(MissionStateError, match="take control first"):
            manager.resume()
        question = manager.take_control()
        assert question.startswith("vehicle took control: mode RTL") and "Take control?" in question, question
        assert link.latest_state().vehicle_control  # asking is not taking
        _, modes = _console_commands_after(emu, took)
        assert modes == [] and emu.mode == "RTL"
        manager.take_control(confirm=True)
        manager.resume()  # from 6 m up, outside the workspace: the geofence refuses before any command
        assert manager.wait(30.0) is MissionStatus.PAUSED
        assert "outside the geofence" in _pause_message(manager), events(manager)
        assert emu.flushed()  # a mode command sent on resume would have reached the vehicle now
        _, modes = _console_commands_after(emu, took)
        assert modes == [], modes


def test_after_taking_control_resume_switches_back_to_guided_and_completes() -> None:
    with vehicle(config(fly_speed=1.0, **STEADY), fly_speed=2.0, accel=3.0, brake_decel=3.0, descent_rate=0.3) \
            as (link, emu):
        _airborne(link)
        manager = mission_manager(link, failsafe_after=FAILSAFE_AFTER, failsafe_hold=0.5)
        manager.start(_flight(4.0))
        assert eventually(lambda: emu.pos[0] > 1.0)
        emu.battery_failsafe("LAND")
        assert manager.wait(30.0) is MissionStatus.PAUSED, events(manager)
        assert "vehicle took control: mode LAND (Battery 1 is low" in _pause_message(manager), events(manager)
        with pytest.raises(MissionStateError, match="take control first"):
            manager.resume()
        assert emu.mode == "LAND"
        assert manager.take_control(confirm=True).startswith("control taken")
        manager.resume()
        assert eventually(lambda: emu.mode == "GUIDED", 20.0)  # only now the console switches back
        assert manager.wait(90.0) is MissionStatus.DONE, events(manager)


@pytest.mark.parametrize("change, mode, reason", [
    (lambda emu: emu.battery_failsafe("LAND"), "LAND", "Battery 1 is low"),
    (lambda emu: emu.gcs_failsafe(), "RTL", "GCS Failsafe"),
    (lambda emu: emu.fence_breach(), "BRAKE", "Fence Breached"),
    (lambda emu: emu.other_gcs_set_mode("LAND"), "LAND", "no reason given"),
    (lambda emu: emu.other_gcs_set_mode("LOITER"), "LOITER", "no reason given"),
    (lambda emu: emu.other_gcs_set_mode("SMART_RTL"), "SMART_RTL", "no reason given"),
])
def test_every_mode_the_vehicle_chooses_ends_the_consoles_control(change, mode, reason) -> None:
    with vehicle(config(fly_speed=1.0, **STEADY), fly_speed=2.0, accel=3.0, brake_decel=3.0) as (link, emu):
        _airborne(link)
        manager = mission_manager(link, failsafe_after=FAILSAFE_AFTER, failsafe_hold=0.5)
        manager.start(_flight())
        assert eventually(lambda: emu.pos[0] > 1.0)
        change(emu)
        took = time.monotonic()
        assert manager.wait(30.0) is MissionStatus.PAUSED, events(manager)
        assert f"vehicle took control: mode {mode} ({reason}" in _pause_message(manager), events(manager)
        targets = _targets_sent_after_it_knew(link, emu)
        _, modes = _console_commands_after(emu, took)
        assert targets == 0 and modes == [] and emu.mode == mode, (targets, modes, emu.mode)


def test_the_consoles_land_checks_the_mode_first() -> None:
    """An RTL that starts while the vehicle hovers over the landing spot is not replaced by a LAND."""
    with vehicle(config(fly_speed=1.0, **STEADY)) as (link, emu):
        _airborne(link)
        link.hold()  # BRAKE: the console's own mode
        emu.other_gcs_set_mode("RTL")
        assert eventually(lambda: link.vehicle_control.startswith("vehicle took control: mode RTL"))
        with pytest.raises(LinkError, match="vehicle took control: mode RTL"):
            link.run_segment(MissionSegment(LAND, ((2.5, 0.7, 1.5), (2.5, 0.7, 0.0))))
        with pytest.raises(LinkError, match="vehicle took control: mode RTL"):
            link.land_here()
        link.hold()  # sends nothing
        assert emu.flushed()  # what the console sent has reached the vehicle
        assert "LAND" not in emu.record.modes and emu.record.modes[-1] == "RTL", emu.record.modes


def test_the_consoles_own_mode_changes_are_not_a_takeover() -> None:
    """Neighbour: hold (BRAKE), resume (GUIDED), land (LAND): the console's modes never read as the vehicle's."""
    with vehicle(config(fly_speed=2.0, **STEADY)) as (link, emu):  # (the LAND confirms on a heartbeat: 3 s)
        manager = mission_manager(link, failsafe_after=FAILSAFE_AFTER, failsafe_hold=0.5)
        manager.start(Mission((MissionSegment(TAKEOFF, ((2.5, 0.7, 0.0), (2.5, 0.7, 1.5))),
                               MissionSegment(FLY, ((2.5, 0.7, 1.5), (2.5, 6.0, 1.5))),
                               MissionSegment(LAND, ((2.5, 6.0, 1.5), (2.5, 6.0, 0.0)))), **BOUNDS))
        assert eventually(lambda: emu.pos[0] > 1.0, 60.0)
        manager.pause()
        assert manager.wait(30.0) is MissionStatus.PAUSED
        manager.resume()
        assert manager.wait(90.0) is MissionStatus.DONE, events(manager)
        assert not any("took control" in m for m in events(manager)), events(manager)
        assert link.latest_state().vehicle_control == ""


def test_a_mode_the_vehicle_took_while_hovering_over_the_landing_spot_is_not_replaced_by_the_consoles_land() -> None:
    """The issue's case (an RTL replaced by the console's LAND 0.45 s later), with ArduPilot's 1 Hz heartbeat
    and a mode that keeps the vehicle still (the pilot's LOITER; an RTL climbs, so the console never sees
    the vehicle still and never decides LAND): the mode changes right after a heartbeat, as the vehicle
    settles over the spot; the console's LAND waits for a heartbeat received after it decided, sees
    LOITER and sends nothing."""
    with vehicle(config(fly_speed=1.0, heartbeat_timeout=3.0), heartbeat_rate=1.0) as (link, emu):
        manager = mission_manager(link, failsafe_after=3.0, failsafe_hold=0.5)
        manager.start(Mission((MissionSegment(TAKEOFF, ((2.5, 0.7, 0.0), (2.5, 0.7, 1.5))),
                               MissionSegment(FLY, ((2.5, 0.7, 1.5), (2.5, 2.7, 1.5))),
                               MissionSegment(LAND, ((2.5, 2.7, 1.5), (2.5, 2.7, 0.0)))), **BOUNDS))
        spot = (2.0, 0.0)  # NED of world (2.5, 2.7)
        switched: list[float] = []

        def loiter_right_after_a_heartbeat() -> None:  # the next heartbeat, 1 s later, is the first to say so
            if not switched and emu.mode == "GUIDED" and manager.progress().segment == 2 \
                    and abs(emu.pos[0] - spot[0]) < 0.3:
                switched.append(time.monotonic())
                emu.other_gcs_set_mode("LOITER")

        emu.after_heartbeat = loiter_right_after_a_heartbeat
        assert eventually(lambda: bool(switched), 90.0), (emu.pos, events(manager))
        took = switched[0]
        assert manager.wait(30.0) is MissionStatus.PAUSED, events(manager)
        assert "vehicle took control: mode LOITER" in _pause_message(manager), events(manager)
        _, modes = _console_commands_after(emu, took)
        assert "LAND" not in modes and emu.mode == "LOITER", (modes, emu.record.mode_sources)


def test_mode_authority_rules() -> None:
    """The rules without a vehicle: what counts as the console's own mode and what is a takeover."""
    from console.link.mavlink_authority import ModeAuthority, VehicleInControl

    lines: list[tuple[float, int, str]] = []
    a = ModeAuthority(lambda: lines)
    assert a.observe("STABILIZE") is None  # no claim yet: the vehicle's modes are its own
    a.commanding("GUIDED")
    a.commanded("GUIDED", True)
    assert a.observe("STABILIZE") is None  # a heartbeat from before our change
    assert a.observe("GUIDED") is None and a.confirmed
    a.commanding("BRAKE")
    a.commanded("BRAKE", True)  # accepted; heartbeats still say GUIDED for a moment
    assert a.observe("GUIDED") is None
    lines.append((time.monotonic(), 2, "CRITICAL: Fence Breached"))
    assert a.observe("RTL") is not None  # neither ours nor the one before: a takeover at once
    assert a.describe() == "vehicle took control: mode RTL (Fence Breached)"
    with pytest.raises(VehicleInControl, match="LAND not sent: vehicle took control: mode RTL"):
        a.check("LAND")
    a.take_control()
    assert a.describe() == "" and a.expected is None
    # our own command whose ACK was lost is still ours when it shows up
    a.commanding("GUIDED")
    a.commanded("GUIDED", True)
    a.observe("GUIDED")
    a.commanding("LAND")
    a.commanded("LAND", False)
    assert a.observe("LAND") is None and a.expected == "LAND"
    lines.clear()
    assert a.observe("LOITER") is not None and "no reason given" in a.describe()


def test_a_link_loss_while_the_vehicle_flies_its_own_mode_sends_nothing() -> None:
    """The vehicle took control (LAND by a battery failsafe), then the link is lost: the console's
    failsafe neither holds nor lands it (no BRAKE over the vehicle's own LAND)."""
    with vehicle(config(fly_speed=1.0, **STEADY), descent_rate=0.2) as (link, emu):
        _airborne(link)
        manager = mission_manager(link, failsafe_after=FAILSAFE_AFTER, failsafe_hold=0.5)
        manager.start(_flight())
        assert eventually(lambda: emu.pos[0] > 1.0)
        emu.battery_failsafe("LAND")
        took = time.monotonic()
        assert manager.wait(30.0) is MissionStatus.PAUSED, events(manager)
        emu.heartbeat_enabled = emu.telemetry_enabled = False  # the link goes silent (the vehicle still lands)
        assert eventually(lambda: any(m.startswith("FAILSAFE") for m in events(manager)), 30.0), events(manager)
        said = next(m for m in events(manager) if m.startswith("FAILSAFE"))
        assert "vehicle took control: mode LAND (Battery 1 is low" in said and "the console sends nothing" in said, said
        time.sleep(1.5)
        emu.heartbeat_enabled = emu.telemetry_enabled = True
        assert eventually(lambda: link.link_age_now() < 1.0)  # heard again
        assert emu.flushed()  # whatever the console sent until now has reached the vehicle
        _, modes = _console_commands_after(emu, took)
        assert modes == [] and emu.mode == "LAND", (modes, emu.mode)
