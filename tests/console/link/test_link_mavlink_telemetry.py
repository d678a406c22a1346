"""MAVLink telemetry you can trust, each fault injected into the ArduCopter emulator over UDP:
validation (NaN / inf / implausible fields), unknown position, staleness, reboot, stream requests
refused, vehicle identity (gimbal / camera first, system ids), readiness, the .tlog."""

from __future__ import annotations

import math
import socket
import time

import pytest
from pymavlink import mavutil

from console.link.base import Mode, RunStatus
from console.link.manager import MissionStatus
from console.link.mavlink import MavlinkLink
from mav_emulator import ArduCopterEmulator
from mav_helpers import ORIGIN, config, eventually, events, mission_manager, vehicle
from planner.mission import Mission, MissionSegment, SegmentKind

mav = mavutil.mavlink
WALK, TAKEOFF, FLY, LAND = SegmentKind.WALK, SegmentKind.TAKEOFF, SegmentKind.FLY, SegmentKind.LAND
NAN, INF = float("nan"), float("inf")
FAILSAFE_AFTER = 3.0
"""[s] far above a loaded machine's scheduling gaps: the failsafe starts on the fault injected, never before."""
PATIENT = dict(ack_timeout=1.0, command_max_age=10.0)
"""For the tests not about command time-outs: an ACK slower than the helpers' 0.25 s x 3 within 2 s (a loaded
machine) is not a refusal."""


def _walk_mission() -> Mission:
    return Mission((MissionSegment(WALK, ((2.5, 0.7, 0.0), (2.5, 2.5, 0.0), (2.5, 4.0, 0.0))),))


def _finite(p) -> bool:
    return all(math.isfinite(c) for c in p)


# --- 1. invalid values ---------------------------------------------------------------------------


def test_nan_position_is_dropped_the_pose_goes_stale_and_the_walk_stops() -> None:
    """Fault 1: LOCAL_POSITION_NED x = y = NaN mid-walk. The NaN never becomes the pose, the health
    says why, the manager treats the stale pose as link loss and the robot is stopped."""
    with vehicle(config(ground=replace_ground(0.5), **PATIENT), walk_speed=0.5) as (link, emu):
        manager = mission_manager(link, failsafe_after=FAILSAFE_AFTER, failsafe_hold=0.4)
        manager.start(_walk_mission())
        assert eventually(lambda: link.latest_state().position[1] > ORIGIN[1] + 0.3)
        emu.corrupt = {"x": NAN, "y": NAN}
        assert manager.wait(30.0, until=[MissionStatus.FAILSAFE]) is MissionStatus.FAILSAFE, events(manager)
        # the failsafe reads the live age; the stored state sample says 'stale' at its next sample
        assert eventually(lambda: link.latest_state().health.startswith("stale: no valid position for")), \
            link.latest_state().health
        st = link.latest_state()
        assert not st.link_ok and not st.position_valid and _finite(st.position)
        assert st.health.startswith("stale: no valid position for") and "LOCAL_POSITION_NED.x: not finite" in st.health
        assert link.stats["invalid"] > 5
        assert eventually(lambda: any("robot is on the ground; the mission is kept" in m for m in events(manager)))
        assert any(m.startswith("FAILSAFE: robot not heard for") and "stale" in m for m in events(manager))
        assert all(_finite(t[:3]) for t in emu.record.targets)  # nothing computed from the NaN was sent
        assert eventually(lambda: math.hypot(*emu.vel[:2]) < 1e-6)  # stopped by the hold (zero velocity)
        stopped_at = list(emu.pos)
        emu.corrupt = {}
        assert eventually(lambda: link.latest_state().health == "ok")
        assert link.latest_state().position[1] == pytest.approx(ORIGIN[1] + stopped_at[0], abs=0.02)
        manager.resume()
        assert manager.wait(60.0) is MissionStatus.DONE, events(manager)
        assert eventually(lambda: link.latest_state().position == pytest.approx((2.5, 4.0, 0.0), abs=0.05))
        assert any("link restored after the failsafe: the robot is idle, autopilot mode GUIDED, on the ground at"
                   in m for m in events(manager)), events(manager)


