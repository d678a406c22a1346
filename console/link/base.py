"""The robot link interface: commands to the robot, its state and photos back.

A :class:`RobotLink` is what the console and the mission manager talk to; the simulated robot
(:mod:`console.link.sim`) and the MAVLink vehicle (:mod:`console.link.mavlink`) implement it.

Frames and units: positions and velocities in the world frame (the console's frame, z up) [m],
[m/s]; yaw [rad] counter-clockwise about +z from world +x; times [s]. Camera poses are
``world <- camera`` with the camera in the OpenCV optical frame (x right, y down, z forward).

Threading: every method may be called from any thread (viser callbacks run in threads). State
listeners run on the link's own thread and must return quickly. :meth:`RobotLink.run_segment`
returns at once with a :class:`SegmentRun` handle to poll or wait on.
"""

from __future__ import annotations

import abc
import logging
import threading
import time
from dataclasses import dataclass, field
from enum import Enum
from typing import Callable, Literal

import numpy as np

from pipeline.camera.geometry import CameraMount, Intrinsics, Pose
from pipeline.scene import SceneObject
from planner.mission import MissionSegment

log = logging.getLogger(__name__)

Vec3 = tuple[float, float, float]


class LinkError(RuntimeError):
    """A link operation failed (not connected, refused by the robot, ...)."""


class LinkTimeout(LinkError):
    """The robot did not answer (no acknowledgement, no heartbeat) in time."""


class CommandRejected(LinkError):
    """The robot answered a command with a refusal (a MAVLink NACK, a blocked path)."""


class Mode(str, Enum):
    """What the robot is doing, as reported in :class:`RobotState`."""

    IDLE = "idle"  # on the ground, no command
    WALKING = "walking"
    TAKING_OFF = "taking_off"
    FLYING = "flying"
    LANDING = "landing"
    HOLDING = "holding"  # stopped by hold/abort or hovering without a command
    FAILSAFE = "failsafe"  # the robot's own failsafe is acting
    UNKNOWN = "unknown"  # nothing heard from the robot yet


@dataclass(frozen=True)
class RobotState:
    """One sample of the robot's state stream.

    Attributes:
        time: Sample time [s since the Unix epoch].
        position: Robot body origin in the world frame [m].
        yaw: Heading of the body x axis about world +z [rad].
        velocity: Velocity in the world frame [m/s].
        mode: What the robot is doing.
        armed: Whether the motors are armed.
        landed: Whether the robot stands on the ground.
        battery: Remaining charge in [0, 1], ``None`` when unknown.
        battery_voltage: Battery voltage [V], ``None`` when unknown.
        link_ok: Whether the robot is heard from (heartbeat within the link's timeout).
        link_age: Time since the robot was last heard from [s] (0 for the simulator).
        health: Short text for the operator (``ok``, ``no heartbeat for 2.1 s`` ...).
        autopilot_mode: The flight controller's mode name (``GUIDED``, ``LAND`` ...), or ``""``.
        messages: The robot's latest status messages, oldest first, as ``(number, text)``; ``number``
            counts every message since the link opened (so a listener can tell new ones) and
            ``text`` starts with the severity (MAVLink STATUSTEXT: ``"WARNING: PreArm: Need 3D Fix"``).
        position_valid: Whether ``position`` is a fresh, valid estimate. False before the first
            valid position (``position`` is then only a finite placeholder: do not draw it as known)
            and while the position stream is stale.
        pose_age: Time since the last valid position [s] (``inf`` before the first; 0 for the simulator).
        ready: Whether the robot can take off now (position estimate, EKF, pre-arm checks).
        readiness: Why it is not ready, for the operator (``""`` when ready).
        warnings: Standing warnings about the link or the vehicle (shared system id, failsafe
            parameters off, world frame moved by a reboot ...).
        link_epoch: Counts detected reboots / reconnects of the robot since the link opened.
        link_quality: The link's quality for the operator (``"link 97 % (3 % lost, RTT 12 ms)"``), or ``""``.
        link_loss: Fraction of the robot's packets lost recently, in [0, 1] (``None``: unknown).
        link_rtt: Round-trip time to the robot [s] (``None``: unknown).
        vehicle_control: ``""`` while the console may command the robot; else why not, in the robot's
            words (``"vehicle took control: mode RTL (Battery 1 is low ...)"``): the console sends
            nothing until the operator takes control again.
        estimator: ``""`` when the robot's position estimate is trusted; else why not (a position jump,
            EKF flags / variances).
        estimator_resets: Counts position jumps and new estimator faults since the link opened.
        position_jump: Size of a position jump in the last 10 s [m] (0 when none).
    """

    time: float
    position: Vec3
    yaw: float = 0.0
    velocity: Vec3 = (0.0, 0.0, 0.0)
    mode: Mode = Mode.UNKNOWN
    armed: bool = False
    landed: bool = True
    battery: float | None = None
    battery_voltage: float | None = None
    link_ok: bool = True
    link_age: float = 0.0
    health: str = "ok"
    autopilot_mode: str = ""
    messages: tuple[tuple[int, str], ...] = ()
    position_valid: bool = True
    pose_age: float = 0.0
    ready: bool = True
    readiness: str = ""
    warnings: tuple[str, ...] = ()
    link_epoch: int = 0
    link_quality: str = ""
    link_loss: float | None = None
    link_rtt: float | None = None
    vehicle_control: str = ""
    estimator: str = ""
    estimator_resets: int = 0
    position_jump: float = 0.0

    @property
    def pose(self) -> Pose:
        """``world <- robot`` (upright: yaw only)."""
        return Pose.from_xyz_yaw(*self.position, yaw=self.yaw)

    @property
    def speed(self) -> float:
        """Speed [m/s]."""
        return float(np.linalg.norm(self.velocity))


