"""The agent's view of what is not seen yet: nothing before a capture, then the share seen and the
frontier (seen-free floor beside unseen floor), nearest the robot first."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from console.link.world import paper_room
from console.mcp.door import AgentDoor
from console.mcp.state_read import robot_pose
from console.mcp.unseen import frontier_floor
from console.session.session import Session
from pipeline.camera.geometry import CameraMount, Intrinsics, Pose, camera_pose_in_world
from pipeline.mapping.known_space import KnownState


@pytest.fixture()
def door(tmp_path: Path) -> AgentDoor:
    s = Session(tmp_path / "s")
    s.spawn(paper_room(), origin="test")
    d = AgentDoor(s, runner=None, robot_spec="sim")
    yield d
    d.close()


def test_frontier_is_seen_free_floor_beside_unseen_floor() -> None:
    state = np.full((5, 4, 2), KnownState.UNKNOWN, dtype=np.int8)
    state[0:2, :, 0] = KnownState.FREE  # two seen-free rows; row 1 borders unseen row 2
    state[4, 0, 0] = KnownState.OCCUPIED
    cells = {tuple(c) for c in frontier_floor(state)}
    assert cells == {(1, 0), (1, 1), (1, 2), (1, 3)}


def test_unseen_space_before_and_after_a_capture(door: AgentDoor) -> None:
    before = door.call("unseen_space")
    assert before["known"] is False and before["frontier"] == [] and "fully known" in before["text"]
    session = door.session
    robot = Pose.from_xyz_yaw(2.5, 1.0, 0.0, math.pi / 2)  # looking +y, down the room
    camera = camera_pose_in_world(robot, CameraMount())
    intr = Intrinsics(320.0, 320.0, 320.0, 240.0, 640, 480)
    session.observe_capture("0001", None, intr, camera, robot)  # the mapped boxes bound the rays
    after = door.call("unseen_space")
    assert after["known"] is True and after["policy"] == "closed"
    assert 0.0 < after["seen_share"] < 1.0 and 0.0 < after["floor_seen_share"] < 1.0
    c = after["cells"]
    assert c["free"] > 0 and c["unknown"] > 0 and c["total"] == c["free"] + c["occupied"] + c["unknown"]
    front = np.asarray(after["frontier"])
    assert after["frontier_cells"] >= len(front) > 0 and front.shape[1] == 3
    rx, ry, _, _ = robot_pose(session)  # no live robot here: the route's start
    d = np.hypot(front[:, 0] - rx, front[:, 1] - ry)
    assert np.all(np.diff(d) >= -1e-9)  # nearest the robot first
    space = session.known_space
    for x, y, _z in front:  # each point is seen-free floor
        i, j, k = space.cell_of((x, y, space.origin[2] + 0.5 * space.resolution))
        assert space.state()[i, j, k] == KnownState.FREE