def replace_ground(speed: float):
    from console.link.mavlink import GroundMotion

    return GroundMotion(speed=speed)


@pytest.mark.parametrize("fault, field", [({"z": INF}, "LOCAL_POSITION_NED.z: not finite"),
                                          ({"vx": NAN}, "LOCAL_POSITION_NED.vx: not finite"),
                                          ({"y": 1e7}, "LOCAL_POSITION_NED.y: implausible"),
                                          ({"yaw": NAN}, "ATTITUDE.yaw: not finite")])
def test_other_non_finite_or_implausible_fields_are_dropped_and_named(fault, field) -> None:
    with vehicle(start_ned=(1.0, 2.0, 0.0)) as (link, emu):
        with emu.lock:
            emu.yaw = 0.5
        assert eventually(lambda: link.latest_state().yaw == pytest.approx(math.pi / 2 - 0.5, abs=1e-4))
        emu.corrupt = fault
        assert eventually(lambda: field in link.latest_state().health), link.latest_state().health
        st = link.latest_state()
        assert _finite(st.position) and _finite(st.velocity) and math.isfinite(st.yaw)
        assert st.position == pytest.approx((ORIGIN[0] + 2.0, ORIGIN[1] + 1.0, 0.0), abs=1e-4)
        assert st.yaw == pytest.approx(math.pi / 2 - 0.5, abs=1e-4)
        assert link.stats["invalid"] > 0
        if "ATTITUDE" in field:  # the position stream is fine: the pose stays valid and the link ok
            assert st.position_valid and st.link_ok and st.health.startswith("invalid telemetry dropped")
        else:
            assert eventually(lambda: not link.latest_state().position_valid and not link.latest_state().link_ok)
        emu.corrupt = {}
        assert eventually(lambda: link.latest_state().health == "ok")


def test_before_the_first_position_the_pose_is_unknown_not_the_origin() -> None:
    """Fault 10 (display part): before the EKF has a position the state says so."""
    with vehicle(faults={"ekf_ready": False}, wait_ok=False) as (link, emu):
        assert eventually(lambda: link.latest_state() is not None and "PreArm" in link.latest_state().readiness)
        st = link.latest_state()
        assert not st.position_valid and st.link_ok and not st.ready and _finite(st.position)
        assert st.health == "position unknown: no LOCAL_POSITION_NED yet (no position estimate?)"
        assert "no position estimate yet" in st.readiness and "EKF has no horizontal position" in st.readiness
        assert "pre-arm checks failing (PreArm: Need Position Estimate)" in st.readiness
        with pytest.raises(Exception, match="position is not known|no camera"):
            link.capture()


# --- 2. staleness and reboots --------------------------------------------------------------------


def test_telemetry_stopping_without_a_heartbeat_gap_is_link_loss() -> None:
    """Fault 2, neighbour: the streams stop, heartbeats go on. Health 'stale', failsafe: hold, then
    land where the robot is (no flight anywhere)."""
    with vehicle(config(**PATIENT)) as (link, emu):
        assert link.run_segment(MissionSegment(TAKEOFF, ((2.5, 0.7, 0.0), (2.5, 0.7, 1.5)))).wait(30) is RunStatus.DONE
        manager = mission_manager(link, failsafe_after=FAILSAFE_AFTER, failsafe_hold=0.5)
        manager.start(Mission((MissionSegment(FLY, ((2.5, 0.7, 1.5), (2.5, 9.0, 1.5))),),
                              bounds_max=(10.0, 10.0, 3.0)))
        assert eventually(lambda: link.latest_state().position[1] > 2.0)
        emu.telemetry_enabled = False
        # stale while the heartbeats still arrive (5 Hz: a recent one in some sample)
        assert eventually(lambda: link.latest_state().health.startswith("stale") and link.latest_state().link_age < 0.5), \
            link.latest_state()
        assert manager.wait(30.0, until=[MissionStatus.FAILSAFE]) is MissionStatus.FAILSAFE
        assert eventually(lambda: emu.mode == "LAND"), events(manager)
        changes = emu.record.mode_changes
        i = changes.index("BRAKE", 1)
        assert changes[i:] == ["BRAKE", "LAND"]  # hold, then land: never back to GUIDED
        assert eventually(lambda: emu.landed_state == mav.MAV_LANDED_STATE_ON_GROUND)
        emu.telemetry_enabled = True
        assert eventually(lambda: any("link restored after the failsafe" in m and "on the ground" in m
                                      for m in events(manager))), events(manager)
        assert manager.progress().status is MissionStatus.FAILSAFE


