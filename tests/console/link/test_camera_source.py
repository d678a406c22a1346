"""Live camera sources (console/link/camera_source.py): a video file written here and an MJPEG-over-HTTP
server on 127.0.0.1; newest frame only, lost stream noticed and reconnected."""

from __future__ import annotations

import math
import threading
import time
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from pathlib import Path
from typing import Callable

import cv2
import numpy as np
import pytest

from console.link.camera_source import CameraSource, CameraSourceError, open_camera_source, parse_source
from pipeline.camera.geometry import CameraConfig, CameraMount, Intrinsics

W, H = 160, 120
CAMERA = CameraConfig(Intrinsics(150.0, 150.0, 80.0, 60.0, W, H), CameraMount((0.1, 0.0, 0.8), math.radians(10)))


def wait_for(cond: Callable[[], bool], timeout: float = 20.0) -> bool:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if cond():
            return True
        time.sleep(0.02)
    return cond()


def _video(path: Path, frames: int = 60, fps: float = 20.0, size: tuple[int, int] = (W, H)) -> Path:
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"MJPG"), fps, size)
    assert writer.isOpened()
    for i in range(frames):
        writer.write(np.full((size[1], size[0], 3), 4 * i, np.uint8))  # the frame number, in its brightness
    writer.release()
    return path


def test_sources_are_parsed_and_bad_ones_named(tmp_path: Path) -> None:
    assert parse_source("rtsp://user:secret@10.0.0.5:554/live").label == "rtsp://***@10.0.0.5:554/live"
    assert parse_source("http://127.0.0.1:8080/stream.mjpg").kind == "stream"
    assert parse_source("0").target == 0 and parse_source("0").kind == "device"
    video = _video(tmp_path / "v.avi", frames=2)
    assert parse_source(str(video)).kind == "file"
    for text, match in (("", "empty value"), ("ftp://x/y", "unsupported scheme"), (str(tmp_path / "no.avi"), "no such"),
                        (str(tmp_path), "is a folder"), ("/dev/video99", "no such device")):
        with pytest.raises(CameraSourceError, match=match):
            parse_source(text)


def test_a_video_file_serves_fresh_frames_with_the_camera_file(tmp_path: Path) -> None:
    with CameraSource(str(_video(tmp_path / "walk.avi")), CAMERA) as cam:
        first = cam.next(timeout=20)
        assert first.image.shape == (H, W, 3) and first.intrinsics == CAMERA.intrinsics
        assert first.mount == CAMERA.mount  # the camera file's mount replaces the robot's default
        seen = cam.frames
        second = cam.next(timeout=20)
        assert cam.frames > seen  # a frame that arrived after the request, not the buffered one
        assert wait_for(lambda: cam.preview() is not None)
        assert "live" in cam.status


def test_frames_of_another_size_are_refused_naming_the_fields(tmp_path: Path) -> None:
    with CameraSource(str(_video(tmp_path / "big.avi", size=(320, 240))), CAMERA) as cam:
        with pytest.raises(CameraSourceError, match=r"intrinsics\.width x intrinsics\.height: .*160x120 .*320x240"):
            cam.next(timeout=20)


def test_open_camera_source_needs_a_camera_file(tmp_path: Path) -> None:
    with pytest.raises(CameraSourceError, match="--camera needs --camera-file"):
        open_camera_source("0", None)


class MjpegServer:
    """multipart/x-mixed-replace JPEG frames at ~25 fps; frame k has brightness k % 250."""

    def __init__(self, port: int = 0) -> None:
        self.count = 0
        self.stopping = threading.Event()
        outer = self

        class Handler(BaseHTTPRequestHandler):
            def do_GET(self) -> None:  # noqa: N802 - http.server's name
                self.send_response(200)
                self.send_header("Content-Type", "multipart/x-mixed-replace; boundary=frame")
                self.end_headers()
                try:
                    while not outer.stopping.is_set():
                        k = outer.count
                        outer.count += 1
                        jpg = cv2.imencode(".jpg", np.full((H, W, 3), k % 250, np.uint8))[1].tobytes()
                        self.wfile.write(b"--frame\r\nContent-Type: image/jpeg\r\nContent-Length: %d\r\n\r\n"
                                         % len(jpg) + jpg + b"\r\n")
                        outer.stopping.wait(0.04)
                except OSError:
                    pass

            def log_message(self, *args: object) -> None:
                pass

        self.server = ThreadingHTTPServer(("127.0.0.1", port), Handler)
        self.server.daemon_threads = True
        self.port = self.server.server_address[1]
        self.thread = threading.Thread(target=self.server.serve_forever, daemon=True)
        self.thread.start()

    def stop(self) -> None:
        self.stopping.set()
        self.server.shutdown()
        self.server.server_close()


