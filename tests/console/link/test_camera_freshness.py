"""A live camera whose picture stops changing is stale (console/link/camera_freshness.py, camera_source.py):
an MJPEG server stuck on one frame, a file of one still, a source whose timestamps stop; the status says
so, Capture & map refuses it, and the picture moving again makes the camera live again."""

from __future__ import annotations

import math
import re
import threading
import time
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from pathlib import Path
from typing import Callable

import cv2
import numpy as np
import pytest

from console.link.camera_freshness import FreshnessTracker
from console.link.camera_source import CameraSource, CameraSourceError
from pipeline.camera.geometry import CameraConfig, CameraMount, Intrinsics

W, H = 160, 120
CAMERA = CameraConfig(Intrinsics(150.0, 150.0, 80.0, 60.0, W, H), CameraMount((0.1, 0.0, 0.8), math.radians(10)))
STALE = re.compile(r"camera stale: the same frame for (\d+\.\d) s")


def wait_for(cond: Callable[[], bool], timeout: float = 30.0) -> bool:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if cond():
            return True
        time.sleep(0.02)
    return cond()


class FreezableMjpeg:
    """multipart/x-mixed-replace JPEGs at ~25 fps; while ``frozen`` is set it re-sends its last JPEG
    (a stuck camera server: frames keep arriving, the picture does not change)."""

    def __init__(self) -> None:
        self.frozen = threading.Event()
        self.stopping = threading.Event()
        self.count = 0
        outer = self

        class Handler(BaseHTTPRequestHandler):
            def do_GET(self) -> None:  # noqa: N802 - http.server's name
                self.send_response(200)
                self.send_header("Content-Type", "multipart/x-mixed-replace; boundary=frame")
                self.end_headers()
                jpg = b""
                try:
                    while not outer.stopping.is_set():
                        if not outer.frozen.is_set() or not jpg:
                            outer.count += 1
                            img = np.full((H, W, 3), (7 * outer.count) % 250, np.uint8)
                            jpg = cv2.imencode(".jpg", img)[1].tobytes()
                        self.wfile.write(b"--frame\r\nContent-Type: image/jpeg\r\nContent-Length: %d\r\n\r\n"
                                         % len(jpg) + jpg + b"\r\n")
                        outer.stopping.wait(0.04)
                except OSError:
                    pass

            def log_message(self, *args: object) -> None:
                pass

        self.server = ThreadingHTTPServer(("127.0.0.1", 0), Handler)
        self.server.daemon_threads = True
        self.url = f"http://127.0.0.1:{self.server.server_address[1]}/stream.mjpg"
        threading.Thread(target=self.server.serve_forever, daemon=True).start()

    def stop(self) -> None:
        self.stopping.set()
        self.server.shutdown()
        self.server.server_close()


def test_an_mjpeg_stream_stuck_on_one_frame_is_stale_refused_and_live_again() -> None:
    server = FreezableMjpeg()
    notices: list[str] = []
    cam = CameraSource(server.url, CAMERA, stale_after=1.0, open_timeout=3.0, on_notice=notices.append).start()
    try:
        assert cam.next(timeout=30).image.shape == (H, W, 3)  # a moving picture is served
        assert "live, last frame" in cam.status
        server.frozen.set()
        assert wait_for(lambda: cam.freshness.stale), cam.status
        m = STALE.search(cam.status)
        assert m and float(m.group(1)) >= 1.0, cam.status  # the panel's words, not "live, last frame 0.0 s ago"
        assert "live, last frame" not in cam.status
        assert wait_for(lambda: any("camera stale: the same frame for" in n and "Capture & map refuses" in n
                                    for n in notices)), notices
        with pytest.raises(CameraSourceError, match=r"camera stale: the same frame for \d+\.\d s: a frozen picture "
                                                    r"is not mapped"):
            cam.next(timeout=10)
        server.frozen.clear()
        assert wait_for(lambda: not cam.freshness.stale), cam.status
        assert cam.next(timeout=30).image.shape == (H, W, 3)
        assert wait_for(lambda: any("the picture is changing again" in n for n in notices)), notices
    finally:
        cam.close()
        server.stop()


