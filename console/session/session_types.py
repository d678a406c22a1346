"""The console session's value types: immutable snapshots handed to the views, and its error.

Frames and units: positions are in the world frame (the console's frame, z up) [m], yaw about
+z [rad]; the camera pose of a capture is ``world <- camera`` with the camera in the OpenCV
optical frame (x right, y down, z forward).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from typing import Any, Mapping, Sequence

import numpy as np

from pipeline.camera.geometry import Intrinsics, Pose

Vec3 = tuple[float, float, float]


class SessionError(ValueError):
    """An operator request that cannot be carried out; the message says why."""


class MappingError(RuntimeError):
    """Capture or perception failed; the message is for the operator (raised by the mapping job and the
    model preload; importable from :mod:`console.session.mapping_job` too)."""


def fmt_point(p: Sequence[float]) -> str:
    """A point for an operator message: ``(x, y[, z])`` with two decimals [m]."""
    return "(" + ", ".join(f"{v:.2f}" for v in p) + ")"


@dataclass(frozen=True)
class Notice:
    """A message shown to every connected operator."""

    title: str
    body: str
    level: str = "info"  # info | success | warning | error


@dataclass(frozen=True)
class Detection:
    """One detection of a capture, for drawing on the photo.

    Attributes:
        label: Class name.
        score: Confidence in [0, 1].
        bbox: ``(x1, y1, x2, y2)`` [px] in the capture's image.
        object_id: Id of the scene object it became, if any.
    """

    label: str
    score: float
    bbox: tuple[float, float, float, float]
    object_id: str | None = None


@dataclass(frozen=True)
class CaptureRecord:
    """The last photo the robot took and what the pipeline made of it.

    Attributes:
        id: Capture id (matches ``SceneObject.source.capture``).
        image: RGB photo, H x W x 3 uint8.
        intrinsics: Intrinsics of ``image`` [px].
        camera_pose: ``world <- camera`` (camera in the OpenCV optical frame).
        robot_pose: ``world <- robot`` at capture time.
        detections: Boxes found in the photo.
        depth: Depth along the optical axis [m], H x W float32, or ``None``.
        backend: What produced the detections, for the operator (e.g. ``ground truth (sim)``).
        timings: Wall time per stage [s].
        timestamp: Capture time [s since the epoch].
    """

    id: str
    image: np.ndarray
    intrinsics: Intrinsics
    camera_pose: Pose
    robot_pose: Pose
    detections: tuple[Detection, ...] = ()
    depth: np.ndarray | None = None
    backend: str = ""
    timings: Mapping[str, float] = field(default_factory=dict)
    timestamp: float = field(default_factory=time.time)


@dataclass(frozen=True)
class RobotSnapshot:
    """The robot as last reported by the link (world frame).

    Attributes:
        pose: ``world <- robot`` [m, rad].
        mode: Locomotion / autopilot mode as reported (``walk``, ``fly``, ``idle`` ...).
        armed: Whether the motors are armed.
        battery: Charge in [0, 1], or ``None`` if unknown.
        healthy: Whether the link is alive.
        detail: Free text from the link (e.g. the failing check).
        stamp: Time of the report [s since the epoch].
        messages: The robot's latest status messages, oldest first, ``(number, "SEVERITY: text")``.
        landed: Whether the robot stands on the ground as the link reports it, or ``None`` when
            unknown (the rules then judge by its height).
        position_valid: Whether ``pose`` is a fresh, valid estimate. When False, ``pose`` is the
            last valid one while stale (``pose_age`` finite) or only a placeholder when no position
            was ever known (``pose_age`` infinite): never draw or plan from it as if known.
        pose_age: Time since the last valid position [s], ``inf`` before the first (never written
            to JSON as such: the recorder writes ``null``).
        ready: Whether the robot can take off now (position estimate, EKF, pre-arm checks).
        readiness: Why it is not ready (``""`` when ready).
        warnings: Standing warnings about the link or the vehicle, for the robot panel.
        link_quality: The link's quality figure (``"link 97 % (3 % lost, RTT 12 ms)"``), ``""`` if none.
        vehicle_control: ``""`` while the console may command the robot, else why not (``"vehicle took
            control: mode RTL (...)"``).
    """

    pose: Pose
    mode: str = "unknown"
    armed: bool = False
    battery: float | None = None
    healthy: bool = True
    detail: str = ""
    stamp: float = field(default_factory=time.time)
    messages: tuple[tuple[int, str], ...] = ()
    landed: bool | None = None
    position_valid: bool = True
    pose_age: float = 0.0
    ready: bool = True
    readiness: str = ""
    warnings: tuple[str, ...] = ()
    link_quality: str = ""
    vehicle_control: str = ""

    def __post_init__(self) -> None:
        age = self.pose_age
        if not isinstance(age, (int, float)) or math.isnan(age) or age < 0:
            raise ValueError(f"pose_age: must be >= 0 s or inf, got {age!r}")

    @property
    def position_status(self) -> str:
        """``known`` (fresh and valid), ``stale`` (the last valid pose, too old) or ``unknown``
        (no valid position ever: the pose is a placeholder)."""
        if self.position_valid:
            return "known"
        return "stale" if math.isfinite(self.pose_age) else "unknown"


def trust_fields(state: Any) -> dict[str, Any]:
    """The position validity, readiness and warnings of a link's ``RobotState`` as
    :class:`RobotSnapshot` keyword arguments (a link without them counts as valid and ready).

    ``pose_age`` NaN or negative becomes ``inf`` (unknown) rather than a false "fresh"."""
    age = getattr(state, "pose_age", 0.0)
    try:
        age = float(age)
    except (TypeError, ValueError):
        age = math.inf
    if math.isnan(age) or age < 0:
        age = math.inf
    valid = bool(getattr(state, "position_valid", True))
    return {"position_valid": valid, "pose_age": age, "ready": bool(getattr(state, "ready", True)),
            "readiness": str(getattr(state, "readiness", "") or ""),
            "warnings": tuple(str(w) for w in (getattr(state, "warnings", ()) or ())),
            "link_quality": str(getattr(state, "link_quality", "") or ""),
            "vehicle_control": str(getattr(state, "vehicle_control", "") or "")}


def robot_snapshot(state: Any) -> RobotSnapshot:
    """A link's ``RobotState`` (:class:`console.link.base.RobotState`) as the session's snapshot."""
    landed = getattr(state, "landed", None)
    return RobotSnapshot(
        pose=state.pose, mode=getattr(state.mode, "value", str(state.mode)), armed=bool(state.armed),
        battery=state.battery, healthy=bool(state.link_ok),
        detail="" if state.health in ("", "ok") else str(state.health), stamp=float(state.time),
        messages=tuple(getattr(state, "messages", ())), landed=None if landed is None else bool(landed),
        **trust_fields(state))


@dataclass(frozen=True)
class JobStatus:
    """Progress of a background job (mapping, scene import).

    Attributes:
        name: What runs (``Capture & map``).
        running: Whether it is still running.
        fraction: Progress in [0, 1].
        message: Current stage, or the outcome when finished.
        error: Error text when it failed.
    """

    name: str = ""
    running: bool = False
    fraction: float = 0.0
    message: str = ""
    error: str | None = None


@dataclass(frozen=True)
class RunStatus:
    """Mission execution as reported by the mission manager.

    Attributes:
        state: ``idle``, ``running``, ``paused``, ``failsafe`` (link lost: holding or landing),
            ``done``, ``aborted`` or ``failed``.
        segment: Index of the segment being executed, or ``None``.
        fraction: Overall progress in [0, 1].
        message: Human-readable status.
    """

    state: str = "idle"
    segment: int | None = None
    fraction: float = 0.0
    message: str = ""

    @property
    def active(self) -> bool:
        """Whether a mission is under way (the route must not change under it)."""
        return self.state in ("running", "paused", "failsafe")


@dataclass(frozen=True)
class RouteSnapshot:
    """What the paths view draws (world frame [m]).

    Attributes:
        start: Where the route starts.
        registered: One point array (K x 3) per registered segment.
        candidate: Candidate path points (K x 3), or ``None``.
        candidate_goal: Goal of the candidate, or ``None``.
        goals: End point of each registered segment.
    """

    start: Vec3
    registered: tuple[np.ndarray, ...]
    candidate: np.ndarray | None
    candidate_goal: Vec3 | None
    goals: tuple[Vec3, ...]


@dataclass(frozen=True)
class Settings:
    """Operator choices shared by every tab.

    Attributes:
        goal_mode: ``ground`` (goals on the floor) or ``altitude`` (goals at ``altitude``).
        altitude: Goal height above the floor [m] in ``altitude`` mode.
        click_to_goal: Whether a click in the 3D view adds a goal.
    """

    goal_mode: str = "ground"
    altitude: float = 1.5
    click_to_goal: bool = True


@dataclass(frozen=True)
class SpawnReport:
    """What :meth:`Session.spawn` did."""

    added: tuple[str, ...]
    updated: tuple[str, ...]
    notes: tuple[str, ...]
