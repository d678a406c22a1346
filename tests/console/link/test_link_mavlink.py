"""The MAVLink link against an ArduPilot-like emulator over real UDP on 127.0.0.1."""

from __future__ import annotations

from dataclasses import replace

import math
import time
from typing import Iterator

import numpy as np
import pytest
from pymavlink import mavutil

from console.link import LinkError, LinkTimeout, open_link
from console.link.base import Mode, RunStatus
from console.link.manager import MissionManager, MissionStateError, MissionStatus
from console.link.mavlink import (POSITION_ONLY_MASK, POSITION_YAW_MASK, VELOCITY_ONLY_MASK, GroundMotion,
                                  MavlinkConfig, MavlinkLink, copter_modes, parse_connection)
from console.link.ned import NedFrame
from mav_emulator import ArduCopterEmulator
from planner.mission import Mission, MissionSegment, SegmentKind

mav = mavutil.mavlink
WALK, TAKEOFF, FLY, LAND = SegmentKind.WALK, SegmentKind.TAKEOFF, SegmentKind.FLY, SegmentKind.LAND
ORIGIN = (2.5, 0.7, 0.0)  # world position of the vehicle's NED origin (where it starts)
CFG = MavlinkConfig(ned=NedFrame(origin=ORIGIN), ack_timeout=0.25, retries=4, heartbeat_timeout=1.0,
                    setpoint_rate=10.0, fly_speed=4.0, climb_rate=3.0, descent_rate=3.0, timeout_slack=5.0,
                    ground=GroundMotion(speed=2.0))


def _mission() -> Mission:
    return Mission((
        MissionSegment(WALK, ((2.5, 0.7, 0.0), (2.5, 1.8, 0.0), (2.8, 2.9, 0.0))),
        MissionSegment(TAKEOFF, ((2.8, 2.9, 0.0), (2.8, 2.9, 1.875))),
        MissionSegment(FLY, ((2.8, 2.9, 1.875), (2.5, 4.0, 1.875), (2.5, 5.0, 1.875))),
        MissionSegment(LAND, ((2.5, 5.0, 1.875), (2.5, 5.0, 0.0))),
        MissionSegment(WALK, ((2.5, 5.0, 0.0), (2.5, 5.7, 0.0))),
    ))


@pytest.fixture
def vehicle(request: pytest.FixtureRequest) -> Iterator[tuple[MavlinkLink, ArduCopterEmulator]]:
    opts = dict(getattr(request, "param", {}))
    cfg = opts.pop("config", CFG)
    link = MavlinkLink("udpin:127.0.0.1:0", cfg)  # port 0: a free port, so tests run in parallel
    link.open()
    emu = ArduCopterEmulator(link.local_port, **opts)
    emu.start()
    try:
        link.connect(timeout=20.0)
        deadline = time.monotonic() + 30.0
        while (link.latest_state() is None or link.latest_state().health != "ok") and time.monotonic() < deadline:
            time.sleep(0.02)
        yield link, emu
    finally:
        link.close()
        emu.stop()


def _events(manager: MissionManager) -> list[str]:
    return [e.message for e in manager.events]


# --- frames and constants -------------------------------------------------------------------------


def test_world_ned_round_trip_and_axes() -> None:
    f = NedFrame()  # world +y = north, +x = east, +z = up
    assert f.to_ned((1.0, 2.0, 3.0)) == pytest.approx((2.0, 1.0, -3.0))
    assert f.yaw_to_ned(math.pi / 2) == pytest.approx(0.0)  # facing world +y = facing north
    assert f.yaw_to_ned(0.0) == pytest.approx(math.pi / 2)  # facing +x = east, 90 deg clockwise
    g = NedFrame(origin=(1.0, -2.0, 0.5), north_yaw=math.radians(30))
    rng = np.random.default_rng(3)
    for p in rng.uniform(-10, 10, size=(20, 3)):
        assert g.to_world(g.to_ned(p)) == pytest.approx(tuple(p), abs=1e-9)
        assert g.velocity_to_world(g.velocity_to_ned(p)) == pytest.approx(tuple(p), abs=1e-9)
    for yaw in rng.uniform(-math.pi, math.pi, size=10):
        assert math.cos(g.yaw_to_world(g.yaw_to_ned(yaw)) - yaw) == pytest.approx(1.0)
    # north is where north_yaw points; moving north by 1 m moves (cos 30, sin 30) in the world
    assert np.subtract(g.to_world((1.0, 0.0, 0.0)), g.origin) == pytest.approx((math.cos(math.radians(30)),
                                                                                 math.sin(math.radians(30)), 0.0))
    # NED is right-handed: north x east = down
    n = np.subtract(g.to_world((1, 0, 0)), g.origin)
    e = np.subtract(g.to_world((0, 1, 0)), g.origin)
    d = np.subtract(g.to_world((0, 0, 1)), g.origin)
    assert np.cross(n, e) == pytest.approx(d)
    assert g.altitude(2.0) == pytest.approx(1.5)