@pytest.mark.parametrize("silence", [0.4, 1.6])  # shorter than the heartbeat time-out, and longer
def test_a_reboot_is_detected_streams_come_back_and_the_origin_change_is_warned(silence, caplog) -> None:
    """Fault 2: the vehicle reboots mid-walk, forgets the stream rates and sets a new EKF origin
    where it stands. The link asks for the streams again, re-reads the origin and warns; the
    mission pauses with the reason."""
    with vehicle(config(ground=replace_ground(0.5)), walk_speed=0.5, reboot_silence=silence,
                 faults={"streams_need_request": True}) as (link, emu):
        manager = mission_manager(link, failsafe_after=3.0, failsafe_hold=0.5)
        manager.start(_walk_mission())
        assert eventually(lambda: link.latest_state().position[1] > ORIGIN[1] + 0.8)
        requests = len(emu.record.intervals)
        with emu.lock:  # the new origin is where it stands at the reboot
            moved = math.hypot(emu.pos[0], emu.pos[1])
            emu.reboot()
        assert manager.wait(30.0, until=[MissionStatus.PAUSED]) is MissionStatus.PAUSED, events(manager)
        assert eventually(lambda: len(emu.record.intervals) > requests), emu.record.intervals  # streams asked again
        assert eventually(lambda: link.latest_state().health == "ok" and link.latest_state().link_epoch >= 1), \
            link.latest_state()
        assert eventually(lambda: any("EKF origin moved" in w for w in link.latest_state().warnings))
        warning = next(w for w in link.latest_state().warnings if "EKF origin moved" in w)
        # said to 0.1 m (+-0.05) of an origin sent in 1e-7 degrees (+-0.011 m a side): 0.848 m reads "0.9 m"
        assert float(warning.split("moved ")[1].split(" m")[0]) == pytest.approx(moved, abs=0.07), warning
        message = manager.progress().message
        assert "walk: the robot reconnected or rebooted" in message and "robot held, mission paused" in message
        # a long silence is seen twice (the heartbeat gap, then time_boot_ms going back; a loaded machine can
        # stretch a short one past the heartbeat time-out too): the pause names whichever the manager heard
        # of last, which depends on scheduling; the link logged each
        whys = ("time_boot_ms went back", "heartbeat back after")
        assert any(f"vehicle rebooted ({w}" in message or f"vehicle {w}" in message for w in whys), message
        logged = [r.getMessage() for r in caplog.records]
        assert any("time_boot_ms went back" in m for m in logged), logged
        if silence >= 1.0:
            assert any("heartbeat back after" in m for m in logged), logged
        # the twin now shows the new-origin pose: at the NED origin again, and the operator was told
        assert eventually(lambda: link.latest_state().position[:2] == pytest.approx(ORIGIN[:2], abs=0.05)), \
            link.latest_state().position


def test_a_tcp_reconnect_is_detected_and_the_streams_are_asked_for_again() -> None:
    """Fault 2, transport: the vehicle's TCP end drops the connection (SITL restarted, a router);
    pymavlink reconnects with a new socket: the link counts a reconnect and re-requests the streams."""
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    emu = ArduCopterEmulator(0, url=f"tcpin:127.0.0.1:{port}")
    emu.streams_need_request = True
    emu.start()
    link = MavlinkLink(f"tcp:127.0.0.1:{port}", config())
    try:
        link.connect(timeout=20.0)
        assert eventually(lambda: link.latest_state() is not None and link.latest_state().health == "ok")
        asked = len(emu.record.intervals)
        emu.drop_client()
        emu.streaming = set()  # a restarted vehicle forgot the rates
        assert eventually(lambda: link.latest_state().link_epoch >= 1)
        assert any("transport reconnected" in w for w in link.latest_state().warnings)
        assert eventually(lambda: len(emu.record.intervals) > asked), emu.record.intervals  # asked again
        assert eventually(lambda: link.latest_state().health == "ok")
    finally:
        link.close()
        emu.stop()


