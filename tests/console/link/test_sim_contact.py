"""The simulated robot finds hidden objects by touching them: where it stops and what it says."""

from __future__ import annotations

import math

import pytest

from console.link.base import RunStatus
from console.link.sim import SimConfig, SimRobot
from console.link.sim_contact import BodyContact, contact_text
from console.link.world import BOX_LINE_Y, BOX_SIZE
from pipeline.camera.geometry import Pose
from pipeline.scene import Scene, SceneObject
from planner.mission import MissionSegment, SegmentKind

BOX = SceneObject("b", "cardboard_box", (2.0, 2.0, 0.2), (0.4, 0.4, 0.4), 0.0, "world")
DIAMOND = SceneObject("d", "cardboard_box", (2.0, 2.0, 0.2), (0.4, 0.4, 0.4), math.radians(45), "world")


def test_body_contact_geometry_and_moving_away_is_allowed() -> None:
    body = BodyContact([BOX], radius=0.25, height=0.45)
    assert not body.touches((2.0, 2.5, 0.0))  # 0.3 m from the box's face
    assert body.touches((2.0, 2.4, 0.0))
    assert not body.touches((2.0, 2.0, 0.5))  # above its top (0.4 m)
    assert body.touches((2.0, 2.0, 0.3))  # the body reaches down into it
    hit = body.blocked((2.0, 2.5, 0.0), (2.0, 2.4, 0.0))
    assert hit == pytest.approx((2.0, 2.2, 0.225))  # the point of the face it meets, at the body's mid-height
    corner = 0.2 * math.sqrt(2)  # the yawed box's corner points along x
    diamond = BodyContact([DIAMOND], radius=0.25, height=0.45)
    assert diamond.touches((2.0 + corner + 0.2, 2.0, 0.0)) and not diamond.touches((2.0 + corner + 0.3, 2.0, 0.0))
    assert body.blocked((2.0, 2.4, 0.0), (2.0, 2.45, 0.0)) is None  # stepping back out of contact
    assert body.blocked((2.0, 2.4, 0.0), (2.0, 2.35, 0.0)) is not None  # ... but not further in
    assert contact_text((1.0, 2.345, 0.2)) == "contact with an unmapped obstacle ahead at (1.00, 2.35, 0.20)"
    with pytest.raises(ValueError, match="body radius"):
        BodyContact([BOX], radius=float("nan"), height=0.4)


def test_a_landing_onto_a_hidden_box_stops_in_the_air_at_contact() -> None:
    robot = SimRobot(start=Pose.from_xyz_yaw(2.5, 3.0, 0.0, math.pi / 2),
                     config=SimConfig(spool_time=0.1, settle_time=0.1), manual_clock=True)
    robot.connect()

    def run(seg: MissionSegment) -> object:
        r = robot.run_segment(seg)
        t0 = robot.sim_time
        while not r.done and robot.sim_time - t0 < 60:
            robot.step(0.01)
        return r

    assert run(MissionSegment(SegmentKind.TAKEOFF, ((2.5, 3.0, 0.0), (2.5, 3.0, 1.6)))).status is RunStatus.DONE
    assert run(MissionSegment(SegmentKind.FLY, ((2.5, 3.0, 1.6), (2.5, BOX_LINE_Y, 1.6)))).status is RunStatus.DONE
    r = run(MissionSegment(SegmentKind.LAND, ((2.5, BOX_LINE_Y, 1.6), (2.5, BOX_LINE_Y, 0.0))))
    # the stack's top meets the descending body below it: "contact below" (the centre is over a gap between boxes)
    assert r.status is RunStatus.FAILED and r.error.startswith("landing stopped: contact below at (")
    st = robot.latest_state()
    top = 3 * BOX_SIZE[1]
    assert top - 1e-6 <= st.position[2] <= top + 0.06 and not st.landed  # resting just above the stack, in the air
    assert "box" not in r.error


ROOM = ((0.0, -1.0, 0.0), (5.0, 9.0, 4.0))  # the paper room's shell: walls x = 0 / 5, y = -1 / 9, ceiling 4 m


