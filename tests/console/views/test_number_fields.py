"""Number fields the browser would empty or rewrite never move things with hidden values.

A browser's number input sends nothing for ``abc`` / ``nan`` / ``inf`` (the server kept its last value, even one
from a refused move) and makes ``1e308`` ``1308``. The objects panel's Centre x / y / z and Yaw fields and the Find
panel's budgets are text fields checked on the server: what is typed is what is checked, a bad one is refused
naming its field, and after any refused move the fields show the object's real pose again.
"""

from __future__ import annotations

import math
from pathlib import Path
from types import SimpleNamespace
from typing import Any, Iterator

import pytest
import viser

from console.session.search_types import MAX_CAPTURES, target_height
from console.session.session import Session, SessionError
from console.views import objects_view
from console.views.objects_view import ObjectsView
from console.views.pose_fields import typed_pose
from console.views.search_view import SearchView
from planner.grid import Workspace
from pipeline.scene import Scene, SceneObject

START = (2.5, 0.7, 0.0)  # the robot stands here
DESK = SceneObject("desk-1", "desk", (1.3, 2.98, 0.375), (1.4, 0.75, 0.7))
WS = Workspace()  # 0..5 x 0..8 x 0..3 m


# --- the parser -------------------------------------------------------------------------------------------
@pytest.mark.parametrize(("centre", "yaw", "said"), [
    (("abc", "2.98", "0.375"), "0", "centre.x: must be a number [m], got 'abc'"),
    (("", "2.98", "0.375"), "0", "centre.x: must be a number [m], got ''"),
    (("nan", "2.98", "0.375"), "0", "centre.x: must be a finite number [m], got 'nan'"),
    (("1.3", "-inf", "0.375"), "0", "centre.y: must be a finite number [m], got '-inf'"),
    (("1e308", "2.98", "0.375"), "0", "centre.x: 1e+308 m is far outside the workspace (-1.00 to 6.00 m)"),
    (("1.3", "2.98", "1e309"), "0", "centre.z: must be a finite number [m], got '1e309'"),
    (("1.3", "2.98", "0.375"), "inf", "yaw: must be a finite number [deg], got 'inf'"),
    (("1.3", "2.98", "0.375"), "1e308", "yaw: must be within -360..360 deg, got '1e308'"),
])
def test_junk_and_out_of_range_text_is_refused_naming_the_field(centre, yaw, said) -> None:
    with pytest.raises(SessionError) as refused:
        typed_pose(centre, yaw, WS)
    assert str(refused.value) == said


def test_good_text_gives_the_pose_in_metres_and_radians() -> None:
    (x, y, z), yaw = typed_pose((" 1.30", "2.98 ", "-0.5"), "90", WS)
    assert (x, y, z) == (1.3, 2.98, -0.5) and yaw == pytest.approx(math.pi / 2)


# --- the objects panel --------------------------------------------------------------------------------------
@pytest.fixture()
def server() -> Iterator[viser.ViserServer]:
    srv = viser.ViserServer(host="127.0.0.1", port=0, verbose=False)
    yield srv
    srv.stop()


