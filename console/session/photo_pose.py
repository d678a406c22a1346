"""The robot's pose at the moment a live camera's photo was taken, not when Capture & map asked.

A link places a photo at the robot's pose *when asked*; a live camera's frame arrived earlier or
later (stream latency, the wait for a fresh frame), and a moving robot has moved meanwhile (0.5 m/s
over 0.3 s is 15 cm). :class:`PoseHistory` keeps the robot's recent poses from the link's state
stream (valid positions only, each at its sample time: ``RobotState.time - pose_age``) and
:func:`pair_with_pose` re-places a shot at the pose nearest its frame's arrival time, or refuses it
when no pose is near enough.

Frames: poses are ``world <- robot`` (robot x forward, y left, z up; world z up) [m, rad]; times
are seconds since the Unix epoch.
"""

from __future__ import annotations

import bisect
import math
import threading
from dataclasses import replace
from typing import Any, Callable

from pipeline.camera.geometry import Pose, camera_pose_in_world

from console.link.base import CaptureResult, RobotState

HISTORY_S = 10.0
"""Seconds of poses kept."""

MAX_GAP_S = 0.5
"""A photo more than this far in time [s] from every known pose is not placed."""


class PhotoPoseError(RuntimeError):
    """No robot pose near the photo's time; the message is for the operator."""


class PoseHistory:
    """The robot's valid poses of the last ``keep`` seconds, by sample time.

    Args:
        keep: Seconds of history kept [s], > 0.
    """

    def __init__(self, keep: float = HISTORY_S) -> None:
        if not (math.isfinite(keep) and keep > 0):
            raise ValueError(f"keep: must be a finite number of seconds > 0, got {keep!r}")
        self.keep = float(keep)
        self._lock = threading.Lock()
        self._times: list[float] = []
        self._poses: list[Pose] = []

    def __len__(self) -> int:
        with self._lock:
            return len(self._times)

    def add(self, t: float, pose: Pose) -> None:
        """Record ``pose`` (``world <- robot``) sampled at ``t`` [s since the epoch]."""
        if not math.isfinite(t):
            return
        with self._lock:
            i = bisect.bisect_right(self._times, t)
            self._times.insert(i, t)
            self._poses.insert(i, pose)
            cut = bisect.bisect_left(self._times, self._times[-1] - self.keep)
            if cut:
                del self._times[:cut], self._poses[:cut]

    def on_state(self, state: RobotState) -> None:
        """A link state listener: keeps valid positions at their sample time."""
        if not state.position_valid:
            return
        age = state.pose_age if math.isfinite(state.pose_age) and state.pose_age > 0 else 0.0
        self.add(float(state.time) - age, state.pose)

    def nearest(self, t: float) -> tuple[Pose, float] | None:
        """``(pose, |dt| [s])`` of the sample nearest ``t``, ``None`` when empty."""
        with self._lock:
            if not self._times:
                return None
            i = bisect.bisect_left(self._times, t)
            best = min((j for j in (i - 1, i) if 0 <= j < len(self._times)), key=lambda j: abs(self._times[j] - t))
            return self._poses[best], abs(self._times[best] - t)


def pair_with_pose(shot: CaptureResult, frame_time: float | None, history: PoseHistory,
                   max_gap: float = MAX_GAP_S) -> CaptureResult:
    """``shot`` placed at the robot's pose nearest ``frame_time`` [s since the epoch], stamped with it.

    Unchanged when there is no frame time (rendered or folder photos) or no history yet (a link
    without a state stream).

    Raises:
        PhotoPoseError: Poses are known but none within ``max_gap`` [s] of the frame.
    """
    if frame_time is None or not math.isfinite(frame_time):
        return shot
    found = history.nearest(frame_time)
    if found is None:
        return shot
    pose, gap = found
    if gap > max_gap:
        raise PhotoPoseError(f"no robot pose within {max_gap:.1f} s of the photo (the nearest is {gap:.1f} s away): "
                           "cannot place it; is the robot's position stream alive?")
    return replace(shot, robot_pose=pose, camera_pose=camera_pose_in_world(pose, shot.mount), timestamp=frame_time)


def photo_pairing(link: Any) -> Callable[[CaptureResult], CaptureResult] | None:
    """For a link with a live camera (:class:`~console.link.camera_source.CameraSource` as its photo
    source or camera), a function that re-places each shot at the pose of its frame's time; ``None``
    for links without one. Subscribes a :class:`PoseHistory` to the link's states."""
    source = next((c for c in (getattr(link, "captures", None), getattr(link, "camera", None))
                   if c is not None and hasattr(c, "served_at")), None)
    if source is None or not callable(getattr(link, "subscribe", None)):
        return None
    history = PoseHistory()
    link.subscribe(history.on_state)

    def pair(shot: CaptureResult) -> CaptureResult:
        return pair_with_pose(shot, getattr(source, "served_at", None), history)

    pair.history = history  # type: ignore[attr-defined]  (for tests and diagnostics)
    return pair


__all__ = ["HISTORY_S", "MAX_GAP_S", "PhotoPoseError", "PoseHistory", "pair_with_pose", "photo_pairing"]
