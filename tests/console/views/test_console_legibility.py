"""What the operator reads and clicks, without a browser: plain words and plurals, natural order of
object ids, photo labels that never pile up, the depth scale, the fly segments' peak height,
where notifications go and how long they stay, the "disconnected" banner, goal picking through
objects, typed goals, the top view, goal drop lines, the selection highlight and the object list."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import viser

from console.views.capture_view import PANEL_WIDTH, depth_with_scale, frustum_photo
from console.views.client_notice import DISCONNECTED_TEXT, notice_seconds, page_style, tell
from console.views.mission_view import segment_table
from console.views.objects_view import NONE_CHOICE, ObjectsView
from console.views.photo_marks import BAR_WIDTH, box_clusters, depth_colorbar, depth_colors, nice_ticks, photo_labels
from console.views.picking import click_intent, drop_lines, ray_plane, top_view, typed_goal
from console.session.session import Session, SessionError
from console.wording import mode_text, natural_sorted, plural
from pipeline.scene import Scene, SceneObject
from planner.grid import Workspace
from planner.mission import Mission, MissionSegment, SegmentKind


# --- words -------------------------------------------------------------------------------------------
def test_counts_have_the_right_plural_and_modes_read_as_words() -> None:
    assert plural(1, "segment") == "1 segment" and plural(0, "segment") == "0 segments"
    assert plural(2, "object") == "2 objects" and plural(1, "object") == "1 object"
    assert plural(3, "box", "boxes") == "3 boxes" and plural(1, "box", "boxes") == "1 box"
    assert mode_text("taking_off") == "taking off" and mode_text("IDLE") == "idle"
    assert mode_text(SegmentKind.TAKEOFF) == "takeoff" and mode_text(None) == "unknown" and mode_text("") == "unknown"


def test_object_ids_sort_by_their_numbers() -> None:
    assert natural_sorted(["11", "2", "10", "1"]) == ["1", "2", "10", "11"]
    ids = ["cap-2-box10", "cap-2-box2", "cap-10-box1", "cap-2-box1", "Desk", "chair"]
    assert natural_sorted(ids) == ["cap-2-box1", "cap-2-box2", "cap-2-box10", "cap-10-box1", "chair", "Desk"]


# --- the mission table -----------------------------------------------------------------------------
def _over_the_boxes() -> Mission:
    return Mission(segments=(
        MissionSegment(SegmentKind.WALK, ((2.5, 0.7, 0.0), (2.1, 3.4, 0.0))),
        MissionSegment(SegmentKind.TAKEOFF, ((2.1, 3.4, 0.0), (2.1, 3.4, 0.4))),
        MissionSegment(SegmentKind.FLY, ((2.1, 3.4, 0.4), (2.1, 3.6, 1.9), (2.1, 4.4, 1.9), (2.1, 4.6, 0.4))),
        MissionSegment(SegmentKind.LAND, ((2.1, 4.6, 0.4), (2.1, 4.6, 0.0))),
    ))


def test_a_fly_segment_says_how_high_it_climbs() -> None:
    table = segment_table(_over_the_boxes())
    fly_row = next(line for line in table.splitlines() if "fly |" in line)
    assert "(2.1, 3.4, 0.4) →<br>(2.1, 4.6, 0.4)<br>**max 1.9 m**" in fly_row  # one a line: the columns fit the panel
    assert sum("max " in line for line in table.splitlines()) == 1  # only the fly segment
    assert "4 segments" in table
    one = Mission(segments=(MissionSegment(SegmentKind.WALK, ((0.5, 0.5, 0.0), (1.5, 0.5, 0.0))),))
    assert "1 segment," in segment_table(one) and "1 segments" not in segment_table(one)


# --- photo labels and the depth scale ------------------------------------------------------------
def _box_wall() -> list[tuple[str, float, tuple[float, float, float, float]]]:
    """19 touching cardboard boxes (the line of boxes seen from the start) and two other objects."""
    dets = []
    for k in range(19):
        col, row = k % 7, k // 7
        x, y = 20 + 60 * col, 40 + 45 * row
        dets.append(("cardboard_box", 1.0, (x, y, x + 60, y + 45)))
    dets.append(("desk", 0.93, (10, 200, 120, 300)))
    dets.append(("office_chair", 0.88, (300, 190, 380, 300)))
    return dets


def test_photo_labels_merge_a_stack_of_boxes_and_never_overlap() -> None:
    dets = _box_wall()
    labels, skipped = photo_labels(dets, 480, 320)
    texts = [lab.text for lab in labels]
    assert "cardboard box ×19" in texts and sum("cardboard" in t for t in texts) == 1
    assert "desk 0.93" in texts and "office chair 0.88" in texts and skipped == 0
    for i, a in enumerate(labels):
        assert 0 <= a.rect[0] and a.rect[2] <= 480 and 0 <= a.rect[1] and a.rect[3] <= 320
        for b in labels[:i]:
            assert not (a.rect[0] < b.rect[2] and b.rect[0] < a.rect[2] and a.rect[1] < b.rect[3] and b.rect[1] < a.rect[3])


def test_a_label_with_no_free_place_is_left_out_not_printed_over_another() -> None:
    # two different classes with the same box: every place for the second label is taken by the first
    dets = [("desk", 0.9, (100.0, 100.0, 200.0, 200.0)), ("table", 0.8, (100.0, 100.0, 200.0, 200.0)),
            ("chair", 0.7, (100.0, 100.0, 200.0, 200.0)), ("lamp", 0.6, (100.0, 100.0, 200.0, 200.0))]
    labels, skipped = photo_labels(dets, 480, 320)
    assert [lab.label for lab in labels] == ["desk", "table", "chair"] and skipped == 1  # above, inside, below
    assert box_clusters([("a", 1.0, (0, 0, 10, 10)), ("a", 1.0, (50, 50, 60, 60)), ("a", 1.0, (10, 0, 20, 10))]) == [[0, 2], [1]]


def test_the_depth_picture_has_a_scale_in_metres() -> None:
    assert nice_ticks(0.8, 8.2) == [1.0, 3.0, 5.0, 7.0] or nice_ticks(0.8, 8.2) == [2.0, 4.0, 6.0, 8.0]
    assert nice_ticks(1.0, 1.0) == [] and nice_ticks(math.nan, 2.0) == []
    bar, ticks = depth_colorbar(0.8, 8.2, 300)
    assert bar.shape == (300, BAR_WIDTH, 3) and len(ticks) >= 3
    values = [v for v, _ in ticks]
    rows = [r for _, r in ticks]
    assert values == sorted(values) and rows == sorted(rows) and 0.8 <= values[0] and values[-1] <= 8.2
    for v, row in ticks:  # the bar's colour at a tick is the depth picture's colour for that depth
        assert np.abs(bar[row, 10].astype(int) - depth_colors(np.array([v]), 0.8, 8.2)[0].astype(int)).max() <= 12
    near_rgb, far_rgb = depth_colors(np.array([0.8, 8.2]), 0.8, 8.2)
    assert near_rgb[0] > near_rgb[2] and far_rgb[2] > far_rgb[0]  # warm near, cold far
    depth = np.linspace(1.0, 5.0, 240 * 320, dtype=np.float32).reshape(240, 320)
    img, near, far = depth_with_scale(depth)
    assert img.shape[1] == PANEL_WIDTH and 1.0 <= near < far <= 5.0
    assert (img[:, -BAR_WIDTH:] == 255).mean() > 0.5  # the white scale strip with its bar and ticks


def test_the_photo_on_the_frustum_is_see_through() -> None:
    photo = np.full((480, 640, 3), 200, np.uint8)
    thumb = frustum_photo(photo)
    assert thumb.shape == (180, 240, 4) and 0 < thumb[..., 3].max() < 255
    with pytest.raises(ValueError, match="alpha"):
        frustum_photo(photo, alpha=1.5)


# --- notifications and the disconnected banner ----------------------------------------------------
class _Client:
    def __init__(self) -> None:
        self.shown: list[tuple[str, str, Any]] = []

    def add_notification(self, title: str, body: str, *, color: str, auto_close_seconds: Any) -> None:
        self.shown.append((title, color, auto_close_seconds))


def test_every_notice_closes_by_itself_errors_last() -> None:
    # errors used to stay until closed and stacked over the 3D view (tests/console/views/test_notices.py)
    assert notice_seconds("red") > notice_seconds("blue") == notice_seconds("yellow") > 0
    c = _Client()
    tell(c, "Saved", "x", "green")
    tell(c, "Not saved", "disk full", "red")
    tell(c, "Busy", "x", "yellow", 4.0)
    tell(None, "nobody", "x")  # an event without a tab: nothing, no error
    assert c.shown == [("Saved", "green", notice_seconds("green")), ("Not saved", "red", notice_seconds("red")),
                       ("Busy", "yellow", 4.0)]


def test_the_page_style_moves_notifications_aside_and_has_a_disconnected_banner() -> None:
    css = page_style(370)
    assert ".mantine-Notifications-root" in css and "bottom: 1em" in css and "calc(370px + 1em)" in css
    assert "top: auto" in css and "left: auto" in css
    assert 'pointer-events: none' in css and ":has(" in css and DISCONNECTED_TEXT in css


# --- goals: through objects, typed, top view, drop lines ---------------------------------------------
def test_in_goal_mode_a_click_goes_through_objects_and_shift_selects() -> None:
    assert click_intent(True, None, on_object=True) == "goal"
    assert click_intent(True, None, on_object=False) == "goal"
    assert click_intent(True, "shift", on_object=True) == "select"
    assert click_intent(True, "shift", on_object=False) is None
    assert click_intent(False, None, on_object=True) == "select"
    assert click_intent(False, None, on_object=False) is None
    assert click_intent(True, "cmd/ctrl", on_object=True) is None


def test_a_ray_through_a_box_picks_the_floor_behind_it(tmp_path: Path) -> None:
    session = Session(tmp_path / "s", start=(2.5, 0.7, 0.0), autosave=False)
    session.spawn(Scene(objects=(SceneObject("wall", "cardboard_box", (2.5, 4.0, 0.6), (0.5, 1.2, 4.0)),)))
    eye = np.array([0.4, -1.7, 4.3])  # the default view's camera, behind and above the start
    behind = np.array([2.5, 4.8, 0.0])  # the floor just behind the box line
    d = behind - eye
    # the ray passes through the box (x in its width, 0 < z < 1.2 m where y crosses 3.75..4.25)
    t = (4.0 - eye[1]) / d[1]
    assert 0.0 < (eye + t * d)[2] < 1.2
    goal = session.goal_from_ray(eye, d)
    assert goal == pytest.approx((2.5, 4.8, 0.0), abs=1e-9)
    session.set_goal_mode("altitude", 1.5)
    high = session.goal_from_ray(eye, d)
    assert high[2] == pytest.approx(1.5) and high == pytest.approx(ray_plane(eye, d, 1.5))
    assert session.add_goal(goal).ok  # planned past the box


def test_typed_goals_are_checked_field_by_field() -> None:
    ws = Workspace()
    assert typed_goal((2.5, "5.7", 0), ws) == (2.5, 5.7, 0.0)
    for values, match in [((2.5, math.nan, 0.0), r"goal\.y: must be a finite"), (("a", 1.0, 0.0), r"goal\.x: must be a number"),
                          ((2.5, 9.0, 0.0), r"goal\.y: 9\.00 m is outside the workspace"), ((1.0, 1.0), "three numbers"),
                          ((1.0, 1.0, -0.5), r"goal\.z"), ((True, 1.0, 0.0), r"goal\.x"), (None, "three numbers")]:
        with pytest.raises(SessionError, match=match):
            typed_goal(values, ws)


def test_the_top_view_looks_straight_down_on_the_whole_flight_volume() -> None:
    ws = Workspace()
    vfov, aspect = math.radians(50.0), 740 / 900
    position, look_at, up = top_view(ws, vfov, aspect)
    forward = np.subtract(look_at, position)
    forward /= np.linalg.norm(forward)
    assert forward[2] < -0.9999 and up == (0.0, 0.0, 1.0)  # straight down
    assert position[2] > ws.max[2]
    for corner in [(ws.min[0], ws.min[1]), (ws.max[0], ws.min[1]), (ws.min[0], ws.max[1]), (ws.max[0], ws.max[1])]:
        for z in (ws.floor, ws.max[2]):  # the whole flight volume: its top corners are the nearest to the camera
            dz = position[2] - z
            assert abs(corner[1] - look_at[1]) / dz <= math.tan(vfov / 2) + 1e-6  # within the vertical fov
            assert abs(corner[0] - look_at[0]) / dz <= math.tan(vfov / 2) * aspect + 1e-6  # and the horizontal
    with pytest.raises(SessionError, match="fov"):
        top_view(ws, 0.0, 1.0)


def test_goals_in_the_air_get_a_drop_line_to_the_floor() -> None:
    lines = drop_lines([(1.0, 2.0, 1.5), (2.0, 3.0, 0.0), (3.0, 3.0, 0.75)], floor=0.0)
    assert lines.shape == (2, 2, 3)
    assert lines[0].tolist() == [[1.0, 2.0, 1.5], [1.0, 2.0, 0.0]] and lines[1, 1].tolist() == [3.0, 3.0, 0.0]
    assert drop_lines([], 0.0).shape == (0, 2, 3)


# --- the object list and the highlight ----------------------------------------------------------
@pytest.fixture()
def server() -> viser.ViserServer:
    srv = viser.ViserServer(host="127.0.0.1", port=0, verbose=False)
    yield srv
    srv.stop()


def test_the_list_is_in_natural_order_and_deselect_clears_it(server: viser.ViserServer, tmp_path: Path) -> None:
    session = Session(tmp_path / "s", start=(2.5, 0.7, 0.0), autosave=False)
    objs = tuple(SceneObject(f"box{n}", "cardboard_box", (0.5 + 0.4 * (n % 10), 3.0 + 0.8 * (n // 10), 0.2), (0.3, 0.4, 0.3))
                 for n in (1, 2, 10, 11))
    session.spawn(Scene(objects=objs))
    view = ObjectsView(server, session)
    assert list(view._chooser.options) == [NONE_CHOICE, "box1", "box2", "box10", "box11"]
    assert view.highlighted() is None
    session.select("box10")
    assert view.chooser_value() == "box10" and view.highlighted() == "box10"
    session.select(None)  # what the Deselect button does
    assert view.chooser_value() == NONE_CHOICE and view.highlighted() is None
    session.select("box2")
    session.delete_object("box2")
    assert view.chooser_value() == NONE_CHOICE and "box2" not in view._chooser.options
    assert "3 objects" in view._summary.content
    session.delete_object("box1")
    session.delete_object("box10")
    assert "1 object<" in view._summary.content