def test_mjpeg_over_http_newest_frame_lost_notice_and_reconnect() -> None:
    server = MjpegServer()
    url = f"http://127.0.0.1:{server.port}/stream.mjpg"
    notices: list[str] = []
    cam = CameraSource(url, CAMERA, lost_after=1.0, reconnect_every=0.3, open_timeout=2.0,
                       on_notice=notices.append).start()
    try:
        assert wait_for(lambda: cam.frames > 3)
        sent_before = server.count
        photo = cam.next(timeout=20)
        # JPEG brightness is within a few levels of the frame number: this frame was sent after the request
        assert int(photo.image[H // 2, W // 2, 0]) >= (sent_before - 1) % 250 - 3 or sent_before >= 249
        server.stop()
        assert wait_for(lambda: "stream lost" in cam.status), cam.status
        assert wait_for(lambda: any("stream lost" in n for n in notices)), notices  # told after the status is set
        with pytest.raises(CameraSourceError, match="stream lost"):
            cam.next(timeout=0.5)
        server = MjpegServer(server.port)  # the camera comes back on the same address
        assert wait_for(lambda: cam.connected, 30), cam.status
        assert cam.next(timeout=20).image.shape == (H, W, 3)
        assert wait_for(lambda: any("stream back" in n for n in notices)), notices
    finally:
        cam.close()
        server.stop()


def test_the_simulated_robot_serves_the_live_camera_with_its_mount(tmp_path: Path) -> None:
    from console.link.sim import SimRobot

    with CameraSource(str(_video(tmp_path / "walk.avi")), CAMERA) as cam:
        robot = SimRobot(captures=cam, manual_clock=True)
        robot.connect()
        try:
            shot = robot.capture()
            image, intr = cam()  # the callable a MAVLink link takes
        finally:
            robot.close()
    assert shot.image.shape == (H, W, 3) and shot.intrinsics == CAMERA.intrinsics
    assert shot.mount == CAMERA.mount
    # the camera sits 0.8 m above the robot's floor point, as its camera file says
    assert shot.camera_pose.translation[2] == pytest.approx(shot.robot_pose.translation[2] + 0.8)
    assert image.shape == (H, W, 3) and intr == CAMERA.intrinsics


def test_the_camera_panel_preview_follows_the_live_camera(tmp_path: Path) -> None:
    from types import SimpleNamespace

    from console.views.camera_preview import LivePreview, live_source
    from console.link.sim import SimRobot

    image, status = SimpleNamespace(image=None), SimpleNamespace(content="")
    with CameraSource(str(_video(tmp_path / "walk.avi")), CAMERA, preview_interval=0.1) as cam:
        assert live_source(SimRobot(captures=cam, manual_clock=True)) is cam
        assert live_source(SimRobot(manual_clock=True)) is None  # rendered camera: no live preview
        preview = LivePreview(cam, image, status, interval=0.05)
        try:
            assert wait_for(lambda: image.image is not None and "live, last frame" in status.content), status.content
            assert image.image.shape[1] <= 320 and image.image.shape[2] == 3
            first = image.image
            assert wait_for(lambda: image.image is not first)  # it keeps following the stream
        finally:
            preview.close()


def test_a_lost_stream_reaches_the_operator_as_a_notice() -> None:
    from types import SimpleNamespace

    from console.views.camera_preview import live_preview

    gui = SimpleNamespace(add_markdown=lambda text: SimpleNamespace(content=text),
                          add_image=lambda image, **kw: SimpleNamespace(image=image))
    told: list[tuple[str, str, str]] = []
    server = MjpegServer()
    cam = CameraSource(f"http://127.0.0.1:{server.port}/stream.mjpg", CAMERA, lost_after=1.0, reconnect_every=0.3,
                       open_timeout=2.0).start()
    preview = live_preview(SimpleNamespace(gui=gui), SimpleNamespace(captures=cam, camera=None),
                           interval=0.05, notify=lambda *n: told.append(n))
    try:
        assert preview is not None and wait_for(lambda: cam.frames > 2)
        server.stop()
        assert wait_for(lambda: any(level == "warning" and "stream lost" in body for _, body, level in told)), told
        assert wait_for(lambda: "stream lost" in preview._status.content), preview._status.content
    finally:
        preview.close()
        cam.close()
        server.stop()