@pytest.fixture()
def view(server: viser.ViserServer, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Any:
    session = Session(tmp_path / "s", start=START, autosave=False)
    session.spawn(Scene(objects=(DESK,)))
    told: list[tuple[str, str]] = []
    monkeypatch.setattr(objects_view, "tell", lambda client, title, body, *a, **k: told.append((title, body)))
    v = ObjectsView(server, session)
    session.select("desk-1")
    return v, session, told


def _type(v: ObjectsView, x: str, y: str, z: str, yaw: str) -> None:
    """What the tab sends: the text in each field, as typed."""
    for handle, text in zip((*v._pose.centre, v._pose.yaw), (x, y, z, yaw)):
        handle.value = text


def _shown(v: ObjectsView) -> tuple[str, ...]:
    return tuple(str(h.value) for h in (*v._pose.centre, v._pose.yaw))


def test_the_fields_are_text_showing_the_selected_objects_pose(view) -> None:
    v, _session, _told = view
    assert _shown(v) == ("1.300", "2.980", "0.375", "0.0")


def test_after_a_refused_move_junk_in_x_moves_nothing_and_the_fields_show_the_real_pose(view) -> None:
    v, session, told = view
    _type(v, "2.50", "1.60", "0.375", "0")  # over the robot at (2.5, 0.7): refused
    v._on_move(SimpleNamespace(client=None))
    assert told[-1][0] == "Cannot move" and "overlap the robot" in told[-1][1]
    assert _shown(v) == ("1.300", "2.980", "0.375", "0.0")  # the real pose again, not the refused one
    _type(v, "abc", "2.98", "0.375", "0")
    v._on_move(SimpleNamespace(client=None))
    assert told[-1] == ("Cannot move", "centre.x: must be a number [m], got 'abc'")
    assert session.scene.object("desk-1").position == DESK.position
    assert _shown(v) == ("1.300", "2.980", "0.375", "0.0")


@pytest.mark.parametrize(("field", "text", "said"), [
    (0, "nan", "centre.x: must be a finite number [m], got 'nan'"),
    (0, "1e308", "centre.x: 1e+308 m is far outside the workspace (-1.00 to 6.00 m)"),
    (3, "inf", "yaw: must be a finite number [deg], got 'inf'"),
    (3, "1e308", "yaw: must be within -360..360 deg, got '1e308'"),
])
def test_nan_inf_and_huge_numbers_are_refused_not_rewritten(view, field, text, said) -> None:
    v, session, told = view
    typed = ["1.30", "2.98", "0.375", "0"]
    typed[field] = text
    _type(v, *typed)
    v._on_move(SimpleNamespace(client=None))
    assert told == [("Cannot move", said)]
    desk = session.scene.object("desk-1")
    assert (desk.position, desk.yaw) == (DESK.position, DESK.yaw)


def test_a_good_typed_pose_moves_the_object(view) -> None:
    v, session, told = view
    _type(v, "1.50", "3.20", "0.375", "90")
    v._on_move(SimpleNamespace(client=None))
    assert told[-1][0] == "Moved desk", told
    moved = session.scene.object("desk-1")
    assert moved.position == pytest.approx((1.5, 3.2, 0.375)) and moved.yaw == pytest.approx(math.pi / 2)
    assert _shown(v) == ("1.500", "3.200", "0.375", "90.0")


# --- the Find panel's budgets ---------------------------------------------------------------------------------
class _Job:
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
def panel(server: viser.ViserServer, tmp_path: Path) -> Any:
    job = _Job()
    v = SearchView(server, Session(tmp_path / "s", autosave=False), job, target_height)  # type: ignore[arg-type]
    try:
        yield v, job
    finally:
        v._refresher.close()


@pytest.mark.parametrize(("field", "text", "said"), [
    ("captures", "nan", f"Capture budget: must be a whole number within 1..{MAX_CAPTURES}, got nan"),
    ("captures", "1e309", f"Capture budget: must be a whole number within 1..{MAX_CAPTURES}, got 1e309"),
    ("captures", "abc", f"Capture budget: must be a whole number within 1..{MAX_CAPTURES}, got abc"),
    ("minutes", "nan", "Time budget [min]: must be a number within 0.5..1440 min, got nan"),
    ("minutes", "1e308", "Time budget [min]: must be a number within 0.5..1440 min, got 1e308"),
    ("reserve", "1e309", "Battery reserve [%]: must be at least"),
])
def test_a_budget_the_browser_would_empty_or_rewrite_is_refused_naming_it(panel, field, text, said) -> None:
    v, job = panel
    assert isinstance(getattr(v, field).value, str)  # a text field: the browser sends what was typed
    getattr(v, field).value = text
    tab = _Tab()
    v._act(SimpleNamespace(client=tab), v._start)
    assert job.started == []
    assert len(tab.notices) == 1 and tab.notices[0][1].startswith(said), tab.notices


def test_the_budgets_start_as_the_text_they_show(panel) -> None:
    v, job = panel
    assert (v.captures.value, v.minutes.value, v.reserve.value) == ("20", "15", "30")
    v._act(SimpleNamespace(client=_Tab()), v._start)
    assert (job.started[0].max_captures, job.started[0].max_time, job.started[0].min_battery) == (20, 900.0, 0.3)