def test_type_masks_and_copter_modes_follow_ardupilot() -> None:
    ign = {k: getattr(mav, f"POSITION_TARGET_TYPEMASK_{k}_IGNORE") for k in
           ("X", "Y", "Z", "VX", "VY", "VZ", "AX", "AY", "AZ", "YAW", "YAW_RATE")}
    vel_acc = ign["VX"] | ign["VY"] | ign["VZ"] | ign["AX"] | ign["AY"] | ign["AZ"]
    assert POSITION_ONLY_MASK == vel_acc | ign["YAW"] | ign["YAW_RATE"]
    assert POSITION_YAW_MASK == vel_acc | ign["YAW_RATE"]
    assert VELOCITY_ONLY_MASK == ign["X"] | ign["Y"] | ign["Z"] | ign["AX"] | ign["AY"] | ign["AZ"] | ign["YAW_RATE"]
    modes = copter_modes()
    assert (modes["GUIDED"], modes["LOITER"], modes["LAND"], modes["BRAKE"]) == (4, 5, 9, 17)
    with pytest.raises(ValueError, match="unknown ArduPilot Copter mode"):
        MavlinkConfig(hold_mode="HOVER")


def test_connection_strings() -> None:
    assert parse_connection("udpin:0.0.0.0:14550") == ("udpin:0.0.0.0:14550", None)
    assert parse_connection("tcp:127.0.0.1:5760") == ("tcp:127.0.0.1:5760", None)
    assert parse_connection("/dev/ttyACM0,57600") == ("/dev/ttyACM0", 57600)
    assert parse_connection("/dev/ttyUSB1") == ("/dev/ttyUSB1", None)
    for bad in ("", "udp:localhost", "udpin:1.2.3.4:70000", "http://x:1", "/dev/ttyACM0,fast", "ttyACM0"):
        with pytest.raises(LinkError):
            parse_connection(bad)


def test_connect_times_out_without_a_vehicle() -> None:
    link = MavlinkLink("udpin:127.0.0.1:0", CFG)
    t0 = time.monotonic()
    with pytest.raises(LinkTimeout, match="no heartbeat"):
        link.connect(timeout=0.4)
    assert time.monotonic() - t0 < 4.0  # the 0.4 s time-out is kept (+ scheduling on a loaded machine)
    assert not link.connected


# --- telemetry -----------------------------------------------------------------------------------


@pytest.mark.parametrize("vehicle", [{"start_ned": (1.0, 2.0, 0.0)}], indirect=True)
def test_state_stream_converts_ned_telemetry_to_the_world_frame(vehicle) -> None:
    link, emu = vehicle
    with emu.lock:
        emu.yaw = 0.5  # 0.5 rad clockwise from north
    assert _eventually(lambda: link.latest_state().yaw == pytest.approx(math.pi / 2 - 0.5, abs=1e-4))
    states = []
    unsubscribe = link.subscribe(states.append)
    t0 = time.monotonic()
    assert _eventually(lambda: len(states) >= 20)
    took = time.monotonic() - t0
    unsubscribe()
    assert took < 3.0, took  # 20 states in ~1 s at 20 Hz; a loaded machine may stall the sampler a while
    st = states[-1]
    # north 1 m -> world +y, east 2 m -> world +x, from the origin
    assert st.position == pytest.approx((ORIGIN[0] + 2.0, ORIGIN[1] + 1.0, 0.0), abs=1e-4)
    assert st.yaw == pytest.approx(math.pi / 2 - 0.5, abs=1e-4)
    assert st.landed and not st.armed and st.mode is Mode.IDLE
    assert st.autopilot_mode == "STABILIZE" and st.link_ok and st.health == "ok"
    assert st.battery == pytest.approx(1.0, abs=0.02) and st.battery_voltage == pytest.approx(15.8)
    assert emu.record.gcs_heartbeats >= 1  # our GCS heartbeat reaches the vehicle


