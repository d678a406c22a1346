"""The link against the emulator made to answer as ArduPilot Copter's firmware does (read from
ArduCopter/GCS_Mavlink.cpp, mode.cpp, takeoff.cpp, events.cpp and libraries/GCS_MAVLink/GCS_Common.cpp):
COMMAND_ACKs addressed to their sender, mode-change refusals with their reasons, speeds only in the
modes that take them, the GCS failsafe counting only heartbeats from SYSID_MYGCS, Copter mode numbers."""

from __future__ import annotations

import math
import time

import pytest
from pymavlink import mavutil

from console.link.base import CommandRejected, RunStatus
from console.link.mavlink_commands import copter_modes
from mav_emulator_commands import OTHER_GCS
from mav_emulator_events import use_mavlink2
from mav_helpers import config, eventually, vehicle
from planner.mission import MissionSegment, SegmentKind

mav = mavutil.mavlink


@pytest.fixture(autouse=True)
def _mavlink2() -> None:
    use_mavlink2()  # ArduPilot speaks MAVLink 2: COMMAND_ACK carries target_system / target_component


def test_copter_mode_numbers_are_the_firmwares() -> None:
    """ArduCopter/mode.h ``Mode::Number``: the numbers HEARTBEAT.custom_mode carries."""
    firmware = {"STABILIZE": 0, "ACRO": 1, "ALT_HOLD": 2, "AUTO": 3, "GUIDED": 4, "LOITER": 5, "RTL": 6,
                "CIRCLE": 7, "LAND": 9, "DRIFT": 11, "SPORT": 13, "FLIP": 14, "AUTOTUNE": 15, "POSHOLD": 16,
                "BRAKE": 17, "THROW": 18, "AVOID_ADSB": 19, "GUIDED_NOGPS": 20, "SMART_RTL": 21}
    modes = copter_modes()
    assert {k: modes[k] for k in firmware} == firmware


@pytest.mark.parametrize("command, result", [(mav.MAV_CMD_DO_SET_MODE, mav.MAV_RESULT_DENIED),
                                             (mav.MAV_CMD_COMPONENT_ARM_DISARM, mav.MAV_RESULT_FAILED)])
def test_an_ack_addressed_to_another_ground_station_is_not_taken_as_ours(command, result) -> None:
    """A second ground station's same command is refused just before ours is answered: its COMMAND_ACK
    (target 254/190) must not be read as the answer to ours."""
    with vehicle(faults={"foreign_acks": {command: result}}) as (link, emu):
        if command == mav.MAV_CMD_DO_SET_MODE:
            link.set_mode("GUIDED")
            assert eventually(lambda: link.vehicle_mode() == "GUIDED")
        else:
            link.arm()
            assert eventually(lambda: link.commander.armed())
        sent = [c for c in emu.record.commands if c[0] == command]
        assert sent and sent[-1][2] == mav.MAV_RESULT_ACCEPTED
        assert link.telemetry.v.foreign_acks >= 1  # seen, addressed to OTHER_GCS, ignored
        assert OTHER_GCS == (254, 190)


def test_an_armed_vehicle_without_a_position_refuses_guided_and_says_why() -> None:
    """mode.cpp: armed, a mode that needs a position is refused (FAILED) with the vehicle's own words."""
    with vehicle() as (link, emu):
        link.arm()
        assert eventually(lambda: link.commander.armed())
        emu.ekf_ready = False
        with pytest.raises(CommandRejected) as err:
            link.set_mode("GUIDED")
        print(err.value)
        assert "MAV_RESULT_FAILED" in str(err.value)
        assert "Mode change to GUIDED failed: requires position" in str(err.value)
        assert emu.mode == "STABILIZE"


def test_a_mode_blocked_for_ground_stations_is_refused_with_the_parameter_named() -> None:
    with vehicle(faults={"gcs_blocked_modes": {"BRAKE"}}) as (link, emu):
        with pytest.raises(CommandRejected) as err:
            link.set_mode("BRAKE")
        # STATUSTEXT carries 50 characters: the firmware's line is cut after "GCS entry disabled (F"
        assert "Mode change to BRAKE failed: GCS entry disabled" in str(err.value), err.value


