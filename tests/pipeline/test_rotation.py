"""One yaw <-> quaternion helper (pipeline.rotation, on scipy) in both orders, used by the 3D view and the recording."""

from __future__ import annotations

import math

import pytest
from scipy.spatial.transform import Rotation

from console.recording import recording_schemas as rs
from console.views import objects_view
from pipeline.rotation import quat_wxyz_yaw, quat_xyzw_yaw, yaw_quat_wxyz, yaw_quat_xyzw


@pytest.mark.parametrize("yaw", [0.0, 0.3, -2.0, math.pi - 0.01, 1.5 * math.pi])
def test_both_orders_agree_with_scipy_and_round_trip(yaw: float) -> None:
    x, y, z, w = yaw_quat_xyzw(yaw)
    assert (x, y) == (0.0, 0.0) and Rotation.from_quat((x, y, z, w)).apply((1.0, 0.0, 0.0)) == pytest.approx(
        (math.cos(yaw), math.sin(yaw), 0.0))
    assert yaw_quat_wxyz(yaw) == (w, x, y, z)
    assert quat_xyzw_yaw((x, y, z, w)) == pytest.approx(math.remainder(yaw, math.tau))
    assert quat_wxyz_yaw(yaw_quat_wxyz(yaw)) == pytest.approx(math.remainder(yaw, math.tau))


def test_a_tilted_rotation_gives_the_heading_of_its_x_axis() -> None:
    q = Rotation.from_euler("ZYX", [0.7, 0.2, -0.4]).as_quat()
    assert quat_xyzw_yaw(q) == pytest.approx(0.7)
    assert quat_xyzw_yaw(2.0 * q) == pytest.approx(0.7)  # not normalised


def test_the_view_and_the_recording_use_it() -> None:
    assert objects_view.yaw_wxyz is yaw_quat_wxyz and objects_view.wxyz_yaw is quat_wxyz_yaw
    expected = rs._pose((1.0, 2.0, 0.5), yaw_quat_xyzw(0.9)).encode()
    assert rs._yaw_pose((1.0, 2.0, 0.5), 0.9).encode() == expected
    assert rs._yaw_pose((1.0, 2.0, 0.5), 0.9).encode() != rs._pose((1.0, 2.0, 0.5), yaw_quat_wxyz(0.9)).encode()
