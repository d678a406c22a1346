"""Heading <-> quaternion in one place, on scipy's :class:`~scipy.spatial.transform.Rotation`.

A heading (yaw) [rad] is a turn counter-clockwise about the frame's +z axis (world and robot frames, z up:
ROS REP 103). Two quaternion orders are in use and every name here says which:

- ``xyzw`` (scalar last): scipy, ROS, Foxglove / MCAP messages, the scene file's ``camera_quaternion``;
- ``wxyz`` (scalar first): viser's scene nodes.
"""

from __future__ import annotations

import warnings
from typing import Sequence

import numpy as np
from scipy.spatial.transform import Rotation

Quat = tuple[float, float, float, float]


def yaw_quat_xyzw(yaw: float) -> Quat:
    """Quaternion ``(x, y, z, w)`` of a turn by ``yaw`` [rad] about +z."""
    x, y, z, w = Rotation.from_euler("z", float(yaw)).as_quat()
    return (float(x), float(y), float(z), float(w))


def yaw_quat_wxyz(yaw: float) -> Quat:
    """Quaternion ``(w, x, y, z)`` of a turn by ``yaw`` [rad] about +z."""
    x, y, z, w = yaw_quat_xyzw(yaw)
    return (w, x, y, z)


def quat_xyzw_yaw(xyzw: Sequence[float]) -> float:
    """Heading [rad] in ``(-pi, pi]`` about +z of a rotation given as ``(x, y, z, w)``: the first angle of
    its intrinsic z-y'-x'' (yaw, pitch, roll) decomposition, so a tilted rotation gives the heading of its x axis."""
    q = np.asarray(xyzw, dtype=np.float64).reshape(4)
    with warnings.catch_warnings():  # pitched by +-90 deg (gimbal lock): the heading is still returned
        warnings.simplefilter("ignore", UserWarning)
        return float(Rotation.from_quat(q).as_euler("ZYX")[0])


def quat_wxyz_yaw(wxyz: Sequence[float]) -> float:
    """Heading [rad] about +z of a rotation given as ``(w, x, y, z)`` (see :func:`quat_xyzw_yaw`)."""
    w, x, y, z = (float(v) for v in wxyz)
    return quat_xyzw_yaw((x, y, z, w))


GLTF_TO_OBJECT_XYZW: Quat = (0.5, 0.5, 0.5, 0.5)
"""Rotation (order ``[x, y, z, w]``) from a y-up glTF model's axes to the object frame: glTF X (left) -> y,
Y (up) -> z, Z (forward) -> x (120 deg about (1, 1, 1))."""


def yaw_gltf_quat_wxyz(yaw: float) -> Quat:
    """``(w, x, y, z)`` placing a y-up glTF proxy model in a z-up scene turned by ``yaw`` [rad] about +z (scale it
    by ``[w, h, l]`` along its own axes)."""
    x, y, z, w = (Rotation.from_euler("z", float(yaw)) * Rotation.from_quat(GLTF_TO_OBJECT_XYZW)).as_quat()
    return (float(w), float(x), float(y), float(z))


__all__ = ["GLTF_TO_OBJECT_XYZW", "Quat", "quat_wxyz_yaw", "quat_xyzw_yaw", "yaw_gltf_quat_wxyz", "yaw_quat_wxyz",
           "yaw_quat_xyzw"]
