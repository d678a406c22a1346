"""`morphonavi search --battery-reserve PCT`: the search's battery budget, checked naming the option."""

from __future__ import annotations

from console.cli.morphonavi import main


def test_battery_reserve_below_the_consoles_low_battery_rule_is_refused_naming_the_option(capsys) -> None:
    assert main(["search", "--target", "robot dog", "--battery-reserve", "10"]) == 2
    err = capsys.readouterr().err
    assert "--battery-reserve: must be at least 25 % and below 100 % (below 25 % the console refuses new moves), " \
           "got 10" in err, err
    assert main(["search", "--target", "robot dog", "--battery-reserve", "nan"]) == 2
    assert "--battery-reserve" in capsys.readouterr().err