@dataclass(frozen=True)
class VisibleObject:
    """A ground-truth object as seen in one image.

    Attributes:
        index: Value of this object in :attr:`GroundTruth.instances` (``-1`` if no mask).
        id: Object id in the hidden world / annotation.
        label: Catalog class name (or the dataset's label for photo folders).
        bbox: Visible 2D box ``(x1, y1, x2, y2)`` [px].
        pixels: Visible area [px] (0 when only a box is known).
        truncated: The object is cut by the image border (its box touches the border).
    """

    index: int
    id: str
    label: str
    bbox: tuple[float, float, float, float]
    pixels: int = 0
    truncated: bool = False


@dataclass(frozen=True)
class GroundTruth:
    """What is really in a capture, for the ground-truth perception backend and for evaluation.

    This is NOT perception: it comes from the simulator's hidden world (or a photo folder's
    annotations). Anything built from it must be labelled as ground truth.

    Attributes:
        objects: The true objects: world frame for simulator renders, camera frame (OpenCV
            optical) for annotated photo folders.
        visible: The objects visible in the image, with their 2D boxes.
        depth: Depth along the optical axis [m], H x W float32 (``inf`` where nothing was hit),
            or ``None`` when unknown.
        instances: H x W int32, the :attr:`VisibleObject.index` of the object seen at each pixel,
            ``-1`` for background (floor, walls), or ``None`` when unknown.
    """

    objects: tuple[SceneObject, ...] = ()
    visible: tuple[VisibleObject, ...] = ()
    depth: np.ndarray | None = None
    instances: np.ndarray | None = None

    def mask(self, object_id: str) -> np.ndarray:
        """Boolean H x W mask of one visible object (KeyError if not visible or no masks)."""
        if self.instances is None:
            raise KeyError(f"{object_id}: this capture has no instance masks")
        for v in self.visible:
            if v.id == object_id:
                return self.instances == v.index
        raise KeyError(f"{object_id}: not visible in this capture")


CaptureSource = Literal["sim-render", "captures-folder", "mavlink"]


@dataclass(frozen=True)
class CaptureResult:
    """One photo from the robot and where it was taken.

    Attributes:
        image: RGB photo, H x W x 3 uint8.
        intrinsics: Pinhole intrinsics of ``image`` [px].
        camera_pose: ``world <- camera`` (OpenCV optical frame) at capture time.
        robot_pose: ``world <- robot`` at capture time.
        mount: Camera on the robot (robot body frame).
        timestamp: Capture time [s since the Unix epoch].
        source: ``sim-render`` (rendered hidden world), ``captures-folder`` (a real photo from a
            folder) or ``mavlink`` (the vehicle's camera).
        name: Short name of the photo (file name for folders, a counter for renders).
        ground_truth: What is really in the image, when known (simulator, annotated folders).
    """

    image: np.ndarray
    intrinsics: Intrinsics
    camera_pose: Pose
    robot_pose: Pose
    mount: CameraMount = field(default_factory=CameraMount)
    timestamp: float = field(default_factory=time.time)
    source: CaptureSource = "sim-render"
    name: str = ""
    ground_truth: GroundTruth | None = None


