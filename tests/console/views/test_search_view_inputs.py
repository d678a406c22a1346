"""The Find panel refuses bad fields before a search starts, with the words `morphonavi search` uses for its
options (one check: console/session/search_inputs.py), shown in the clicking tab's notice; good fields start it."""

from __future__ import annotations

from pathlib import Path
from types import SimpleNamespace
from typing import Any

import pytest
import viser

from console.session.search_inputs import CLI_NAMES, search_config
from console.session.search_types import target_height
from console.session.session import Session, SessionError
from console.views.search_view import SearchView


class _Job:
    """What the panel reads and calls of a SearchJob; records the starts."""

    running = paused = waiting_approval = False
    pause_reason = ""
    steps: list[str] = []
    result = None
    chosen = None

    def __init__(self) -> None:
        self.started: list[Any] = []

    def start(self, config: Any) -> None:
        self.started.append(config)

    approve = pause = resume = stop = lambda self: None


class _Tab:
    def __init__(self) -> None:
        self.notices: list[tuple[str, str]] = []

    def add_notification(self, title: str, body: str, *, color: str, auto_close_seconds: Any) -> Any:
        self.notices.append((title, body))
        return SimpleNamespace(remove=lambda: None)


@pytest.fixture()
def panel(tmp_path: Path) -> Any:
    server = viser.ViserServer(host="127.0.0.1", port=0, verbose=False)
    job = _Job()
    view = SearchView(server, Session(tmp_path / "s", autosave=False), job, target_height)  # type: ignore[arg-type]
    try:
        yield view, job
    finally:
        view._refresher.close()
        server.stop()


def _click_start(view: SearchView) -> _Tab:
    tab = _Tab()
    view._act(SimpleNamespace(client=tab), view._start)
    return tab


def _cli_words(**kw: Any) -> str:
    with pytest.raises(SessionError) as err:
        search_config(CLI_NAMES, kw.pop("target", "robot dog"), **kw)
    return str(err.value).split(": ", 1)[1]


@pytest.mark.parametrize("field, value, name, cli", [
    ("target", "unicorn", "Find", {"target": "unicorn"}),
    ("target", "  ", "Find", {"target": ""}),
    ("captures", "0", "Capture budget", {"max_captures": "0"}),
    ("captures", "201", "Capture budget", {"max_captures": "201"}),
    ("reserve", "10", "Battery reserve [%]", {"battery_reserve": "10"}),
    ("reserve", "100", "Battery reserve [%]", {"battery_reserve": "100"}),
    ("minutes", "0.1", "Time budget [min]", None),
])
def test_bad_fields_are_refused_before_starting_in_the_clis_words(panel, field, value, name, cli) -> None:
    view, job = panel
    getattr(view, field).value = value
    tab = _click_start(view)
    assert job.started == []  # nothing started
    assert len(tab.notices) == 1 and tab.notices[0][0] == "Not possible", tab.notices
    body = tab.notices[0][1]
    assert body.startswith(f"{name}: "), body
    if cli is not None:  # the same words (a long notice shows its first clause, up to "; ")
        words = _cli_words(**cli)
        assert body[len(name) + 2:] == words or body[len(name) + 2:].startswith(words.split("; ")[0]), (body, words)
    else:
        assert body == "Time budget [min]: must be a number within 0.5..1440 min, got 0.1"


def test_good_fields_start_the_search_they_show(panel) -> None:
    view, job = panel
    view.target.value, view.mode.value = "quadruped", "step"
    view.captures.value, view.minutes.value, view.reserve.value = "12", "2.5", "40"  # text fields
    tab = _click_start(view)
    assert tab.notices == []
    assert len(job.started) == 1
    cfg = job.started[0]
    assert (cfg.target, cfg.mode, cfg.max_captures, cfg.max_time, cfg.min_battery, cfg.target_height) == (
        "quadruped", "step", 12, 150.0, 0.4, 0.4)


@pytest.mark.parametrize("target, head", [
    ("unicorn", "Find: 'unicorn' is not an object the perception can name"),
    ("a red bicycle", "Find: 'a red bicycle' is not an object the perception can name (did you mean 'bicycle'?)"),
])
def test_an_unknown_target_is_refused_in_a_short_notice_with_the_classes_one_click_away(panel, target, head) -> None:
    from console.views.client_notice import DETAILS_WHERE, forget
    from console.views.notice_details import NoticeDetails

    view, job = panel
    details = NoticeDetails(view._server)
    view.target.value = target
    tab = _Tab()
    tab._viser_server, tab.client_id = view._server, 7301  # type: ignore[attr-defined]
    try:
        view._act(SimpleNamespace(client=tab), view._start)
    finally:
        forget(7301)
    whole = _cli_words(target=target)  # ~750 characters: the reason, then every class the perception can name
    assert len(whole) > 600 and job.started == []
    assert len(tab.notices) == 1 and tab.notices[0][0] == "Not possible", tab.notices
    body = tab.notices[0][1]
    assert len(body) <= 150 and body == f"{head} … ({DETAILS_WHERE})", body
    assert "<li>Find: " in details.text and "robot dog, table, chair" in details.text  # the whole text, one click away
    assert "add it to the catalog (assets/catalog.toml" in details.text and details._folder.visible