# --- missions ------------------------------------------------------------------------------------


def test_full_walk_takeoff_fly_land_walk_mission(vehicle) -> None:
    link, emu = vehicle
    manager = MissionManager(link, failsafe_after=1.5, failsafe_hold=0.5)
    fractions: list[float] = []
    manager.subscribe(lambda e: fractions.append(e.progress.fraction))
    t0 = time.monotonic()
    manager.start(_mission())
    assert manager.wait(60.0) is MissionStatus.DONE, _events(manager)
    elapsed = time.monotonic() - t0
    # the last walking target stays set: the robot closes the final tolerance gap
    assert _eventually(lambda: link.latest_state().position == pytest.approx((2.5, 5.7, 0.0), abs=0.05))
    st = link.latest_state()
    assert st.landed and not st.armed
    # ArduPilot conventions on the wire
    assert emu.record.modes[0] == "GUIDED" and "LAND" in emu.record.modes
    assert emu.record.takeoff_altitudes == [pytest.approx(1.875)]
    arm = [c for c in emu.record.commands if c[0] == mav.MAV_CMD_COMPONENT_ARM_DISARM]
    assert arm and arm[0][2] == mav.MAV_RESULT_ACCEPTED
    walk_targets = [t for t in emu.record.targets if abs(t[2]) < 1e-6]
    air_targets = [t for t in emu.record.targets if t[2] < -1.0]
    assert walk_targets and air_targets
    assert all(t[3] in (POSITION_YAW_MASK, POSITION_ONLY_MASK) for t in emu.record.targets)  # yaw: travel direction
    # while travelling the yaw follows the path; hovering still over the landing spot (world (2.5, 5.0) = NED
    # north 4.3, east 0) before LAND the vehicle keeps its yaw (position only)
    travel = [t for t in emu.record.targets if not (math.dist(t[:2], (4.3, 0.0)) < 0.2 and t[2] < -1.0)]
    assert sum(t[3] == POSITION_YAW_MASK for t in travel) > 0.8 * len(travel)
    # the first walking target enters position control where the robot stands (then the speed is sent:
    # ArduCopter resets it on that entry); the next is world (2.5, 1.8), 1.1 m north of the origin
    assert walk_targets[0][:2] == pytest.approx((0.0, 0.0), abs=0.05)
    assert walk_targets[1][:2] == pytest.approx((1.1, 0.0), abs=1e-4)
    # the flight height; a segment starts where the robot is, which may be the take-off's overshoot (a few cm)
    heights = [t[2] for t in air_targets]
    assert sum(h == pytest.approx(-1.875, abs=1e-3) for h in heights) > 0.8 * len(heights), heights
    assert min(heights) > -1.875 - 0.15, heights
    # progress only grows and reaches 1; the console heard about control switches
    assert fractions == sorted(fractions) and fractions[-1] == 1.0
    msgs = _events(manager)
    assert msgs.count("switching to flight control") == 1 and msgs.count("switching to ground control") == 2
    # GCS heartbeat at 1 Hz (each wait of 1 s may wake up to 0.25 s late on a loaded machine: the count drifts low)
    assert elapsed / 1.25 - 1.5 <= emu.record.gcs_heartbeats <= elapsed + 3, (elapsed, emu.record.gcs_heartbeats)


