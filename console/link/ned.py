"""World frame <-> the vehicle's MAVLink local NED frame.

The world frame is the console's (z up) [m]; MAVLink local positions (LOCAL_POSITION_NED,
SET_POSITION_TARGET_LOCAL_NED with MAV_FRAME_LOCAL_NED) are north, east, down [m] from the
vehicle's EKF origin, and MAVLink yaw is clockwise from north [rad].

The mapping is fixed by two numbers the operator sets once per site:

- ``origin``: the world point [m] where the vehicle's local origin (EKF origin / home) is;
- ``north_yaw``: the direction of north in the world, counter-clockwise from world +x [rad].

With the default ``north_yaw = pi/2`` (world +y points north) the world is ENU around ``origin``:
``north = y - oy``, ``east = x - ox``, ``down = -(z - oz)``, and a world yaw ``psi`` is the NED
yaw ``pi/2 - psi``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Sequence

import numpy as np

Vec3 = tuple[float, float, float]


def _wrap(a: float) -> float:
    return (a + math.pi) % (2 * math.pi) - math.pi


@dataclass(frozen=True)
class NedFrame:
    """How the vehicle's local NED frame sits in the world frame.

    Attributes:
        origin: World position of the NED origin [m].
        north_yaw: Direction of north, counter-clockwise from world +x [rad].
    """

    origin: Vec3 = (0.0, 0.0, 0.0)
    north_yaw: float = math.pi / 2

    def __post_init__(self) -> None:
        if len(self.origin) != 3 or not all(math.isfinite(v) for v in self.origin):
            raise ValueError(f"NED origin must be 3 finite numbers [m], got {self.origin!r}")
        if not math.isfinite(self.north_yaw):
            raise ValueError(f"north_yaw must be finite [rad], got {self.north_yaw!r}")

    @property
    def _axes(self) -> np.ndarray:
        """Rows: world-frame unit vectors of north, east, down."""
        a = self.north_yaw
        return np.array([[math.cos(a), math.sin(a), 0.0],
                         [math.sin(a), -math.cos(a), 0.0],
                         [0.0, 0.0, -1.0]])

    def to_ned(self, p: Sequence[float]) -> Vec3:
        """World point [m] -> local NED [m]."""
        v = self._axes @ (np.asarray(p, dtype=np.float64) - np.asarray(self.origin))
        return (float(v[0]), float(v[1]), float(v[2]))

    def to_world(self, ned: Sequence[float]) -> Vec3:
        """Local NED [m] -> world point [m]."""
        v = self._axes.T @ np.asarray(ned, dtype=np.float64) + np.asarray(self.origin)
        return (float(v[0]), float(v[1]), float(v[2]))

    def velocity_to_world(self, v_ned: Sequence[float]) -> Vec3:
        """NED velocity [m/s] -> world velocity [m/s]."""
        v = self._axes.T @ np.asarray(v_ned, dtype=np.float64)
        return (float(v[0]), float(v[1]), float(v[2]))

    def velocity_to_ned(self, v_world: Sequence[float]) -> Vec3:
        """World velocity [m/s] -> NED velocity [m/s]."""
        v = self._axes @ np.asarray(v_world, dtype=np.float64)
        return (float(v[0]), float(v[1]), float(v[2]))

    def yaw_to_world(self, yaw_ned: float) -> float:
        """MAVLink yaw (clockwise from north) [rad] -> world yaw (counter-clockwise from +x)."""
        return _wrap(self.north_yaw - yaw_ned)

    def yaw_to_ned(self, yaw_world: float) -> float:
        """World yaw [rad] -> MAVLink yaw (clockwise from north) [rad]."""
        return _wrap(self.north_yaw - yaw_world)

    def altitude(self, z_world: float) -> float:
        """Height above the NED origin [m] (MAV_CMD_NAV_TAKEOFF altitude) of a world height."""
        return float(z_world - self.origin[2])


__all__ = ["NedFrame"]
