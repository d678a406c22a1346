"""The objects panel without a browser: proxy meshes follow the scene; selecting puts a drag gizmo on
the object; dropping the gizmo moves the object (keeping its height) and rebuilds the grid."""

from __future__ import annotations

import math
from pathlib import Path

import pytest
import viser

from console.views.objects_view import ObjectsView, label_groups, wxyz_yaw, yaw_wxyz
from console.session.session import Session, SessionError
from pipeline.scene import Scene, SceneObject
from planner.grid import CellState


@pytest.fixture()
def server() -> viser.ViserServer:
    srv = viser.ViserServer(host="127.0.0.1", port=0, verbose=False)
    yield srv
    srv.stop()


@pytest.fixture()
def session(tmp_path: Path) -> Session:
    s = Session(tmp_path / "session", start=(2.5, 0.7, 0.0), autosave=False)
    s.spawn(Scene(objects=(
        SceneObject("crate", "cardboard_box", (1.0, 4.0, 0.3), (0.6, 0.6, 0.6)),
        SceneObject("desk", "desk", (3.5, 6.0, 0.375), (0.7, 0.75, 1.4), yaw=0.3),
    )))
    return s


@pytest.mark.parametrize("yaw", [0.0, 0.3, -2.0, math.pi - 0.01])
def test_yaw_quaternion_round_trip(yaw: float) -> None:
    assert wxyz_yaw(yaw_wxyz(yaw)) == pytest.approx(yaw)


def test_stacked_boxes_share_one_label() -> None:
    stack = [SceneObject(f"b{i}", "cardboard_box", (1.0, 4.0, 0.25 + 0.5 * i), (0.5, 0.5, 0.5)) for i in range(3)]
    groups = label_groups(stack + [SceneObject("far", "cardboard_box", (4.0, 1.0, 0.25), (0.5, 0.5, 0.5))])
    assert sorted(text for text, _, _ in groups) == ["cardboard box", "cardboard box ×3"]
    (pos,) = [p for text, p, _ in groups if text.endswith("×3")]
    assert pos[2] == pytest.approx(1.5 + 0.08)  # above the top box


def test_selection_puts_a_gizmo_on_the_object_and_a_drop_moves_it(server: viser.ViserServer, session: Session) -> None:
    view = ObjectsView(server, session)
    assert view.drawn_ids() == ["crate", "desk"]
    assert view.gizmo_pose() is None

    session.select("desk")
    (x, y, z), yaw = view.gizmo_pose()
    assert (x, y, z) == pytest.approx((3.5, 6.0, 0.375)) and yaw == pytest.approx(0.3)

    old_cell = session.grid.workspace.cell_of((3.5, 6.0, 0.2))
    assert session.grid.state[old_cell] == CellState.OCCUPIED
    notes = view.drop("desk", (1.5, 2.0), 1.2)
    assert isinstance(notes, list)
    desk = session.scene.object("desk")
    assert desk.position == pytest.approx((1.5, 2.0, 0.375))  # same height: it slid on the floor
    assert desk.yaw == pytest.approx(1.2)
    assert session.grid.state[session.grid.workspace.cell_of((1.5, 2.0, 0.2))] == CellState.OCCUPIED
    assert session.grid.state[old_cell] != CellState.OCCUPIED
    (x, y, _), yaw = view.gizmo_pose()  # the gizmo followed the object
    assert (x, y) == pytest.approx((1.5, 2.0)) and yaw == pytest.approx(1.2)

    session.select(None)
    assert view.gizmo_pose() is None


def test_a_refused_drop_keeps_the_object_and_puts_the_gizmo_back(server: viser.ViserServer, session: Session) -> None:
    view = ObjectsView(server, session)
    session.select("crate")
    with pytest.raises(SessionError, match="outside the workspace"):
        view.drop("crate", (40.0, 4.0), 0.0)
    assert session.scene.object("crate").position == pytest.approx((1.0, 4.0, 0.3))
    (x, y, _), _ = view.gizmo_pose()
    assert (x, y) == pytest.approx((1.0, 4.0))

    session.delete_object("desk")  # e.g. in another tab
    with pytest.raises(SessionError, match="no object 'desk'"):
        view.drop("desk", (1.0, 1.0), 0.0)
    assert view.drawn_ids() == ["crate"]


def test_a_click_on_the_gizmo_moves_nothing_and_keeps_the_mission(server: viser.ViserServer,
                                                                   session: Session) -> None:
    view = ObjectsView(server, session)
    session.add_goal((2.5, 2.0, 0.0))
    session.register()
    mission = session.build_mission()
    session.select("desk")
    grid = session.grid
    assert view.drop("desk", (3.5 + 2e-4, 6.0), 0.3 + 2e-4) is None  # released where it was grabbed
    assert session.mission is mission and session.grid is grid
    assert session.scene.object("desk").position == pytest.approx((3.5, 6.0, 0.375))
    assert view.drop("desk", (3.5, 6.0), 0.3 + 2 * math.pi) is None  # a full turn is no turn
    assert view.drop("desk", (3.6, 6.0), 0.3) is not None  # 10 cm is a move
    assert session.grid is not grid


def test_details_say_when_the_floor_contact_was_only_a_bound() -> None:
    from console.views.objects_view import describe
    from pipeline.scene import SceneObject, Source

    def details(distances: dict[str, float]) -> str:
        return describe(SceneObject(id="nightstand-1", label="nightstand", position=(1.0, 2.0, 0.3), size=(0.5, 0.6, 0.4),
                                    source=Source(capture="c1", method="fused", distances=distances)))

    hidden = details({"geometric": 5.1, "ground_contact_bound": 8.58, "fused": 5.2})
    assert "| distance, ground contact (maybe hidden: at most) | 8.58 m |" in hidden
    seen = details({"geometric": 5.1, "ground_contact": 5.0, "fused": 5.05})
    assert "| distance, ground contact | 5.00 m |" in seen and "maybe hidden" not in seen