def test_a_speed_outside_guided_is_refused_as_the_firmware_does_and_only_warned_about() -> None:
    """GCS_Mavlink.cpp handle_MAV_CMD_DO_CHANGE_SPEED: the mode decides; STABILIZE does not take a speed
    (FAILED), GUIDED does; type 4 and a speed <= 0 are DENIED."""
    with vehicle() as (link, emu):
        assert link.vehicle_mode() == "STABILIZE"
        assert link.commander.change_speed(1, 0.7) is False
        assert eventually(lambda: any("MAV_RESULT_FAILED" in w and "its own configured speed" in w
                                      for w in link.latest_state().warnings)), link.latest_state().warnings
        link.set_mode("GUIDED")
        assert link.commander.change_speed(1, 0.7) is True
        assert emu.cmd_speed == pytest.approx(0.7, abs=1e-6)  # a float32 on the wire
        with pytest.raises(CommandRejected, match="MAV_RESULT_DENIED"):
            link.command(mav.MAV_CMD_DO_CHANGE_SPEED, (4, 0.7, -1), "speed type 4")
        with pytest.raises(CommandRejected, match="MAV_RESULT_DENIED"):
            link.command(mav.MAV_CMD_DO_CHANGE_SPEED, (1, 0.0, -1), "speed 0")


def test_the_gcs_failsafe_counts_only_sysid_mygcs_heartbeats_and_the_console_says_so() -> None:
    """events.cpp failsafe_gcs_check with GCS_Mavlink.cpp: a console heartbeating as system 250 to a
    vehicle whose SYSID_MYGCS is 255 is never 'seen': the link works, yet the vehicle RTLs after
    FS_GCS_TIMEOUT. The console warns before take-off, then says the vehicle took control."""
    with vehicle(config(source_system=250)) as (link, emu):
        assert eventually(lambda: any("SYSID_MYGCS (MAV_GCS_SYSID) is 255, the console is system 250" in w
                                      for w in link.latest_state().warnings), 30.0), link.latest_state().warnings
        run = link.run_segment(MissionSegment(SegmentKind.TAKEOFF, ((2.5, 0.7, 0.0), (2.5, 0.7, 1.5))))
        assert run.wait(60.0) is RunStatus.DONE, run.error
        with emu.lock:  # a ground station with id 255 was seen once; none since: the countdown runs
            emu.params["FS_GCS_TIMEOUT"] = 2.0
            emu.gcs_last_seen = time.monotonic()
            emu.gcs_failsafe_auto = True
        assert eventually(lambda: emu.mode == "RTL", 30.0)
        assert eventually(lambda: link.vehicle_control.startswith("vehicle took control: mode RTL (GCS Failsafe"),
                          30.0), link.vehicle_control
        assert link.latest_state().link_ok  # the link itself was fine all along


def test_with_the_right_gcs_id_the_vehicle_sees_the_console_and_no_failsafe_comes() -> None:
    with vehicle() as (link, emu):
        run = link.run_segment(MissionSegment(SegmentKind.TAKEOFF, ((2.5, 0.7, 0.0), (2.5, 0.7, 1.5))))
        assert run.wait(60.0) is RunStatus.DONE, run.error
        with emu.lock:
            emu.params["FS_GCS_TIMEOUT"] = 3.0
            emu.gcs_failsafe_auto = True
            t0 = time.monotonic()
        # the vehicle keeps hearing system 255 for longer than its timeout
        assert eventually(lambda: emu.gcs_last_seen > t0 + 4.0, 60.0)
        assert not emu.failsafe_gcs and emu.mode == "GUIDED"
        assert "SYSID_MYGCS" in link.telemetry.v.params
        assert not any("SYSID_MYGCS" in w for w in link.latest_state().warnings)


def test_a_vehicle_flying_its_own_slower_speed_is_timed_on_the_speed_it_flies() -> None:
    """The speed command is ACCEPTED but not applied (a firmware keeping WPNAV_SPEED, 1 m/s here; 4 m/s
    commanded): the flight's time-out (12 m / 4 m/s x 1 + 5 s = 8 s) follows the measured 1 m/s instead
    of failing a vehicle that is still on its way; the operator is told both speeds."""
    with vehicle(config(timeout_factor=1.0, fly_speed=4.0), fly_speed=1.0, accel=3.0,
                 faults={"speed_ignored": True}) as (link, emu):
        run = link.run_segment(MissionSegment(SegmentKind.TAKEOFF, ((2.5, 0.7, 0.0), (2.5, 0.7, 1.5))))
        assert run.wait(60.0) is RunStatus.DONE, run.error
        t0 = time.monotonic()
        run = link.run_segment(MissionSegment(SegmentKind.FLY, ((2.5, 0.7, 1.5), (2.5, 12.7, 1.5))))
        assert run.wait(120.0) is RunStatus.DONE, run.error
        took = time.monotonic() - t0
        print(f"12 m at the vehicle's own 1 m/s took {took:.1f} s (first time-out 8 s)")
        assert took > 8.0  # it did outlast the first time-out
        assert any("the vehicle flies at" in m and "4.00 m/s was commanded" in m for _, m in
                   link.latest_state().messages), link.latest_state().messages


