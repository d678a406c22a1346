"""The battery time left to land while the robot hovers: the measured drain in the air and the words shown."""

from __future__ import annotations

import time
from pathlib import Path

import pytest

from console.link.base import Mode, RobotState
from console.session.battery_estimate import MIN_SPAN, DrainRate, hover_text, minutes_text, time_left
from console.session.operator_state import BATTERY_CRITICAL
from console.session.session import Session
from console.session.session_types import RunStatus, robot_snapshot

START = (2.5, 0.7, 0.0)
HOVER = (2.0, 2.5, 1.5)


def test_the_drain_is_fitted_over_the_reports_in_the_air() -> None:
    d = DrainRate()
    for k in range(30):  # 0.5 % per second, reported as whole percent like MAVLink's battery_remaining
        d.add(1000.0 + k, round(80.0 - 0.5 * k) / 100.0, airborne=True)
    assert d.rate() == pytest.approx(0.005, rel=0.05)
    assert time_left(0.40, d.rate()) == pytest.approx((0.40 - BATTERY_CRITICAL) / 0.005, rel=0.05)
    d.add(1031.0, 0.65, airborne=False)  # landed: a new flight measures again
    assert d.rate() is None


def test_no_estimate_before_enough_seconds_in_the_air_or_without_a_falling_charge() -> None:
    d = DrainRate()
    for k in range(int(MIN_SPAN) - 2):
        d.add(float(k), 0.9 - 0.01 * k, airborne=True)
    assert d.rate() is None  # too short
    steady = DrainRate()
    for k in range(30):
        steady.add(float(k), 0.9, airborne=True)
    assert steady.rate() is None  # not falling: no time to give
    swapped = DrainRate()
    for k in range(20):
        swapped.add(float(k), 0.5 - 0.01 * k, airborne=True)
    swapped.add(20.0, 0.95, airborne=True)  # a jump up: another battery, start over
    assert swapped.rate() is None
    for bad in (None, float("nan"), float("inf")):
        swapped.add(21.0, bad, airborne=True)  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="window: must be"):
        DrainRate(window=0.0)
    with pytest.raises(ValueError, match="min_span: must be"):
        DrainRate(window=10.0, min_span=20.0)


def test_the_words() -> None:
    assert hover_text(0.55, 0.0025) == ("hovering: about 3 min of battery left to land (the console lands the "
                                        "robot at 10 %)")
    assert minutes_text(45.0) == "less than 1 min" and minutes_text(150.0) == "about 2 min"
    assert hover_text(0.55, None) == "hovering: measuring the battery drain for a time estimate…"
    assert hover_text(None, 0.01) == "hovering: battery charge unknown, no time estimate"
    assert "the robot lands now" in hover_text(0.08, 0.01)
    assert time_left(0.5, 0.0) is None and time_left(None, 0.01) is None


def test_the_session_says_the_time_left_while_the_robot_hovers_after_a_mission(tmp_path: Path) -> None:
    s = Session(tmp_path / "s", start=START, autosave=False)
    t0 = time.time()

    def report(t: float, p: tuple[float, float, float], mode: Mode, charge: float, landed: bool) -> None:
        s.set_robot(robot_snapshot(RobotState(time=t0 + t, position=p, mode=mode, armed=True, landed=landed,
                                              battery=charge)))

    report(0.0, START, Mode.IDLE, 0.80, True)
    assert s.operator_state().battery_note == ""  # on the ground: no hover estimate
    s.set_run(RunStatus("running", 0, 0.1))
    for k in range(20):  # flying the mission: 0.25 % per second
        report(1.0 + k, HOVER, Mode.FLYING, 0.80 - 0.0025 * k, False)
    assert s.operator_state().battery_note == ""  # a mission under way: not hovering
    s.set_run(RunStatus("done", 0, 1.0))
    report(21.0, HOVER, Mode.HOLDING, 0.80 - 0.0025 * 20, False)
    note = s.operator_state().battery_note
    # (0.75 - 0.10) / 0.0025 per s = 260 s: about 4 min
    assert note == "hovering: about 4 min of battery left to land (the console lands the robot at 10 %)"
    s.set_run(RunStatus("paused", 0, 0.5))  # a paused mission: the robot hovers, the operator decides
    assert s.operator_state().battery_note == note
    report(40.0, (2.0, 2.5, 0.0), Mode.IDLE, 0.70, True)  # landed
    assert s.operator_state().battery_note == ""