@pytest.mark.parametrize("vehicle", [{"config": replace(CFG, fly_speed=1.0)}], indirect=True)  # a long flight
def test_heartbeat_loss_triggers_the_failsafe_and_keeps_the_mission(vehicle) -> None:
    link, emu = vehicle
    manager = MissionManager(link, failsafe_after=1.5, failsafe_hold=0.4)
    manager.start(_mission())
    assert _eventually(lambda: manager.progress().kind is FLY, 60.0), _events(manager)
    time.sleep(0.1)
    emu.heartbeat_enabled = False
    silenced = time.monotonic()
    assert manager.wait(30.0) is MissionStatus.FAILSAFE
    took = time.monotonic() - silenced
    assert took > 1.2  # not before failsafe_after (1.5 s); how much later depends on the machine's load
    assert _eventually(lambda: emu.landed_state == mav.MAV_LANDED_STATE_ON_GROUND)
    assert _eventually(lambda: any("FAILSAFE: landed" in m for m in _events(manager))), _events(manager)
    assert _eventually(lambda: link.latest_state().landed)
    msgs = _events(manager)
    assert any(m.startswith("FAILSAFE: robot not heard for") and "no heartbeat" in m for m in msgs)
    assert any("landing" in m for m in msgs) and any("FAILSAFE: landed" in m for m in msgs)
    assert emu.record.mode_changes[-2:] == ["BRAKE", "LAND"]  # hold, then land
    # the mission is kept: same mission, the interrupted segment, and the last known state
    p = manager.progress()
    assert p.status is MissionStatus.FAILSAFE and p.segment == 2 and p.mission_id == manager.mission.id
    st = link.latest_state()
    assert not st.link_ok and "no heartbeat" in st.health and st.landed
    with pytest.raises(MissionStateError, match="not heard"):
        manager.resume()
    # the link comes back: resume takes off again where it landed and finishes the mission
    emu.heartbeat_enabled = True
    assert _eventually(lambda: link.latest_state().link_ok and link.link_age_now() < 1.0)
    manager.resume()
    assert manager.wait(60.0) is MissionStatus.DONE, _events(manager)
    assert _eventually(lambda: link.latest_state().position == pytest.approx((2.5, 5.7, 0.0), abs=0.05))
    assert len(emu.record.takeoff_altitudes) == 2


# A lossy radio is configured with more re-sends: a command + ACK round trip fails 36 % of the
# time at 20 % loss each way, so 5 attempts still fail once in ~170 commands; 13 in ~600,000.
# The mission's LAND waits for a heartbeat received after it decided (heartbeats at 5 Hz, 20 % lost): its
# time-out only has to be later than the next one, and is 3 s so a loaded machine's pauses do not end it;
# the failsafe (3 s) is far above those pauses, and the motion time-outs get 30 s of slack (a lossy link on a
# loaded machine spends seconds with no fresh position; no time-out is under test here).
@pytest.mark.parametrize("vehicle", [{"drop": 0.2, "seed": 7, "config": replace(CFG, retries=12, heartbeat_timeout=3.0,
                                                                              timeout_slack=30.0)}], indirect=True)
def test_mission_completes_with_20_percent_packet_loss(vehicle) -> None:
    link, emu = vehicle
    manager = MissionManager(link, failsafe_after=3.0, failsafe_hold=0.5)
    manager.start(_mission())
    assert manager.wait(90.0) is MissionStatus.DONE, _events(manager)
    assert _eventually(lambda: link.latest_state().position == pytest.approx((2.5, 5.7, 0.0), abs=0.1))
    assert emu.record.dropped_in > 0 and emu.record.dropped_out > 20


def test_a_refused_mode_change_pauses_the_mission_with_a_clear_error(vehicle) -> None:
    link, emu = vehicle
    emu.deny_modes["LAND"] = 1
    manager = MissionManager(link, failsafe_after=1.5, failsafe_hold=0.5)
    manager.start(_mission())
    assert manager.wait(60.0) is MissionStatus.PAUSED
    p = manager.progress()
    assert p.segment == 3 and p.kind is LAND and p.mission_id == manager.mission.id
    assert "mode change to LAND rejected by the vehicle: MAV_RESULT_DENIED" in p.message
    assert link.stats["nacks"] == 1
    assert not link.latest_state().landed  # still hovering above the spot, not lost
    manager.resume()
    assert manager.wait(60.0) is MissionStatus.DONE, _events(manager)
    assert _eventually(lambda: link.latest_state().position == pytest.approx((2.5, 5.7, 0.0), abs=0.05))


