"""Cameras and frames: intrinsics, rigid poses, camera -> robot -> world, (back-)projection.

Frames:
- camera: OpenCV optical frame, x right, y down, z forward [m];
- robot: body frame, x forward, y left, z up [m] (REP-103);
- world: the console's frame, z up [m].

Rotations use :class:`scipy.spatial.transform.Rotation` (no hand-rolled Euler code).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Mapping, Sequence

import numpy as np
from scipy.spatial.transform import Rotation


class CameraError(ValueError):
    """Invalid camera intrinsics, mount or pose."""


@dataclass(frozen=True)
class Intrinsics:
    """Pinhole intrinsics of one image [px]; ``dist`` = OpenCV distortion coefficients."""

    fx: float
    fy: float
    cx: float
    cy: float
    width: int
    height: int
    dist: tuple[float, ...] = ()

    def __post_init__(self) -> None:
        for name in ("fx", "fy", "cx", "cy"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
                raise CameraError(f"intrinsics.{name}: must be a finite number, got {v!r}")
        if self.fx <= 0 or self.fy <= 0:
            raise CameraError(f"intrinsics: focal lengths must be > 0, got fx={self.fx}, fy={self.fy}")
        for name in ("width", "height"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, (int, np.integer)):
                raise CameraError(f"intrinsics.{name}: must be a whole number of pixels, got {v!r}")
        if self.width <= 0 or self.height <= 0:
            raise CameraError(f"intrinsics: image size must be > 0, got {self.width}x{self.height}")
        if not (0 <= self.cx <= self.width and 0 <= self.cy <= self.height):
            raise CameraError(
                f"intrinsics: principal point ({self.cx}, {self.cy}) lies outside the "
                f"{self.width}x{self.height} image"
            )
        if len(self.dist) not in (0, 4, 5, 8, 12, 14):
            raise CameraError(f"intrinsics.dist: expected 0, 4, 5, 8, 12 or 14 coefficients, got {len(self.dist)}")
        for i, d in enumerate(self.dist):
            if isinstance(d, bool) or not isinstance(d, (int, float)) or not math.isfinite(d):
                raise CameraError(f"intrinsics.dist[{i}]: must be a finite number, got {d!r}")

    @property
    def K(self) -> np.ndarray:
        """3x3 camera matrix."""
        return np.array([[self.fx, 0, self.cx], [0, self.fy, self.cy], [0, 0, 1]], dtype=np.float64)

    @staticmethod
    def from_K(K: Sequence[Sequence[float]], width: int, height: int, dist: Sequence[float] = ()) -> "Intrinsics":
        k = np.asarray(K, dtype=np.float64)
        if k.shape != (3, 3):
            raise CameraError(f"intrinsics: K must be 3x3, got shape {k.shape}")
        return Intrinsics(float(k[0, 0]), float(k[1, 1]), float(k[0, 2]), float(k[1, 2]), int(width), int(height), tuple(dist))

    def scaled(self, width: int, height: int) -> "Intrinsics":
        """The same camera for an image resized to ``width`` x ``height``."""
        sx, sy = width / self.width, height / self.height
        return Intrinsics(self.fx * sx, self.fy * sy, self.cx * sx, self.cy * sy, width, height, self.dist)

    def check_image(self, width: int, height: int) -> None:
        """Raise if an image of this size does not match these intrinsics."""
        if (width, height) != (self.width, self.height):
            hint = ""
            if width * self.height == height * self.width or abs(width / self.width - height / self.height) < 0.01:
                hint = (f" (resized by {width / self.width:.3g}? the intrinsics must be for the image as given: "
                        f"scale fx, fy, cx, cy and width, height by the same factor)")
            elif (width, height) == (self.height, self.width):
                hint = " (rotated? the intrinsics describe the upright image, EXIF orientation applied)"
            raise CameraError(
                f"intrinsics.width x intrinsics.height: the intrinsics are for a {self.width}x{self.height} image "
                f"but the image is {width}x{height}{hint}"
            )

    def to_dict(self) -> dict[str, float]:
        return {"fx": self.fx, "fy": self.fy, "cx": self.cx, "cy": self.cy,
                "width": self.width, "height": self.height}

    def undistort_pixels(self, uv: np.ndarray) -> np.ndarray:
        """Pixel coordinates with lens distortion removed (identity without ``dist``)."""
        uv = np.asarray(uv, dtype=np.float64).reshape(-1, 2)
        if not self.dist or not any(self.dist):
            return uv
        import cv2

        pts = cv2.undistortPoints(uv.reshape(-1, 1, 2), self.K, np.asarray(self.dist), P=self.K)
        return pts.reshape(-1, 2)

    @property
    def hfov(self) -> float:
        """Horizontal field of view [rad]."""
        return 2.0 * math.atan2(self.width / 2.0, self.fx)

    @property
    def vfov(self) -> float:
        """Vertical field of view [rad]."""
        return 2.0 * math.atan2(self.height / 2.0, self.fy)


@dataclass(frozen=True)
class Pose:
    """A rigid transform ``parent <- child``: ``p_parent = R @ p_child + t``."""

    translation: tuple[float, float, float] = (0.0, 0.0, 0.0)
    quaternion: tuple[float, float, float, float] = (0.0, 0.0, 0.0, 1.0)  # x, y, z, w

    @property
    def rotation(self) -> Rotation:
        return Rotation.from_quat(self.quaternion)

    @staticmethod
    def from_rotation(rotation: Rotation, translation: Sequence[float] = (0.0, 0.0, 0.0)) -> "Pose":
        q = rotation.as_quat()
        t = tuple(float(v) for v in translation)
        return Pose((t[0], t[1], t[2]), (float(q[0]), float(q[1]), float(q[2]), float(q[3])))

    @staticmethod
    def from_xyz_yaw(x: float, y: float, z: float = 0.0, yaw: float = 0.0) -> "Pose":
        """A pose at ``(x, y, z)`` [m] turned by ``yaw`` [rad] about +z."""
        return Pose.from_rotation(Rotation.from_euler("z", yaw), (x, y, z))

    @property
    def matrix(self) -> np.ndarray:
        m = np.eye(4)
        m[:3, :3] = self.rotation.as_matrix()
        m[:3, 3] = self.translation
        return m

    @property
    def yaw(self) -> float:
        """Heading of the child's x axis in the parent's xy plane [rad]."""
        x_axis = self.rotation.apply([1.0, 0.0, 0.0])
        return math.atan2(x_axis[1], x_axis[0])

    def apply(self, points: np.ndarray | Sequence[float]) -> np.ndarray:
        """Transform child-frame points (N x 3 or 3) into the parent frame."""
        p = np.asarray(points, dtype=np.float64)
        return self.rotation.apply(p) + np.asarray(self.translation)

    def __matmul__(self, other: "Pose") -> "Pose":
        """Compose: ``(a @ b)`` maps b's child frame into a's parent frame."""
        return Pose.from_rotation(self.rotation * other.rotation, self.apply(other.translation))

    def inverse(self) -> "Pose":
        inv = self.rotation.inv()
        return Pose.from_rotation(inv, -inv.apply(self.translation))


OPTICAL_TO_BODY = Rotation.from_matrix(np.array([[0.0, 0.0, 1.0], [-1.0, 0.0, 0.0], [0.0, -1.0, 0.0]]))
"""Rotation taking optical-frame vectors (x right, y down, z fwd) to body (x fwd, y left, z up)."""


@dataclass(frozen=True)
class CameraMount:
    """Where the camera sits on the robot.

    Attributes:
        position: Camera centre in the robot body frame [m] (x forward, y left, z up).
        pitch: Downward tilt of the optical axis [rad] (positive looks down).
        yaw: Pan of the optical axis to the left [rad].
        roll: Roll about the optical axis [rad].
        assumed: The pitch, roll and height are a stand-in, not known for this photo (a captures
            folder's photo without ``gravity_cam`` / ``camera_height``, a live camera whose file has no
            ``[mount]``): the mapper then fits them from the photo's floor, the mount's height its prior.
    """

    position: tuple[float, float, float] = (0.15, 0.0, 0.35)
    pitch: float = 0.0
    yaw: float = 0.0
    roll: float = 0.0
    assumed: bool = False

    @property
    def pose(self) -> Pose:
        """``robot <- camera`` transform."""
        # body-frame intrinsic rotations: yaw about z, then pitch down (= +y in FLU), then roll about x.
        tilt = Rotation.from_euler("ZYX", [self.yaw, self.pitch, self.roll])
        return Pose.from_rotation(tilt * OPTICAL_TO_BODY, self.position)


def mount_from_gravity_height(gravity_cam: Sequence[float], camera_height: float,
                              base: CameraMount | None = None) -> CameraMount:
    """The mount of a camera that sees gravity as ``gravity_cam`` (unit down vector, camera frame)
    from ``camera_height`` [m] above the floor, for a robot standing level on the floor.

    Pitch (down positive) and roll come from the gravity vector; the yaw (unobservable from gravity)
    and the forward/left offsets are those of ``base`` (default: the default mount's), the height
    is ``camera_height``.
    """
    gx, gy, gz = (float(v) for v in gravity_cam)
    pitch = math.atan2(gz, math.hypot(gx, gy))
    roll = math.atan2(gx, gy)
    b = base or CameraMount()
    return CameraMount((b.position[0], b.position[1], float(camera_height)), pitch, b.yaw, roll)


def camera_pose_in_world(robot_pose: Pose, mount: CameraMount) -> Pose:
    """``world <- camera`` for a robot at ``robot_pose`` (``world <- robot``)."""
    return robot_pose @ mount.pose


def backproject(uv: np.ndarray | Sequence[float], depth: np.ndarray | float, intr: Intrinsics) -> np.ndarray:
    """Pixels ``(u, v)`` at optical-axis depth ``z`` [m] -> camera-frame points (N x 3)."""
    uv = intr.undistort_pixels(np.asarray(uv, dtype=np.float64))
    z = np.broadcast_to(np.asarray(depth, dtype=np.float64).reshape(-1), (uv.shape[0],))
    x = (uv[:, 0] - intr.cx) / intr.fx * z
    y = (uv[:, 1] - intr.cy) / intr.fy * z
    return np.stack([x, y, z], axis=1)


def project(points_cam: np.ndarray, intr: Intrinsics) -> np.ndarray:
    """Camera-frame points (N x 3, z > 0) -> pixels (N x 2), ignoring distortion."""
    p = np.asarray(points_cam, dtype=np.float64).reshape(-1, 3)
    return np.stack([intr.fx * p[:, 0] / p[:, 2] + intr.cx, intr.fy * p[:, 1] / p[:, 2] + intr.cy], axis=1)


def ray_directions(uv: np.ndarray | Sequence[float], intr: Intrinsics) -> np.ndarray:
    """Unit viewing rays (camera frame) through pixels ``(u, v)``."""
    p = backproject(uv, 1.0, intr)
    return p / np.linalg.norm(p, axis=1, keepdims=True)


@dataclass(frozen=True)
class CameraConfig:
    """A camera description as read from ``camera.toml``: intrinsics and mount.

    ``mount_given``: whether the file said where the camera points (a ``[mount]`` table, or a photo's
    ``gravity_cam`` + ``camera_height``); when not, ``mount`` is the default and the mapper fits the
    camera's pitch, roll and height from the photo instead of taking it as level.
    """

    intrinsics: Intrinsics
    mount: CameraMount = field(default_factory=CameraMount)
    mount_given: bool = True


def parse_pose(text: str, where: str = "pose") -> Pose:
    """Parse ``x,y[,z[,yaw]]`` (metres, degrees) as given on the command line into a world pose.

    ``where`` names the option in errors (``--pose: empty value; expected 'x,y[,z[,yaw_deg]]'``).
    """
    from pipeline.option_values import ValueListError, parse_numbers

    try:
        vals = parse_numbers(text, where, (2, 3, 4), "x,y[,z[,yaw_deg]] in metres and degrees")
    except ValueListError as exc:
        raise CameraError(str(exc)) from None
    x, y = vals[0], vals[1]
    z = vals[2] if len(vals) > 2 else 0.0
    yaw = math.radians(vals[3]) if len(vals) > 3 else 0.0
    return Pose.from_xyz_yaw(x, y, z, yaw)
