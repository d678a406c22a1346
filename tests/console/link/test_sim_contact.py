"""The simulated robot finds hidden objects by touching them: where it stops and what it says."""

from __future__ import annotations

import math

import pytest

from console.link.base import RunStatus
from console.link.sim import SimConfig, SimRobot
from console.link.sim_contact import BodyContact, contact_text
from console.link.world import BOX_LINE_Y, BOX_SIZE
from pipeline.camera.geometry import Pose
from pipeline.scene import SceneObject
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
    assert r.status is RunStatus.FAILED and r.error.startswith("landing stopped: contact with an unmapped obstacle")
    st = robot.latest_state()
    top = 3 * BOX_SIZE[1]
    assert top - 1e-6 <= st.position[2] <= top + 0.06 and not st.landed  # resting just above the stack, in the air
    assert "box" not in r.error