def test_unanswered_commands_are_retried_then_reported(vehicle) -> None:
    link, emu = vehicle
    emu.ignore_commands.add(mav.MAV_CMD_COMPONENT_ARM_DISARM)
    run = link.run_segment(MissionSegment(TAKEOFF, ((2.5, 0.7, 0.0), (2.5, 0.7, 1.5))))
    assert run.wait(30.0) is RunStatus.FAILED
    assert "arming: no COMMAND_ACK from the vehicle after 5 attempt(s)" in run.error
    confirmations = [c for cmd, c in emu.record.received if cmd == mav.MAV_CMD_COMPONENT_ARM_DISARM]
    assert confirmations == [0, 1, 2, 3, 4]


def test_hold_brakes_in_the_air(vehicle) -> None:
    link, emu = vehicle
    assert link.run_segment(MissionSegment(TAKEOFF, ((2.5, 0.7, 0.0), (2.5, 0.7, 1.5)))).wait(30) is RunStatus.DONE
    run = link.run_segment(MissionSegment(FLY, ((2.5, 0.7, 1.5), (2.5, 7.0, 1.5))))
    assert _eventually(lambda: emu.pos[0] > 0.3)  # flying north (world +y), well short of the goal
    link.hold()
    held_at = time.time()
    assert run.status is RunStatus.HELD
    assert emu.mode == "BRAKE"
    # state samples taken after the hold returned (a loaded machine may delay the sampler): it stays put
    assert _eventually(lambda: link.latest_state().time > held_at + 0.1)
    y = link.latest_state().position[1]
    assert _eventually(lambda: link.latest_state().time > held_at + 0.5)
    assert link.latest_state().position[1] == pytest.approx(y, abs=1e-3) and 0.9 < y < 6.5
    assert link.latest_state().mode is Mode.HOLDING


def test_open_link_reaches_a_vehicle_by_spec() -> None:
    from mav_emulator import free_udp_port

    port = free_udp_port()
    emu = ArduCopterEmulator(port).start()
    try:
        link = open_link(f"mavlink:udpin:127.0.0.1:{port}", timeout=5.0, config=CFG)
        try:
            assert isinstance(link, MavlinkLink) and link.connected
            assert "127.0.0.1" in link.description
            assert _eventually(lambda: link.latest_state() is not None)
            with pytest.raises(LinkError, match="no camera"):
                link.capture()
        finally:
            link.close()
    finally:
        emu.stop()


def test_a_failed_prearm_check_is_reported_with_the_vehicles_reason(vehicle) -> None:
    """ArduPilot refuses arming with MAV_RESULT_FAILED after a STATUSTEXT naming the failed check:
    the operator gets both, and the message also reaches the state stream."""
    link, emu = vehicle
    emu.prearm_failure = "Need 3D Fix"
    manager = MissionManager(link, failsafe_after=1.5, failsafe_hold=0.5)
    manager.start(Mission((MissionSegment(TAKEOFF, ((2.5, 0.7, 0.0), (2.5, 0.7, 1.5))),)))
    assert manager.wait(60.0) is MissionStatus.PAUSED
    message = manager.progress().message
    assert "arming rejected by the vehicle: MAV_RESULT_FAILED (vehicle says: CRITICAL: PreArm: Need 3D Fix)" \
        in message, message
    assert _eventually(lambda: [t for _, t in link.latest_state().messages] == ["CRITICAL: PreArm: Need 3D Fix"])
    emu.prearm_failure = None  # the fix came: resume arms and takes off
    emu.say("EKF3 IMU0 is using GPS")
    manager.resume()
    assert manager.wait(60.0) is MissionStatus.DONE, _events(manager)
    assert _eventually(lambda: link.latest_state().messages[-1] == (2, "INFO: EKF3 IMU0 is using GPS"))
    assert [n for n, _ in link.latest_state().messages] == [1, 2]


def _eventually(check, timeout: float = 30.0) -> bool:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if check():
            return True
        time.sleep(0.02)
    return check()
