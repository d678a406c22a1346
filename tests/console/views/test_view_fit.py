"""Camera poses that fit the workspace: the default view shows every corner of the flight volume in
the 3D view between the panels at 1280 x 720 and wider; a phone's view keeps the room and the robot
above its control sheet; bad arguments are refused naming the field."""

from __future__ import annotations

import itertools

import pytest

from console.views.screen_layout import PHONE_SHEET_VH, layout_style, phone_view, pin_script
from console.views.view_fit import DEFAULT_DIRECTION, DEFAULT_FOV, default_view, fit_view, in_picture
from planner.grid import Workspace

WS = Workspace((0.0, 0.0, 0.0), (5.0, 8.0, 3.0), 0.25)  # the paper's room


def _corners(ws: Workspace) -> list[tuple[float, float, float]]:
    return list(itertools.product((ws.min[0], ws.max[0]), (ws.min[1], ws.max[1]), (ws.min[2], ws.max[2])))


@pytest.mark.parametrize("aspect", [572 / 720, 732 / 900, 1.0, 1.78])
def test_the_default_view_shows_the_whole_flight_volume(aspect: float) -> None:
    position, look_at, up = default_view(WS, DEFAULT_FOV, min(aspect, 0.75))
    assert up == (0.0, 0.0, 1.0) and position[2] > WS.max[2]  # from above the room
    for corner in _corners(WS):
        x, y = in_picture(position, look_at, DEFAULT_FOV, aspect, corner)
        assert 0.0 < x < 1.0 and 0.0 < y < 1.0, (corner, x, y)


def test_a_fitted_view_is_tight_and_centred() -> None:
    position, look_at, _ = fit_view(WS, DEFAULT_DIRECTION, 1.0, 1.3, margin=0.05)
    pts = [in_picture(position, look_at, 1.0, 1.3, c) for c in _corners(WS)]
    xs, ys = [p[0] for p in pts], [p[1] for p in pts]
    # one pair of sides touches the margin (5 % of the height), the other pair is centred
    assert min(xs) == pytest.approx(1 - max(xs), abs=0.01) and min(ys) == pytest.approx(1 - max(ys), abs=0.01)
    assert min(min(ys), min(xs) * 1.3) == pytest.approx(0.05, abs=0.01)


def test_a_phone_keeps_the_room_and_a_robot_by_the_wall_above_its_sheet() -> None:
    robot = (4.9, 7.9, 2.1)  # hovering at 2.1 m in the far corner
    aspect = 390 / 844
    position, look_at, _ = phone_view(WS, DEFAULT_FOV, aspect, [robot])
    bottom = 1 - PHONE_SHEET_VH / 100
    for p in _corners(WS) + [robot]:
        x, y = in_picture(position, look_at, DEFAULT_FOV, aspect, p)
        assert 0.0 < x < 1.0 and 0.0 < y < bottom, (p, x, y)


def test_bad_arguments_are_refused_naming_the_field() -> None:
    with pytest.raises(ValueError, match="fov: must be in"):
        fit_view(WS, DEFAULT_DIRECTION, 0.0, 1.0)
    with pytest.raises(ValueError, match="aspect: must be > 0"):
        fit_view(WS, DEFAULT_DIRECTION, 1.0, float("nan"))
    with pytest.raises(ValueError, match="frame: must be"):
        fit_view(WS, DEFAULT_DIRECTION, 1.0, 1.0, frame=(0.5, 0.0, 0.4, 1.0))
    with pytest.raises(ValueError, match="direction: must be a non-zero"):
        fit_view(WS, (0.0, 0.0, 0.0), 1.0, 1.0)


def test_the_layout_rules_pin_the_block_by_its_marker() -> None:
    css = layout_style()
    assert "position: sticky" in css and "[data-mn-pin]" in css and "white-space: nowrap" in css
    assert "@media (max-width: 575px)" in css and "made for screens at least 1280 px wide" in css
    assert "scrollPaddingTop" in pin_script()