def test_a_vehicle_that_stops_closing_in_still_times_out() -> None:
    with vehicle(config(timeout_factor=1.0, timeout_slack=1.0)) as (link, emu):
        run = link.run_segment(MissionSegment(SegmentKind.TAKEOFF, ((2.5, 0.7, 0.0), (2.5, 0.7, 1.5))))
        assert run.wait(60.0) is RunStatus.DONE, run.error
        emu.freeze_motion = True
        run = link.run_segment(MissionSegment(SegmentKind.FLY, ((2.5, 0.7, 1.5), (2.5, 8.7, 1.5))))
        assert run.wait(60.0) is RunStatus.FAILED
        assert "not reached within 3 s" in run.error, run.error


def test_guided_stops_a_velocity_target_not_renewed_and_a_frame_it_does_not_take() -> None:
    """mode_guided.cpp: a velocity target not renewed within GUID_TIMEOUT (3 s) is zeroed; GCS_Mavlink.cpp:
    a SET_POSITION_TARGET_LOCAL_NED in MAV_FRAME_GLOBAL stops the vehicle. The link's own targets are
    all of the kinds GUIDED takes."""
    with vehicle() as (link, emu):
        run = link.run_segment(MissionSegment(SegmentKind.TAKEOFF, ((2.5, 0.7, 0.0), (2.5, 0.7, 1.5))))
        assert run.wait(60.0) is RunStatus.DONE, run.error
        link.send_velocity_target((0.0, 0.5, 0.0))
        sent = time.monotonic()
        assert eventually(lambda: math.hypot(*emu.vel[:2]) > 0.4, 20.0)
        assert eventually(lambda: math.hypot(*emu.vel[:2]) < 1e-6, 30.0)
        assert time.monotonic() - sent > 2.9  # not before its 3 s time-out
        assert emu.record.targets_invalid == 0  # the link's masks and frame are GUIDED's
        sys_id, comp = link._target()
        link.transport.send("set_position_target_local_ned_send", 0, sys_id, comp, mav.MAV_FRAME_GLOBAL,
                            0b0000_1101_1111_1000, 0.0, 30.0, -1.5, 0, 0, 0, 0, 0, 0, 0, 0)
        assert eventually(lambda: emu.record.targets_invalid == 1, 20.0)
        assert emu.target is None and emu.vtarget == [0.0, 0.0, 0.0]


def test_a_walk_with_velocity_targets_keeps_renewing_them_past_the_guided_timeout() -> None:
    from console.link.mavlink import GroundMotion

    with vehicle(config(ground=GroundMotion(command="velocity", speed=0.5)), walk_speed=0.5) as (link, emu):
        run = link.run_segment(MissionSegment(SegmentKind.WALK, ((2.5, 0.7, 0.0), (2.5, 3.2, 0.0))))
        assert run.wait(90.0) is RunStatus.DONE, run.error  # 2.5 m at 0.5 m/s: longer than GUID_TIMEOUT
        assert emu.record.targets_invalid == 0


def test_a_take_off_from_a_box_climbs_to_the_planned_height_not_above_it() -> None:
    """takeoff.cpp: NAV_TAKEOFF's altitude is above home, and home is where the vehicle armed (here on a
    0.5 m box above the EKF origin): asking the height above the origin (1.5 m) would climb to 2.0 m."""
    with vehicle(start_ned=(0.0, 0.0, -0.5)) as (link, emu):
        run = link.run_segment(MissionSegment(SegmentKind.TAKEOFF, ((2.5, 0.7, 0.5), (2.5, 0.7, 1.5))))
        assert run.wait(60.0) is RunStatus.DONE, run.error
        assert emu.record.takeoff_altitudes == [pytest.approx(1.0, abs=0.05)]
        assert eventually(lambda: emu.landed_state == mav.MAV_LANDED_STATE_IN_AIR and abs(emu.vel[2]) < 0.01, 30.0)
        print(f"highest point {emu.record.max_height:.2f} m above the origin (planned 1.5 m)")
        assert emu.record.max_height < 1.5 + 0.15