def test_a_video_file_of_one_still_is_stale_from_the_start(tmp_path: Path) -> None:
    path = tmp_path / "still.avi"
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"MJPG"), 20.0, (W, H))
    assert writer.isOpened()
    still = np.random.default_rng(0).integers(0, 255, (H, W, 3), dtype=np.uint8)
    for _ in range(400):  # 20 s, played at its own rate and looped
        writer.write(still)
    writer.release()
    with CameraSource(str(path), CAMERA, stale_after=1.0) as cam:
        assert wait_for(lambda: cam.freshness.stale), cam.status
        assert STALE.search(cam.status), cam.status
        with pytest.raises(CameraSourceError, match=r"camera stale: the same frame for \d+\.\d s: a frozen picture"):
            cam.next(timeout=10)


class FakeCapture:
    """A ``cv2.VideoCapture`` stand-in: frames with sensor noise (always changing pixels) and a
    presentation timestamp that advances by 40 ms, then sticks after ``stick_after`` frames."""

    def __init__(self, stick_after: int) -> None:
        self.n = 0
        self.stick_after = stick_after
        self.rng = np.random.default_rng(1)
        self.base = np.full((H, W, 3), 120, np.uint8)

    def isOpened(self) -> bool:  # noqa: N802 - OpenCV's name
        return True

    def read(self) -> tuple[bool, np.ndarray]:
        time.sleep(0.03)
        self.n += 1
        noise = self.rng.integers(-3, 4, self.base.shape)
        return True, np.clip(self.base + noise, 0, 255).astype(np.uint8)

    def get(self, prop: int) -> float:
        assert prop == cv2.CAP_PROP_POS_MSEC
        return 40.0 * min(self.n, self.stick_after)

    def set(self, *args: object) -> bool:
        return True

    def release(self) -> None:
        pass


def test_a_source_whose_timestamps_stop_is_stale_and_a_noisy_still_scene_is_not() -> None:
    stuck = CameraSource("rtsp://cam.local/live", CAMERA, stale_after=0.8,
                         open_capture=lambda spec, timeout: FakeCapture(stick_after=25))
    steady = CameraSource("rtsp://cam.local/other", CAMERA, stale_after=0.8,
                          open_capture=lambda spec, timeout: FakeCapture(stick_after=10 ** 9))
    with stuck, steady:
        assert wait_for(lambda: stuck.freshness.stale), stuck.status
        assert re.search(r"camera stale: the stream's timestamp stuck at 1\.000 s for \d+\.\d s", stuck.status), \
            stuck.status
        with pytest.raises(CameraSourceError, match="timestamp stuck"):
            stuck.next(timeout=10)
        # the same scene, only sensor noise changing, stamps advancing: live for as long as we look
        assert wait_for(lambda: steady.frames > 60)
        assert not steady.freshness.stale and "live" in steady.status
        assert steady.next(timeout=10).image.shape == (H, W, 3)


def test_the_tracker_tells_the_same_picture_from_sensor_noise() -> None:
    rng = np.random.default_rng(2)
    scene = rng.integers(20, 230, (H, W, 3)).astype(np.int16)
    noisy, frozen = FreshnessTracker(stale_after=1.0), FreshnessTracker(stale_after=1.0)
    for k in range(60):  # 3 s at 20 fps
        t = k * 0.05
        v_noisy = noisy.update(np.clip(scene + rng.integers(-2, 3, scene.shape), 0, 255).astype(np.uint8), t)
        v_frozen = frozen.update(scene.astype(np.uint8), t)
    assert not v_noisy.stale and v_noisy.proven
    assert v_frozen.stale and not v_frozen.proven and v_frozen.describe() == "camera stale: the same frame for 3.0 s"  # 2.95 s
    assert not frozen.update(np.zeros((H, W, 3), np.uint8), 3.0).stale  # a new picture: live again
    for bad in ({"stale_after": 0.0}, {"stale_after": math.nan}, {"still_level": -1.0}):
        with pytest.raises(ValueError, match=next(iter(bad))):
            FreshnessTracker(**bad)  # type: ignore[arg-type]
