"""Late COMMAND_ACKs: MAVLink's COMMAND_ACK names only the command id (no sequence number; ArduPilot does
not echo ``confirmation``), so the late answer to a re-sent copy must not be read as the answer to the
next command of the same id. The emulator delays every answer of one command id by ``ACK_DELAY`` (more
than the link's ``ack_timeout`` of 0.25 s), so commands are re-sent and answers arrive after their
command has ended."""

from __future__ import annotations

import pytest
from pymavlink import mavutil

from console.link.base import CommandRejected
from console.link.mavlink_commands import SPEED_CLIMB, SPEED_GROUND
from mav_emulator_events import use_mavlink2
from mav_helpers import eventually, vehicle

mav = mavutil.mavlink
ACK_DELAY = 0.6
"""How late [s] every answer of the command under test arrives (the link waits 0.25 s, then re-sends)."""


@pytest.fixture(autouse=True)
def _mavlink2() -> None:
    use_mavlink2()


def _slow_answers(emu, command: int) -> None:
    with emu.lock:
        emu.ack_delays[command] = [ACK_DELAY] * 100


def test_a_late_accepted_mode_change_does_not_hide_the_next_refusal() -> None:
    """LOITER is accepted (its ACKs late); ALT_HOLD right after is refused (FLTMODE_GCSBLOCK): the refusal is
    what the console reads, not one of LOITER's late ACCEPTED."""
    with vehicle() as (link, emu):
        _slow_answers(emu, mav.MAV_CMD_DO_SET_MODE)
        link.set_mode("LOITER")  # the heartbeat or a late ACK says it worked; copies' ACKs still owed
        assert eventually(lambda: link.vehicle_mode() == "LOITER")
        with emu.lock:
            emu.gcs_blocked_modes = {"ALT_HOLD"}
        with pytest.raises(CommandRejected, match="mode change to ALT_HOLD rejected by the vehicle: MAV_RESULT_FAILED"):
            link.set_mode("ALT_HOLD")
        assert link.vehicle_mode() == "LOITER"
        assert link.commander.stats.get("late_acks", 0) >= 1  # LOITER's late answers were read and dropped


def test_back_to_back_speed_commands_each_get_their_own_answer() -> None:
    """Three DO_CHANGE_SPEED back to back, answers late: the third (speed type 4, DENIED by the firmware)
    is reported refused, not accepted on the second's late ACK."""
    with vehicle() as (link, emu):
        link.set_mode("GUIDED")  # speeds are taken in GUIDED (disarmed: any mode goes)
        assert eventually(lambda: link.vehicle_mode() == "GUIDED")
        _slow_answers(emu, mav.MAV_CMD_DO_CHANGE_SPEED)
        cmd = link.commander
        assert cmd.change_speed(SPEED_GROUND, 1.0)  # accepted: its answer came while its copies went out
        assert cmd.change_speed(SPEED_CLIMB, 0.5)
        assert not cmd.change_speed(4, 1.0)  # SPEED_TYPE_ENUM_END: DENIED (GCS_Mavlink.cpp)
        with link.telemetry.lock:
            assert "rejected by the vehicle: MAV_RESULT_DENIED" in link.telemetry.v.warnings["speed4"]
        answers = [r for c, _, r in emu.record.commands if c == mav.MAV_CMD_DO_CHANGE_SPEED]
        assert answers.count(mav.MAV_RESULT_DENIED) >= 1 and link.commander.stats.get("late_acks", 0) >= 1