def test_a_radio_outage_the_vehicle_answers_with_its_gcs_failsafe_is_never_resumed_over() -> None:
    """events.cpp failsafe_gcs_check: the radio goes dead both ways (UDP: packets lost, nothing queued);
    the vehicle hears no ground station for FS_GCS_TIMEOUT and RTLs by itself while the console's own
    failsafe commands are lost. When the link returns the console reads the vehicle's mode first: it
    says the vehicle took control while unheard, offers no resume, refuses one, and sends nothing."""
    from console.link.manager import MissionStateError
    from mav_helpers import events, mission_manager
    from planner.mission import Mission

    with vehicle(config(fly_speed=1.0)) as (link, emu):
        run = link.run_segment(MissionSegment(SegmentKind.TAKEOFF, ((2.5, 0.7, 0.0), (2.5, 0.7, 1.5))))
        assert run.wait(60.0) is RunStatus.DONE, run.error
        with emu.lock:
            emu.params["FS_GCS_TIMEOUT"] = 2.0
            emu.gcs_failsafe_auto = True
        manager = mission_manager(link, failsafe_after=1.0, failsafe_hold=1.0)
        manager.start(Mission((MissionSegment(SegmentKind.FLY, ((2.5, 0.7, 1.5), (2.5, 9.0, 1.5))),),
                              bounds_min=(0.0, 0.0, 0.0), bounds_max=(10.0, 12.0, 20.0)))
        assert eventually(lambda: emu.pos[0] > 1.0, 30.0)
        emu.drop = 1.0  # the radio is out, both ways
        assert eventually(lambda: emu.mode == "RTL", 30.0)
        # the console's failsafe ran its course in the dark (its hold and landing never arrived)
        assert eventually(lambda: any("FAILSAFE landing not" in m for m in events(manager)), 60.0), events(manager)
        back = time.monotonic()
        emu.drop = 0.0
        assert eventually(lambda: any(m.startswith("link restored after the failsafe") for m in events(manager)),
                          30.0), events(manager)
        said = next(m for m in events(manager) if m.startswith("link restored after the failsafe"))
        print(said)
        assert "autopilot mode RTL" in said and "vehicle took control: mode RTL while the console could not hear " \
               "it" in said and "take control first" in said, said
        assert "resume or abort" not in said
        # the vehicle's "GCS Failsafe" was lost with the link; its "GCS Failsafe Cleared" once it hears us names it
        assert eventually(lambda: "(GCS Failsafe (now cleared))" in link.vehicle_control, 30.0), link.vehicle_control
        with pytest.raises(MissionStateError, match="take control first"):
            manager.resume()
        assert eventually(lambda: emu.landed_state == mav.MAV_LANDED_STATE_ON_GROUND, 90.0)
        modes = [m for (m, t), (_, by) in zip(emu.record.mode_times, emu.record.mode_sources) if t > back]
        assert modes == [] and emu.mode == "RTL", modes  # the vehicle's RTL ran to its end, untouched


def test_an_ekf_failsafe_landing_is_left_to_the_vehicle() -> None:
    """ekf_check.cpp: EKF_STATUS_REPORT bad, then "EKF variance" and LAND (FS_EKF_ACTION 1). The console's
    own estimator check fires first; its hold is refused by a vehicle without a trusted position, and
    that refusal is not the vehicle's reason for its LAND: the console names "EKF variance", sends
    nothing more, and the vehicle lands where its failsafe put it."""
    from mav_helpers import events, mission_manager
    from console.link.manager import MissionStatus
    from planner.mission import Mission

    with vehicle(config(fly_speed=1.0), descent_rate=1.0) as (link, emu):
        run = link.run_segment(MissionSegment(SegmentKind.TAKEOFF, ((2.5, 0.7, 0.0), (2.5, 0.7, 1.5))))
        assert run.wait(60.0) is RunStatus.DONE, run.error
        manager = mission_manager(link, failsafe_after=1.5, failsafe_hold=0.5)
        manager.start(Mission((MissionSegment(SegmentKind.FLY, ((2.5, 0.7, 1.5), (2.5, 9.0, 1.5))),),
                              bounds_min=(0.0, 0.0, 0.0), bounds_max=(10.0, 12.0, 3.0)))
        assert eventually(lambda: emu.pos[0] > 1.0, 30.0)
        took = time.monotonic()
        emu.ekf_variance_bad()  # the flags first: the console holds (BRAKE: refused, "requires position")
        assert manager.wait(30.0) is MissionStatus.PAUSED, events(manager)
        assert eventually(lambda: any("Mode change to BRAKE failed: requires position" in m for m in events(manager)),
                          30.0), events(manager)
        emu.ekf_failsafe()  # then the vehicle's own EKF failsafe: LAND
        assert eventually(lambda: "vehicle took control: mode LAND (EKF variance)" in link.vehicle_control, 30.0), \
            link.vehicle_control
        assert eventually(lambda: emu.landed_state == mav.MAV_LANDED_STATE_ON_GROUND, 60.0)
        console_modes = [m for (m, t), (_, by) in zip(emu.record.mode_times, emu.record.mode_sources)
                         if t > took and by == "gcs"]
        assert console_modes == [] and emu.mode == "LAND", (console_modes, emu.mode, events(manager))