def test_walls_and_ceiling_are_felt_like_objects_and_moving_away_is_allowed() -> None:
    body = BodyContact([], radius=0.25, height=0.45, room=ROOM)
    assert not body.touches_wall((4.7, 2.0, 0.0)) and body.touches_wall((4.8, 2.0, 0.0))  # 0.25 m from x = 5
    assert body.touches_wall((2.0, 8.8, 0.0)) and not body.touches_wall((2.0, 8.7, 0.0))
    assert body.touches_wall((2.0, 2.0, 3.6)) and not body.touches_wall((2.0, 2.0, 3.5))  # the body's top at 4 m
    assert body.touches_wall((5.3, 2.0, 0.0))  # out of the room
    assert body.blocked((4.74, 2.0, 0.0), (4.78, 2.0, 0.0)) == pytest.approx((5.0, 2.0, 0.225))
    assert body.blocked((0.3, 2.0, 1.0), (0.2, 2.0, 1.0)) == pytest.approx((0.0, 2.0, 1.225))
    assert body.blocked((2.0, 2.0, 3.5), (2.0, 2.0, 3.6)) == pytest.approx((2.0, 2.0, 4.0))
    assert body.blocked((4.8, 2.0, 0.0), (4.7, 2.0, 0.0)) is None  # stepping back from the wall
    assert body.blocked((4.8, 2.0, 0.0), (4.8, 2.5, 0.0)) is None  # along it, no closer
    assert body.blocked((4.8, 2.0, 0.0), (4.85, 2.0, 0.0)) is not None  # ... but not further in
    # objects first, then walls; no room: no walls
    boxed = BodyContact([BOX], radius=0.25, height=0.45, room=ROOM)
    assert boxed.blocked((4.74, 2.0, 0.0), (4.78, 2.0, 0.0)) == pytest.approx((5.0, 2.0, 0.225))
    assert BodyContact([], radius=0.25, height=0.45).blocked((4.74, 2.0, 0.0), (4.9, 2.0, 0.0)) is None
    with pytest.raises(ValueError, match="room"):
        BodyContact([], 0.25, 0.45, room=((0, 0, 0), (5, float("nan"), 3)))
    with pytest.raises(ValueError, match="room: max"):
        BodyContact([], 0.25, 0.45, room=((0, 0, 0), (5, 0, 3)))


def _run(robot: SimRobot, seg: MissionSegment) -> object:
    r = robot.run_segment(seg)
    t0 = robot.sim_time
    while not r.done and robot.sim_time - t0 < 60:
        robot.step(0.01)
    return r


def test_a_walk_into_the_rooms_wall_stops_at_contact_without_naming_it() -> None:
    # the tutorial's old walk ended at x = 4.9 (the workspace's edge x = 5 is the paper room's wall): the
    # 0.25 m body meets the wall at x = 4.75 and the robot stops there
    robot = SimRobot(Scene(objects=()), start=Pose.from_xyz_yaw(4.0, 2.0, 0.0, 0.0), room=ROOM, manual_clock=True)
    robot.connect()
    r = _run(robot, MissionSegment(SegmentKind.WALK, ((4.0, 2.0, 0.0), (4.9, 2.0, 0.0))))
    assert r.status is RunStatus.FAILED
    assert r.error == "walking stopped: contact with an unmapped obstacle ahead at (5.00, 2.00, 0.23)"
    x = robot.latest_state().position[0]
    assert 4.75 - 0.06 <= x <= 4.75 + 1e-6
    # it can walk away from the wall
    here = tuple(float(v) for v in robot.latest_state().position)
    assert _run(robot, MissionSegment(SegmentKind.WALK, (here, (4.0, 2.0, 0.0)))).status is RunStatus.DONE


def test_without_a_room_the_walls_are_not_there() -> None:
    robot = SimRobot(Scene(objects=()), start=Pose.from_xyz_yaw(4.0, 2.0, 0.0, 0.0), room=None, manual_clock=True)
    robot.connect()
    assert _run(robot, MissionSegment(SegmentKind.WALK, ((4.0, 2.0, 0.0), (4.9, 2.0, 0.0)))).status is RunStatus.DONE
