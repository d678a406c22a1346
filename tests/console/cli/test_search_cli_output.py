"""`morphonavi search` prints each step once (a capture's operator notice is not printed again on stderr) and
counts in the right number ("budget 1 capture", "1 capture")."""

from __future__ import annotations

import pytest

from console.cli.morphonavi import main
from console.cli.search_cmd import said_by_steps


def test_each_capture_is_printed_once_and_one_capture_is_singular(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["search", "--target", "robot dog", "--max-captures", "1", "--time-scale", "20"]) == 1
    cap = capsys.readouterr()
    both = cap.out + cap.err
    assert both.count("26 objects seen") == 1, both  # the step only; the 'Mapped' notice said it again on stderr
    assert "Mapped:" not in cap.err and "Find: robot dog" not in cap.err, cap.err
    assert "budget 1 capture," in cap.out and "budget of 1 capture used" in cap.out, cap.out
    assert "1 captures" not in both, both
    lines = cap.out.strip().splitlines()
    assert lines[-2].startswith("NOT FOUND: not found: budget of 1 capture used") and "; 1 capture, " in lines[-2]
    assert lines[-1].startswith("left unseen: ") and "m² of floor unseen" in lines[-1]  # said once, on stdout


def test_notices_the_steps_already_say_are_known_by_title() -> None:
    assert said_by_steps("Mapped") and said_by_steps("Find: robot dog") and said_by_steps("Find")
    assert not said_by_steps("Check the camera pose") and not said_by_steps("Findings") \
        and not said_by_steps("Capture & map failed")
