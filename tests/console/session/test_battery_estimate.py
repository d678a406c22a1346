"""The battery time left to land while the robot hovers: the measured drain in the air and the words shown."""

from __future__ import annotations

import time
from pathlib import Path

import pytest

from console.link.base import Mode, RobotState
from console.link.sim_config import SimConfig
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
    assert minutes_text(45.0) == "less than 1 min" and minutes_text(150.0) == "about 2 min" and minutes_text(210.0) == "about 3 min"
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


# --- the estimate against a known drain --------------------------------------------------------------------
def _feed(d: DrainRate, t0: float, seconds: float, charge: float, rate: float, step: float = 0.5,
          whole_percent: bool = True) -> tuple[float, float]:
    """Reports every ``step`` s for ``seconds`` at ``rate`` [1/s] from ``charge``; returns (time, charge) at the end."""
    k, t, c = 0, t0, charge
    while k * step <= seconds:
        t, c = t0 + k * step, charge - rate * k * step
        d.add(t, round(100 * c) / 100 if whole_percent else c, airborne=True)
        k += 1
    return t, c


@pytest.mark.parametrize("rate", [SimConfig().drain_fly, 0.17 / 30.0, 5e-4 * 8], ids=["sim-default", "17pc-in-30s", "8x"])
def test_a_steady_drain_gives_the_time_left_within_10_percent(rate: float) -> None:
    d = DrainRate()
    _, c = _feed(d, 1000.0, 50.0, 0.65, rate)  # whole-percent reports, as MAVLink's battery_remaining
    assert d.rate() == pytest.approx(rate, rel=0.10)
    assert time_left(c, d.rate()) == pytest.approx((c - BATTERY_CRITICAL) / rate, rel=0.10)


def test_after_a_change_of_drain_the_estimate_follows_the_new_one_within_seconds() -> None:
    """100 s of a slow hover drain, then the drain of 17 % in 30 s: 20 s later, 40 % left, the time left is the
    new drain's (about 53 s), not the 120 s line's (it said about 3 min: the old and new drains averaged)."""
    d = DrainRate()
    t, c = _feed(d, 1000.0, 100.0, 0.65, 0.0012)  # 0.65 -> 0.53
    fast = 0.17 / 30.0
    t, c = _feed(d, t + 0.5, 23.0, c - 0.5 * fast, fast)  # -> about 0.40
    assert c == pytest.approx(0.40, abs=0.01)
    assert d.rate() == pytest.approx(fast, rel=0.10)
    assert time_left(c, d.rate()) == pytest.approx((c - BATTERY_CRITICAL) / fast, rel=0.10)
    t, c = _feed(d, t + 0.5, 60.0, c, 0.0012, whole_percent=False)  # and back to the slow drain
    assert d.rate() == pytest.approx(0.0012, rel=0.10)


def test_the_simulators_drain_in_the_air_is_measured_within_10_percent() -> None:
    """The simulated robot hovering at 4x the wall clock with its default drain: the estimate from its own
    reports (stamped with the wall clock) is drain_fly x time_scale per wall second."""
    from console.app import wait_until
    from console.link.sim import SimRobot
    from planner.mission import MissionSegment, SegmentKind

    cfg = SimConfig(time_scale=4.0)
    robot = SimRobot(config=cfg)
    d = DrainRate()
    air: list[float] = []  # stamps of the reports in the air [s]

    def report(st: RobotState) -> None:
        d.add(st.time, st.battery, not st.landed)
        if not st.landed:
            air.append(st.time)

    robot.subscribe(report)
    robot.connect()
    try:
        robot.run_segment(MissionSegment(SegmentKind.TAKEOFF, ((2.5, 0.7, 0.0), (2.5, 0.7, 1.5))))
        assert wait_until(lambda: d.rate() is not None and air[-1] - air[0] >= 12.0, 120, 0.1), "no estimate in the air"
        st = robot.latest_state()
        assert st is not None and not st.landed and st.battery > BATTERY_CRITICAL
        assert d.rate() == pytest.approx(cfg.drain_fly * cfg.time_scale, rel=0.10)
    finally:
        robot.close()
