"""Cameras and frames: intrinsics, rigid poses, camera -> robot -> world, (back-)projection.

Frames:
- camera: OpenCV optical frame, x right, y down, z forward [m];
- robot: body frame, x forward, y left, z up [m] (REP-103);
- world: the console's frame, z up [m].

Rotations use :class:`scipy.spatial.transform.Rotation` (no hand-rolled Euler code).
"""

from __future__ import annotations

import math
import sys
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Mapping, Sequence

import numpy as np
from scipy.spatial.transform import Rotation

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover - exercised on Python 3.10 only
    import tomli as tomllib


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
            if not isinstance(v, (int, float)) or not math.isfinite(v):
                raise CameraError(f"intrinsics.{name}: must be a finite number, got {v!r}")
        if self.fx <= 0 or self.fy <= 0:
            raise CameraError(f"intrinsics: focal lengths must be > 0, got fx={self.fx}, fy={self.fy}")
        if self.width <= 0 or self.height <= 0:
            raise CameraError(f"intrinsics: image size must be > 0, got {self.width}x{self.height}")
        if not (0 <= self.cx <= self.width and 0 <= self.cy <= self.height):
            raise CameraError(
                f"intrinsics: principal point ({self.cx}, {self.cy}) lies outside the "
                f"{self.width}x{self.height} image"
            )
        if len(self.dist) not in (0, 4, 5, 8, 12, 14):
            raise CameraError(f"intrinsics.dist: expected 0, 4, 5, 8, 12 or 14 coefficients, got {len(self.dist)}")

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
            raise CameraError(
                f"intrinsics are for a {self.width}x{self.height} image but the image is {width}x{height}"
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
    """

    position: tuple[float, float, float] = (0.15, 0.0, 0.35)
    pitch: float = 0.0
    yaw: float = 0.0
    roll: float = 0.0

    @property
    def pose(self) -> Pose:
        """``robot <- camera`` transform."""
        # body-frame intrinsic rotations: yaw about z, then pitch down (= +y in FLU), then roll about x.
        tilt = Rotation.from_euler("ZYX", [self.yaw, self.pitch, self.roll])
        return Pose.from_rotation(tilt * OPTICAL_TO_BODY, self.position)


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
    """A camera description as read from ``camera.toml``: intrinsics and mount."""

    intrinsics: Intrinsics
    mount: CameraMount = field(default_factory=CameraMount)


def _num(table: Mapping[str, Any], key: str, where: str, default: float | None = None) -> float:
    if key not in table:
        if default is None:
            raise CameraError(f"{where}.{key}: is required")
        return default
    v = table[key]
    if isinstance(v, bool) or not isinstance(v, (int, float)):
        raise CameraError(f"{where}.{key}: must be a number, got {v!r}")
    return float(v)


def load_camera_toml(path: str | Path) -> CameraConfig:
    """Read ``camera.toml``.

    Format::

        [intrinsics]            # pixels, for the image files given with it
        fx = 525.0
        fy = 525.0
        cx = 319.5
        cy = 239.5
        width = 640
        height = 480
        dist = []               # optional OpenCV distortion coefficients

        [mount]                 # optional; robot body frame (x fwd, y left, z up)
        position = [0.15, 0.0, 0.35]   # metres
        pitch_deg = 10.0        # optical axis tilted down
        yaw_deg = 0.0
        roll_deg = 0.0
    """
    p = Path(path)
    try:
        data = tomllib.loads(p.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise CameraError(f"camera file not found: {p}") from None
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
        raise CameraError(f"camera file {p} is not valid TOML: {exc}") from None
    return camera_config_from_dict(data)


def camera_config_from_dict(data: Mapping[str, Any]) -> CameraConfig:
    """Build a :class:`CameraConfig` from a parsed ``camera.toml`` mapping."""
    intr_t = data.get("intrinsics")
    if not isinstance(intr_t, dict):
        raise CameraError("[intrinsics]: table is required")
    dist = intr_t.get("dist", [])
    if not isinstance(dist, list):
        raise CameraError("intrinsics.dist: must be a list of numbers")
    intr = Intrinsics(
        _num(intr_t, "fx", "intrinsics"), _num(intr_t, "fy", "intrinsics"),
        _num(intr_t, "cx", "intrinsics"), _num(intr_t, "cy", "intrinsics"),
        int(_num(intr_t, "width", "intrinsics")), int(_num(intr_t, "height", "intrinsics")),
        tuple(float(d) for d in dist),
    )
    mount_t = data.get("mount", {})
    if not isinstance(mount_t, dict):
        raise CameraError("[mount]: must be a table")
    pos = mount_t.get("position", list(CameraMount().position))
    if not isinstance(pos, list) or len(pos) != 3:
        raise CameraError(f"mount.position: must be 3 numbers [m], got {pos!r}")
    mount = CameraMount(
        position=(float(pos[0]), float(pos[1]), float(pos[2])),
        pitch=math.radians(_num(mount_t, "pitch_deg", "mount", 0.0)),
        yaw=math.radians(_num(mount_t, "yaw_deg", "mount", 0.0)),
        roll=math.radians(_num(mount_t, "roll_deg", "mount", 0.0)),
    )
    return CameraConfig(intr, mount)


def parse_pose(text: str) -> Pose:
    """Parse ``x,y,z,yaw`` (metres, degrees) as given on the command line into a world pose."""
    parts = [p for p in text.replace(" ", "").split(",") if p]
    try:
        vals = [float(p) for p in parts]
    except ValueError:
        raise CameraError(f"pose {text!r}: expected numbers 'x,y,z,yaw_deg'") from None
    if len(vals) not in (2, 3, 4) or not all(math.isfinite(v) for v in vals):
        raise CameraError(f"pose {text!r}: expected 'x,y[,z[,yaw_deg]]' in metres and degrees")
    x, y = vals[0], vals[1]
    z = vals[2] if len(vals) > 2 else 0.0
    yaw = math.radians(vals[3]) if len(vals) > 3 else 0.0
    return Pose.from_xyz_yaw(x, y, z, yaw)