class RunStatus(str, Enum):
    """State of one :class:`SegmentRun`."""

    RUNNING = "running"
    DONE = "done"
    FAILED = "failed"
    HELD = "held"  # stopped by hold(): can be continued from where it stopped
    ABORTED = "aborted"

    @property
    def finished(self) -> bool:
        return self is not RunStatus.RUNNING


class SegmentRun:
    """Handle on one mission segment being executed by a link.

    Poll :attr:`status` / :attr:`progress`, or :meth:`wait`. ``next_waypoint`` is the index of the
    waypoint the robot is heading for, so a held segment can be continued with
    ``waypoints[next_waypoint:]``.
    """

    def __init__(self, segment: MissionSegment) -> None:
        self.segment = segment
        self._cond = threading.Condition()
        self._status = RunStatus.RUNNING
        self._progress = 0.0
        self._next = 1 if len(segment.waypoints) > 1 else 0
        self._error: str | None = None
        self.started = time.time()
        self.finished_at: float | None = None

    @property
    def status(self) -> RunStatus:
        with self._cond:
            return self._status

    @property
    def progress(self) -> float:
        """Fraction of the segment done, in [0, 1]."""
        with self._cond:
            return self._progress

    @property
    def next_waypoint(self) -> int:
        with self._cond:
            return self._next

    @property
    def error(self) -> str | None:
        """Why the run failed / stopped, for the operator."""
        with self._cond:
            return self._error

    @property
    def done(self) -> bool:
        return self.status.finished

    def wait(self, timeout: float | None = None) -> RunStatus:
        """Block until the run finishes (or ``timeout`` [s]); returns the status."""
        with self._cond:
            self._cond.wait_for(lambda: self._status.finished, timeout)
            return self._status

    # --- for link implementations ----------------------------------------------------------------
    def update(self, progress: float, next_waypoint: int | None = None) -> None:
        with self._cond:
            if self._status.finished:
                return
            self._progress = min(1.0, max(self._progress, float(progress)))
            if next_waypoint is not None:
                self._next = int(next_waypoint)

    def finish(self, status: RunStatus, error: str | None = None) -> bool:
        """Mark finished; returns False if it already was (the first outcome wins)."""
        if status is RunStatus.RUNNING:
            raise ValueError("finish() needs a final status")
        with self._cond:
            if self._status.finished:
                return False
            self._status = status
            self._error = error
            if status is RunStatus.DONE:
                self._progress = 1.0
                self._next = len(self.segment.waypoints)
            self.finished_at = time.time()
            self._cond.notify_all()
        return True

    def __repr__(self) -> str:
        return (f"SegmentRun({self.segment.kind.value}, {self.status.value}, "
                f"{self.progress:.0%}{', ' + self.error if self.error else ''})")


StateListener = Callable[[RobotState], None]


class StateStream:
    """Latest-state holder with listeners; links publish through it."""

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._latest: RobotState | None = None
        self._listeners: list[StateListener] = []

    def publish(self, state: RobotState) -> None:
        with self._lock:
            self._latest = state
            listeners = list(self._listeners)
        for cb in listeners:
            try:
                cb(state)
            except Exception:  # a broken listener must not stop the stream
                log.exception("robot state listener %r failed", cb)

    def latest(self) -> RobotState | None:
        with self._lock:
            return self._latest

    def subscribe(self, callback: StateListener) -> Callable[[], None]:
        with self._lock:
            self._listeners.append(callback)

        def unsubscribe() -> None:
            with self._lock:
                if callback in self._listeners:
                    self._listeners.remove(callback)

        return unsubscribe


