"""Object labels without a browser: a crowded room's labels are chosen so that none overlap, the
selected object's label always shows, zooming in shows more, and every tab chooses for its own view."""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass

import numpy as np
import pytest

from console.views.object_labels import MAX_LABELS, LabelSpot, choose, declutter, label_rect, overlaps, project


@dataclass
class Cam:
    """A viser-like camera (world <- camera, OpenCV optical frame) looking from ``eye`` at ``target``."""

    position: np.ndarray
    wxyz: np.ndarray
    fov: float = 1.0
    image_width: int = 900
    image_height: int = 700


def look(eye: tuple[float, float, float], target: tuple[float, float, float], **kw: float) -> Cam:
    from scipy.spatial.transform import Rotation

    e, t = np.asarray(eye, float), np.asarray(target, float)
    z = (t - e) / np.linalg.norm(t - e)
    x = np.cross(z, (0.0, 0.0, 1.0))
    x /= np.linalg.norm(x)
    y = np.cross(z, x)
    q = Rotation.from_matrix(np.column_stack([x, y, z])).as_quat()  # x, y, z, w
    return Cam(e, np.array([q[3], q[0], q[1], q[2]]), **kw)  # type: ignore[arg-type]


def crowd() -> list[LabelSpot]:
    """Twenty labels on a 1 m x 0.6 m patch: far more than fit side by side from across the room."""
    names = ["office chair", "desk", "suitcase", "cardboard box ×3", "office cabinet"]
    return [LabelSpot(names[n % 5], (2.0 + 0.25 * (n % 4), 4.0 + 0.12 * (n // 4), 0.8), (f"o{n}",)) for n in range(20)]


def test_projection_puts_the_look_at_point_in_the_middle() -> None:
    cam = look((2.5, -2.0, 4.0), (2.5, 4.0, 0.0))
    u, v, depth = project(cam.wxyz, cam.position, cam.fov, cam.image_width, cam.image_height, (2.5, 4.0, 0.0))
    assert (u, v) == pytest.approx((450, 350), abs=1e-6) and depth == pytest.approx(math.dist(cam.position, (2.5, 4, 0)))
    above = project(cam.wxyz, cam.position, cam.fov, cam.image_width, cam.image_height, (2.5, 4.0, 1.0))
    assert above[1] < v  # higher in the world is higher in the picture (y down)
    assert project(cam.wxyz, cam.position, cam.fov, 900, 700, (2.5, -5.0, 4.0)) is None  # behind the camera


def test_declutter_keeps_no_two_overlapping_boxes() -> None:
    rects = [(0, 0, 50, 10), (40, 5, 90, 15), (100, 0, 150, 10), (0, 0, 10, 10)]
    assert declutter(rects, [0, 1, 2, 3]) == [0, 2]
    assert declutter(rects, [1, 0, 2, 3]) == [1, 2, 3]  # the first in the order wins
    assert declutter(rects, [0, 1, 2, 3], reserved=[(95, 0, 160, 12)]) == [0]  # the robot's label is left free
    assert declutter(rects, [0, 2], limit=1) == [0]


def test_a_crowded_room_shows_labels_that_do_not_overlap() -> None:
    spots = crowd()
    far = look((2.5, -3.0, 4.0), (2.4, 4.2, 0.5))
    shown = choose(spots, far)
    assert 1 <= len(shown) < len(spots)  # some are left out, some shown
    for (_, a), (_, b) in itertools.combinations(shown, 2):
        assert not overlaps(a, b, gap=0.0), (a, b)
    # closer, the same objects spread over more pixels: more labels fit
    near = look((2.4, 2.6, 1.3), (2.4, 4.2, 0.8))
    assert len(choose(spots, near)) > len(shown)
    assert len(choose(spots, near)) <= MAX_LABELS


def test_the_selected_objects_label_always_shows_and_labels_leave_the_robots_free() -> None:
    spots = crowd()
    cam = look((2.5, -3.0, 4.0), (2.4, 4.2, 0.5))
    hidden = next(s for i, s in enumerate(spots) if i not in {j for j, _ in choose(spots, cam)})
    shown = choose(spots, cam, selected=hidden.ids[0])
    assert spots[shown[0][0]] is hidden  # first, whatever the crowd
    robot = ("robot · walking", spots[0].position)
    kept = choose(spots, cam, reserved_spots=[robot])
    u, v, _ = project(cam.wxyz, cam.position, cam.fov, cam.image_width, cam.image_height, robot[1])
    box = label_rect(robot[0], u, v)
    assert all(not overlaps(r, box, gap=0.0) for _, r in kept)


def test_a_tab_without_a_camera_yet_shows_none() -> None:
    assert choose(crowd(), Cam(np.zeros(3), np.array([1.0, 0, 0, 0]), 0.0, 0, 0)) == []


# --- every label in the declutter: the robot's, the paths', the goal markers ------------------------------
def test_anchors_place_the_box_where_viser_draws_it() -> None:
    below = label_rect("1. take-off", 100.0, 50.0, anchor="top-center", font_scale=0.75)
    above = label_rect("1. take-off", 100.0, 50.0, anchor="bottom-center", font_scale=0.75)
    assert below[1] == pytest.approx(50.0) and above[3] == pytest.approx(50.0)  # hung below / standing on the point
    assert below[0] + below[2] == pytest.approx(200.0)  # centred
    left = label_rect("x", 100.0, 50.0, anchor="top-left")
    assert left[0] == pytest.approx(100.0) and left[1] == pytest.approx(50.0)


def test_labels_every_tab_shows_are_found_where_they_are_now_and_others_leave_them_free() -> None:
    import viser

    from console.views.object_labels import ClientLabels, FixedLabel, board_for, fixed_labels

    server = viser.ViserServer(port=0, verbose=False)
    try:
        robot = server.scene.add_frame("/robot", position=(2.4, 4.2, 0.0), wxyz=(0.0, 0.0, 0.0, 1.0), show_axes=False)
        server.scene.add_label("/robot/label", "robot · walking", position=(0.0, 0.0, 0.55), anchor="bottom-center",
                               font_screen_scale=0.8)
        server.scene.add_label("/search/viewpoint_why", "next viewpoint: gain 3.1 m³", position=(1.0, 2.0, 0.35))
        found = {f.text: f for f in fixed_labels(server)}
        assert found["robot · walking"].position == pytest.approx((2.4, 4.2, 0.55))  # through its parent frame
        assert found["next viewpoint: gain 3.1 m³"].anchor == "top-left"
        robot.visible = False  # a robot whose position is unknown: its label is not drawn, not reserved
        assert "robot · walking" not in {f.text for f in fixed_labels(server)}

        board = ClientLabels(server, lambda: None)
        assert board_for(server) is board
        spots = crowd()
        cam = look((2.5, -3.0, 4.0), (2.4, 4.2, 0.5))
        free = choose(spots, cam)
        robot_label = FixedLabel("robot · walking", (2.4, 4.2, 0.55))
        around = choose(spots, cam, reserved_spots=[robot_label])
        u, v, _ = project(cam.wxyz, cam.position, cam.fov, cam.image_width, cam.image_height, robot_label.position)
        box = label_rect(robot_label.text, u, v)
        assert any(overlaps(r, box, gap=0.0) for _, r in free)  # without it, a label would be drawn under the robot's
        assert all(not overlaps(r, box, gap=0.0) for _, r in around)
        goal = spots[0].position
        gu, gv, _ = project(cam.wxyz, cam.position, cam.fov, cam.image_width, cam.image_height, goal)
        clear = choose(spots, cam, markers=[goal])
        assert all(not (r[0] - 9 <= gu <= r[2] + 9 and r[1] - 9 <= gv <= r[3] + 9) for _, r in clear)  # marker left free
        hung = LabelSpot("1. take-off", goal, (), "top-center", 0.75)  # a spot's label names the marker it hangs from
        assert choose([hung], cam, markers=[goal]) == [] and len(choose([hung], cam, markers=[goal], marker_exempt=[0])) == 1
        path = LabelSpot("2. take-off · 5. land", (2.4, 4.3, 0.05), (), "top-center", 0.75)
        first = choose([*spots, path], cam, rank=[1] * len(spots) + [0])
        assert first[0][0] == len(spots)  # the paths' label before the objects'
        with pytest.raises(ValueError, match="layer: must be one of search, agent, paths, objects"):
            board.set_layer("route", [path])
        board.close()
    finally:
        server.stop()


def test_no_label_is_drawn_cut_by_the_edge_nor_under_a_phones_sheet() -> None:
    spots = crowd()
    near = look((2.4, 2.6, 1.3), (2.4, 4.2, 0.8))
    shown = choose(spots, near)
    assert shown and all(0 <= r[0] and r[2] <= 900 and 0 <= r[1] and r[3] <= 700 for _, r in shown)
    sheet = (0.0, 0.0, 900.0, 350.0)  # a phone's control sheet over the lower half
    assert any(r[3] > 350 for _, r in shown)  # without it some would be under the sheet
    above = choose(spots, near, frame=sheet)
    assert above and all(r[3] <= 350 for _, r in above)
    from console.views.object_labels import ClientLabels

    phone = Cam(np.zeros(3), np.array([1.0, 0, 0, 0]), 1.0, 390, 844)
    between_panels = Cam(np.zeros(3), np.array([1.0, 0, 0, 0]), 1.0, 580, 720)  # a 1280 x 720 window's 3D view
    assert ClientLabels._frame(phone) == pytest.approx((0, 0, 390, 844 * 0.45))
    assert ClientLabels._frame(between_panels) == (0, 0, 580, 720)