# --- 3. stream requests --------------------------------------------------------------------------


def test_refused_set_message_interval_falls_back_to_request_data_stream_and_retries() -> None:
    """Fault 3: SET_MESSAGE_INTERVAL answered UNSUPPORTED, streams only by REQUEST_DATA_STREAM."""
    with vehicle(faults={"message_interval_supported": False, "streams_need_request": True}) as (link, emu):
        st = link.latest_state()
        assert st.health == "ok" and st.position_valid
        assert emu.record.data_streams and not emu.record.intervals
        assert link.streams.method == "data_stream"
        assert any("refused MAV_CMD_SET_MESSAGE_INTERVAL (MAV_RESULT_UNSUPPORTED)" in w for w in st.warnings)
        asked = len(emu.record.data_streams)
        emu.streaming = set()  # the vehicle stops streaming (forgot the rates): asked again
        assert eventually(lambda: link.latest_state().health.startswith("stale"))
        assert eventually(lambda: link.latest_state().health == "ok")
        assert len(emu.record.data_streams) > asked


def test_an_unanswered_set_message_interval_also_asks_with_request_data_stream() -> None:
    """Fault 3, neighbour: no ACK at all (a router dropping COMMAND_LONG): each round also sends
    REQUEST_DATA_STREAM, so the streams flow."""
    with vehicle(faults={"ignore_commands": {mav.MAV_CMD_SET_MESSAGE_INTERVAL}, "streams_need_request": True}) \
            as (link, emu):
        assert link.latest_state().health == "ok" and emu.record.data_streams
        assert link.streams.method == "interval"  # not refused: keeps trying the checked request first


# --- 4 / 5. identity -----------------------------------------------------------------------------


@pytest.mark.parametrize("any_component", [False, True])  # by component id and type, or by type alone
@pytest.mark.parametrize("component, mav_type, autopilot", [
    (154, mav.MAV_TYPE_GIMBAL, mav.MAV_AUTOPILOT_GENERIC),  # fault 4
    (100, mav.MAV_TYPE_CAMERA, mav.MAV_AUTOPILOT_INVALID),  # neighbour: a camera
    (100, mav.MAV_TYPE_CAMERA, mav.MAV_AUTOPILOT_GENERIC),
])
def test_the_autopilot_is_chosen_not_a_component_that_heartbeats_first(component, mav_type, autopilot,
                                                                     any_component) -> None:
    cfg = config(autopilot_component=None, **PATIENT) if any_component else config(**PATIENT)
    with vehicle(cfg, faults={"components": [(component, mav_type, autopilot)], "autopilot_heartbeat_delay": 0.6}) \
            as (link, emu):
        assert "component 1)" in link.description
        assert any(c.startswith(f"1/{component} ") for c in link.components())
        with emu.lock:
            emu.yaw = 0.2  # the component sends ATTITUDE yaw 1.0: not the robot's
        assert eventually(lambda: link.latest_state().yaw == pytest.approx(math.pi / 2 - 0.2, abs=1e-4))
        time.sleep(0.3)
        assert link.latest_state().yaw == pytest.approx(math.pi / 2 - 0.2, abs=1e-4)
        assert link.latest_state().autopilot_mode == "STABILIZE"
        run = link.run_segment(MissionSegment(TAKEOFF, ((2.5, 0.7, 0.0), (2.5, 0.7, 1.0))))
        assert run.wait(30.0) is RunStatus.DONE, run.error
        assert emu.record.to_others == []  # every command went to the autopilot


def test_a_vehicle_with_the_consoles_system_id_is_warned_about() -> None:
    with vehicle(system=255) as (link, emu):
        st = link.latest_state()
        assert any("system id 255, the console's own" in w for w in st.warnings)
        assert any("WARNING: link: the vehicle uses system id 255" in t for _, t in st.messages)