def test_the_reason_for_a_takeover_is_the_vehicles_not_its_answer_to_our_command() -> None:
    """The console's hold raced the vehicle's EKF failsafe: mode.cpp's refusal of our BRAKE came after
    the vehicle's "EKF variance" and before the LAND heartbeat; the reason is "EKF variance". A takeover
    first seen in the heartbeat ending a silence says so, and a failsafe's "... Cleared" names it."""
    from console.link.mavlink_authority import ModeAuthority

    lines: list[tuple[float, int, str]] = []
    a = ModeAuthority(lambda: lines)
    a.commanding("GUIDED")
    a.commanded("GUIDED", True)
    assert a.observe("GUIDED") is None
    now = time.monotonic()
    lines.append((now - 0.3, 2, "CRITICAL: EKF variance"))
    lines.append((now - 0.1, 4, "WARNING: Mode change to BRAKE failed: requires position"))
    assert a.observe("LAND") is not None
    assert a.describe() == "vehicle took control: mode LAND (EKF variance)"
    a.take_control()
    lines.clear()
    a.commanding("GUIDED")
    a.commanded("GUIDED", True)
    assert a.observe("GUIDED") is None
    assert a.observe("RTL", unheard=7.5) is not None
    assert a.describe().startswith("vehicle took control: mode RTL while the console could not hear it (7.5 s) "
                                   "(its reason, if it gave one, was lost with the link")
    lines.append((time.monotonic() + 1.0, 2, "CRITICAL: GCS Failsafe Cleared"))
    assert a.describe() == ("vehicle took control: mode RTL while the console could not hear it (7.5 s) "
                            "(GCS Failsafe (now cleared))")


def test_a_vehicle_without_an_ekf_origin_is_said_to_have_none() -> None:
    """GCS_Common.cpp: MAV_CMD_REQUEST_MESSAGE(GPS_GLOBAL_ORIGIN) is ACCEPTED but nothing is sent while the
    EKF origin is not set (indoors, no GPS): the console says so instead of waiting silently."""
    with vehicle(faults={"origin_set": False}) as (link, emu):
        assert eventually(lambda: any("the vehicle reports no EKF origin (GPS_GLOBAL_ORIGIN asked 5 times, never "
                                      "sent)" in w for w in link.latest_state().warnings), 90.0), \
            link.latest_state().warnings
        asked = [c for c in emu.record.commands if c[0] == mav.MAV_CMD_REQUEST_MESSAGE]
        assert len(asked) >= 5 and all(r == mav.MAV_RESULT_ACCEPTED for _, _, r in asked)
        assert link.telemetry.v.origin_now is None


def test_unknown_battery_values_are_unknown_not_invalid_nor_empty() -> None:
    """SYS_STATUS without a battery monitor: voltage_battery UINT16_MAX and battery_remaining -1 mean
    'unknown' (MAVLink common.xml): no battery figure, not 0 %, and no dropped-message alarm."""
    with vehicle(faults={"battery_unknown": True}) as (link, emu):
        assert eventually(lambda: link.telemetry.stream_age("SYS_STATUS") < 0.5, 30.0)
        st = link.latest_state()
        assert st.battery is None and st.battery_voltage is None, (st.battery, st.battery_voltage)
        assert st.health == "ok" and link.telemetry.v.invalid.get("SYS_STATUS", 0) == 0
        emu.battery_unknown = False
        assert eventually(lambda: link.latest_state().battery is not None, 30.0)
        assert link.latest_state().battery_voltage == pytest.approx(15.8)
