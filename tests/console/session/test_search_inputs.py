"""The search's inputs are checked in one place (console/session/search_inputs.py) for `morphonavi search` and the
Find panel: the same values refused with the same words, each door naming the input as it shows it."""

from __future__ import annotations

import re

import pytest

from console.session.search_inputs import CLI_NAMES, PANEL_NAMES, search_config
from console.session.search_types import SearchConfig, check_target, target_matches
from console.session.session_types import SessionError

BAD = [  # (the input, its value as typed in the panel, its value as typed on the command line, words of the refusal)
    ("target", "unicorn", "unicorn", "'unicorn' is not an object the perception can name"),
    ("target", "   ", "", "must be 1..200 characters (what to find, e.g. 'robot dog'), got nothing"),
    ("target", "x" * 201, "x" * 201, "must be 1..200 characters"),
    ("mode", "fast", "fast", "must be one of auto, step, got fast"),
    ("max_captures", 0, "0", "must be a whole number within 1..200, got 0"),
    ("max_captures", 2.5, "2.5", "must be a whole number within 1..200, got 2.5"),
    ("max_captures", float("nan"), "nan", "must be a whole number within 1..200, got nan"),
    ("max_captures", "x", "x", "must be a whole number within 1..200, got x"),
    ("max_time", 0.25, "15", "must be a number within"),
    ("max_time", float("inf"), "inf", "must be a number within"),
    ("max_time", 2000.0, "100000", "must be a number within"),
    ("battery_reserve", 10, "10", "must be at least 25 % and below 100 % (below 25 % the console refuses new moves), got 10"),
    ("battery_reserve", 100, "100", "must be at least 25 % and below 100 %"),
    ("battery_reserve", float("nan"), "nan", "must be at least 25 % and below 100 %"),
]


def _refusal(names, field: str, value: object) -> str:
    kw: dict[str, object] = {"target": "robot dog", "mode": "auto", "max_captures": 20, "max_time": None,
                             "battery_reserve": None}
    kw[field] = value
    target = kw.pop("target")
    with pytest.raises(SessionError) as err:
        search_config(names, target, **kw)
    return str(err.value)


@pytest.mark.parametrize("field, panel_value, cli_value, words", BAD)
def test_both_doors_refuse_the_same_value_with_the_same_words_naming_their_input(field, panel_value, cli_value,
                                                                                 words) -> None:
    panel, cli = _refusal(PANEL_NAMES, field, panel_value), _refusal(CLI_NAMES, field, cli_value)
    p_name, c_name = getattr(PANEL_NAMES, field), getattr(CLI_NAMES, field)
    assert panel.startswith(f"{p_name}: ") and words in panel, panel
    assert cli.startswith(f"{c_name}: ") and words in cli, cli
    if field != "max_time":  # the time budget is typed in minutes in the panel, in seconds on the command line
        assert panel[len(p_name):] == cli[len(c_name):]
    for text in (panel, cli):  # never the code's field names
        assert not re.search(r"(^|\s)(max_captures|max_time|min_battery|target):", text), text


def test_the_time_budget_names_its_unit_at_each_door() -> None:
    assert _refusal(CLI_NAMES, "max_time", "10") == "--max-time: must be a number within 30..86400 s, got 10"
    assert _refusal(PANEL_NAMES, "max_time", 0.25) == "Time budget [min]: must be a number within 0.5..1440 min, got 0.25"


def test_an_unknown_target_is_refused_with_the_classes_the_perception_names_and_how_to_add_one() -> None:
    text = _refusal(CLI_NAMES, "target", "dog")
    assert "(did you mean 'robot dog'?)" in text
    assert "robot dog, table, chair" in text and "office chair" in text  # the catalog's classes, as words
    assert "add it to the catalog (assets/catalog.toml" in text and "prompts" in text
    assert "(did you mean 'robot dog'?)" in _refusal(PANEL_NAMES, "target", "robt dog")


def test_good_inputs_make_the_search_with_units_converted() -> None:
    cfg = search_config(PANEL_NAMES, "  Quadruped ", mode="step", max_captures=12.0, max_time=2.5, battery_reserve=40)
    assert cfg == SearchConfig("Quadruped", mode="step", max_captures=12, max_time=150.0, target_height=0.4,
                               min_battery=0.4)
    cli = search_config(CLI_NAMES, "robot dog", max_captures="16", max_time="900", battery_reserve="30")
    assert (cli.max_captures, cli.max_time, cli.min_battery, cli.target_height) == (16, 900.0, 0.3, 0.4)
    assert search_config(CLI_NAMES, "a quadruped robot", max_time="30").max_time == 30.0  # the range's ends are in


def test_synonyms_and_prompts_find_the_class_they_name() -> None:
    for words in ("robot dog", "Robot-Dog", "robot dogs", "quadruped", "a quadruped robot", "Unitree Go1"):
        assert check_target(words) == words.strip() and target_matches("robot_dog", words), words
    assert not target_matches("robot_dog", "chair") and not target_matches("office_chair", "chair")
    with pytest.raises(SessionError, match="target: 'unicorn' is not an object"):
        SearchConfig("unicorn")  # every door (the agent's too) refuses it
