"""A live camera's photo is placed at the robot's pose of its frame's time (console/session/photo_pose.py),
and Capture & map refuses a frozen camera with the reason (console/session/mapping_job.py)."""

from __future__ import annotations

import math
import time
from pathlib import Path
from typing import Callable

import numpy as np
import pytest

from console.link.base import CaptureResult
from console.link.camera_source import CameraSource
from console.session.photo_pose import PhotoPoseError, PoseHistory, pair_with_pose, photo_pairing
from pipeline.camera.geometry import CameraConfig, CameraMount, Intrinsics, Pose, camera_pose_in_world

W, H = 160, 120
MOUNT = CameraMount((0.1, 0.0, 0.8), math.radians(10))
CAMERA = CameraConfig(Intrinsics(150.0, 150.0, 80.0, 60.0, W, H), MOUNT)


def wait_for(cond: Callable[[], bool], timeout: float = 30.0) -> bool:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if cond():
            return True
        time.sleep(0.02)
    return cond()


def _shot(robot: Pose, t: float) -> CaptureResult:
    return CaptureResult(np.zeros((H, W, 3), np.uint8), CAMERA.intrinsics, camera_pose_in_world(robot, MOUNT), robot,
                         MOUNT, t, "mavlink", "camera")


def test_the_photo_takes_the_pose_nearest_its_frame_time() -> None:
    history = PoseHistory()
    t0 = 1_700_000_000.0
    for k in range(21):  # driving along world +x at 0.5 m/s, a pose every 0.1 s
        history.add(t0 + 0.1 * k, Pose.from_xyz_yaw(0.05 * k, 0.0, 0.0, yaw=0.0))
    asked = _shot(Pose.from_xyz_yaw(1.0, 0.0, 0.0, yaw=0.0), t0 + 2.0)  # the link placed it when asked (x 1.0)
    paired = pair_with_pose(asked, t0 + 1.23, history)  # the frame arrived 0.77 s earlier
    assert paired.robot_pose.translation[0] == pytest.approx(0.6)  # the pose at t0 + 1.2, 40 cm behind
    assert paired.timestamp == t0 + 1.23
    expected = camera_pose_in_world(paired.robot_pose, MOUNT)
    assert np.allclose(paired.camera_pose.translation, expected.translation)
    assert pair_with_pose(asked, None, history) is asked  # no frame time (renders, folders): unchanged
    assert pair_with_pose(asked, t0, PoseHistory()) is asked  # no state stream: unchanged
    with pytest.raises(PhotoPoseError, match=r"no robot pose within 0\.5 s of the photo \(the nearest is 3\.0 s away\)"):
        pair_with_pose(asked, t0 + 5.0, history)


def test_the_history_keeps_valid_positions_at_their_sample_time() -> None:
    from console.link.base import RobotState

    history = PoseHistory(keep=1.0)
    history.on_state(RobotState(100.0, (1.0, 2.0, 0.0), position_valid=True, pose_age=0.25))
    history.on_state(RobotState(100.1, (9.0, 9.0, 0.0), position_valid=False, pose_age=0.35))  # not a position
    pose, gap = history.nearest(99.75)  # type: ignore[misc]
    assert gap == pytest.approx(0.0) and pose.translation[0] == pytest.approx(1.0) and len(history) == 1
    for k in range(30):
        history.add(101.0 + 0.1 * k, Pose.from_xyz_yaw(0.0, 0.0, 0.0, yaw=0.0))
    assert len(history) == 11  # the last second only
    with pytest.raises(ValueError, match="keep"):
        PoseHistory(keep=math.inf)


class FakeCapture:
    """A ``cv2.VideoCapture`` stand-in serving one picture forever (``noise=False``: a frozen camera) or
    the same scene with sensor noise (a live camera looking at a still scene)."""

    def __init__(self, noise: bool) -> None:
        self.noise = noise
        self.rng = np.random.default_rng(3)
        self.base = np.full((H, W, 3), 100, np.uint8)

    def isOpened(self) -> bool:  # noqa: N802 - OpenCV's name
        return True

    def read(self) -> tuple[bool, np.ndarray]:
        time.sleep(0.03)
        if not self.noise:
            return True, self.base.copy()
        return True, np.clip(self.base + self.rng.integers(-3, 4, self.base.shape), 0, 255).astype(np.uint8)

    def get(self, prop: int) -> float:
        return 0.0

    def set(self, *args: object) -> bool:
        return True

    def release(self) -> None:
        pass


def test_capture_and_map_refuses_a_frozen_camera_with_the_reason(tmp_path: Path) -> None:
    from console.link.sim import SimRobot
    from console.session.mapping_job import GROUND_TRUTH_LABEL, MapperPerceiver, MappingJob, ground_truth_bundle_for
    from console.session.session import NOTICE, Session

    cam = CameraSource("rtsp://cam.local/live", CAMERA, stale_after=0.5,
                       open_capture=lambda spec, timeout: FakeCapture(noise=False)).start()
    robot = SimRobot(captures=cam)
    robot.connect()
    session = Session(tmp_path / "session", autosave=False)
    notices: list = []
    session.subscribe(lambda topic, payload: notices.append(payload) if topic == NOTICE else None)
    try:
        job = MappingJob(session, robot.capture, MapperPerceiver(GROUND_TRUTH_LABEL, ground_truth_bundle_for),
                         pair=photo_pairing(robot))
        assert wait_for(lambda: cam.freshness.stale), cam.status
        assert job.run() is False
        assert "the camera gave no usable photo" in (session.job.error or "")
        assert "camera stale: the same frame for" in (session.job.error or "")
        assert any(n.title == "Capture & map failed" and "a frozen picture is not mapped" in n.body for n in notices)
        assert session.capture is None  # nothing was mapped
    finally:
        robot.close()
        cam.close()


def test_a_live_cameras_photo_is_paired_with_the_pose_of_its_frame(tmp_path: Path) -> None:
    from console.link.sim import SimRobot

    cam = CameraSource("rtsp://cam.local/live", CAMERA, open_capture=lambda spec, timeout: FakeCapture(noise=True)).start()
    robot = SimRobot(captures=cam)
    robot.connect()
    try:
        pair = photo_pairing(robot)
        assert pair is not None and photo_pairing(object()) is None
        assert wait_for(lambda: len(pair.history) > 5)  # type: ignore[attr-defined]
        shot = robot.capture()
        assert cam.served_at is not None and abs(cam.served_at - time.time()) < 30
        paired = pair(shot)
        assert paired.timestamp == cam.served_at  # the frame's time, not the time it was asked for
        pose, gap = pair.history.nearest(cam.served_at)  # type: ignore[attr-defined]
        assert gap < 0.5 and np.allclose(paired.robot_pose.translation, pose.translation)
    finally:
        robot.close()
        cam.close()