def test_a_second_vehicle_is_warned_about_and_ignored() -> None:
    with vehicle(faults={"other_systems": [2]}) as (link, emu):
        assert eventually(lambda: any("second vehicle (system 2" in w for w in link.latest_state().warnings))
        time.sleep(0.3)
        assert link.latest_state().position == pytest.approx((ORIGIN[0], ORIGIN[1], 0.0), abs=1e-4)
        assert "system 1 " in link.description


# --- 10. readiness -------------------------------------------------------------------------------


def test_takeoff_waits_for_the_position_estimate_instead_of_failing() -> None:
    """Fault 10: Execute before the EKF has a position: the mission waits, then takes off."""
    # the LAND waits for a heartbeat (5 Hz) received after it decided: a time-out later than the next one
    with vehicle(config(heartbeat_timeout=3.0, **PATIENT), faults={"ekf_ready": False}, wait_ok=False) as (link, emu):
        assert eventually(lambda: link.latest_state() is not None)
        manager = mission_manager(link, failsafe_after=FAILSAFE_AFTER, failsafe_hold=0.5)
        manager.start(Mission((MissionSegment(TAKEOFF, ((2.5, 0.7, 0.0), (2.5, 0.7, 1.5))),
                               MissionSegment(LAND, ((2.5, 0.7, 1.5), (2.5, 0.7, 0.0))))))
        assert eventually(lambda: any("waiting for the robot's position" in m for m in events(manager)))
        time.sleep(0.5)
        assert manager.progress().status is MissionStatus.RUNNING
        assert not any(c == mav.MAV_CMD_COMPONENT_ARM_DISARM for c, _ in emu.record.received)  # no doomed arming
        emu.ekf_ready = True
        assert manager.wait(60.0) is MissionStatus.DONE, events(manager)
        assert emu.record.takeoff_altitudes == [pytest.approx(1.5)]


def test_a_vehicle_that_never_gets_ready_pauses_the_mission_with_its_reasons() -> None:
    with vehicle(faults={"ekf_ready": False}, wait_ok=False) as (link, emu):
        assert eventually(lambda: link.latest_state() is not None and link.latest_state().readiness)
        manager = mission_manager(link, failsafe_after=FAILSAFE_AFTER, failsafe_hold=0.5, ready_timeout=1.0)
        manager.start(Mission((MissionSegment(TAKEOFF, ((2.5, 0.7, 0.0), (2.5, 0.7, 1.5))),)))
        assert manager.wait(30.0) is MissionStatus.PAUSED
        message = manager.progress().message
        assert "no valid robot position after 1 s" in message and "PreArm: Need Position Estimate" in message, message


# --- the telemetry log ---------------------------------------------------------------------------


def test_the_session_is_recorded_as_a_tlog_that_pymavlink_reads_back(tmp_path) -> None:
    with vehicle(tlog=tmp_path) as (link, emu):
        link.set_mode("GUIDED")
        path = link.tlog
        assert eventually(lambda: emu.mode == "GUIDED")
        assert eventually(lambda: link.stats["received"] > 150)  # a few seconds of telemetry (more than 10 positions)
    assert path is not None and path.parent == tmp_path and path.suffix == ".tlog"
    log = mavutil.mavlink_connection(str(path))
    seen: dict[tuple[str, int], int] = {}
    stamps = []
    while True:
        m = log.recv_match()
        if m is None:
            break
        seen[(m.get_type(), m.get_srcSystem())] = seen.get((m.get_type(), m.get_srcSystem()), 0) + 1
        stamps.append(m._timestamp)
    assert seen.get(("HEARTBEAT", 1), 0) >= 2 and seen.get(("LOCAL_POSITION_NED", 1), 0) > 10
    assert seen.get(("HEARTBEAT", 255), 0) >= 1  # what the console sent is in it too
    assert seen.get(("COMMAND_LONG", 255), 0) >= 1 and seen.get(("COMMAND_ACK", 1), 0) >= 1
    assert all(abs(t - time.time()) < 60 for t in stamps)  # wall-clock timestamps of this session