class RobotLink(abc.ABC):
    """A connection to one robot (simulated or real)."""

    def __init__(self) -> None:
        self._stream = StateStream()

    # --- connection ------------------------------------------------------------------------------
    @abc.abstractmethod
    def connect(self, timeout: float = 10.0) -> None:
        """Open the link and start the state stream; raises :class:`LinkError` on failure."""

    @abc.abstractmethod
    def close(self) -> None:
        """Stop everything and release the connection (idempotent)."""

    @property
    @abc.abstractmethod
    def connected(self) -> bool:
        """Whether :meth:`connect` succeeded and :meth:`close` was not called."""

    @property
    def description(self) -> str:
        """One line for the operator (``simulated robot``, ``mavlink udpin:...``)."""
        return type(self).__name__

    # --- state -----------------------------------------------------------------------------------
    def latest_state(self) -> RobotState | None:
        """The most recent state, or ``None`` before the first one."""
        return self._stream.latest()

    def subscribe(self, callback: StateListener) -> Callable[[], None]:
        """Call ``callback(state)`` for every new state; returns an unsubscribe function."""
        return self._stream.subscribe(callback)

    def link_age_now(self) -> float:
        """Seconds since the robot was last heard with fresh telemetry, read now (failsafe use).

        Links with live clocks override this; the default ages the latest sample by the time
        since it was taken (``inf`` before the first sample)."""
        st = self.latest_state()
        if st is None:
            return float("inf")
        pose_age = st.pose_age if st.pose_age != float("inf") else 0.0
        return max(st.link_age, pose_age) + max(0.0, time.time() - st.time)

    # --- who is in control -----------------------------------------------------------------------
    @property
    def vehicle_control(self) -> str:
        """``""`` while the console may command the robot; else why not (the robot chose its own mode:
        ``"vehicle took control: mode RTL (...)"``). Links whose robot never takes control keep ``""``."""
        return ""

    def take_control(self) -> None:
        """The operator takes control back after the robot chose its own mode (sends nothing)."""

    def release_control(self) -> None:
        """The console no longer claims the robot (mission over): its mode changes are its own."""

    # --- camera ----------------------------------------------------------------------------------
    @abc.abstractmethod
    def capture(self) -> CaptureResult:
        """Take one photo now; raises :class:`LinkError` if the robot has no camera."""

    # --- commands --------------------------------------------------------------------------------
    @abc.abstractmethod
    def run_segment(self, segment: MissionSegment) -> SegmentRun:
        """Start executing one mission segment (world frame); returns at once.

        Only one segment runs at a time: starting another while one runs raises
        :class:`LinkError`. Precondition failures (walking while in the air ...) finish the run
        as ``FAILED`` with a message rather than raising.
        """

    def segment_under_way(self) -> bool:
        """A segment started by :meth:`run_segment` is still running (a look's turn, a mission's leg)."""
        run = self._current_run()
        return run is not None and not run.done

    def _current_run(self) -> SegmentRun | None:
        """The run of the segment last started by :meth:`run_segment`, done or not (``None`` before one or
        after the link dropped it). Links override this; the default knows no segment."""
        return None

    def _refuse_while_running(self) -> None:
        """Raise :class:`LinkError` naming the segment under way (one segment runs at a time); call it under
        the lock that guards the link's run."""
        run = self._current_run()
        if run is not None and not run.done:
            raise LinkError(f"a {run.segment.kind.value} segment is still running: hold or abort it first")

    @abc.abstractmethod
    def hold(self) -> None:
        """Stop where the robot is (hover in the air, stand on the ground); the running segment
        finishes as ``HELD``."""

    @abc.abstractmethod
    def abort(self) -> None:
        """Stop the running segment (finishes as ``ABORTED``) and hold position."""

    def disarm(self) -> None:
        """Stop the motors of a robot standing on the ground (idempotent when already disarmed).

        Raises :class:`LinkError` when the robot is in the air or a segment runs, or when the link
        cannot disarm; implementations override this default, which refuses.
        """
        raise LinkError(f"{self.description}: this robot link cannot disarm")

    def land_here(self, floor: float = 0.0) -> SegmentRun:
        """Land straight down from where the robot is (failsafe use); ``floor`` = world z [m]."""
        from planner.mission import SegmentKind

        st = self.latest_state()
        if st is None:
            raise LinkError("no robot state yet: cannot land")
        x, y, z = st.position
        return self.run_segment(MissionSegment(SegmentKind.LAND, ((x, y, max(z, floor)), (x, y, floor))))

    def __enter__(self) -> "RobotLink":
        if not self.connected:
            self.connect()
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
