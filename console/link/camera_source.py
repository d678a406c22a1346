"""Live cameras as the robot's camera (``morphonavi console --camera SOURCE --camera-file camera.toml``).

A source is read through OpenCV's ``VideoCapture``:

- ``rtsp://host/path`` (RTSP, e.g. an IP camera or a companion computer's stream),
- ``http://host:port/stream.mjpg`` (MJPEG over HTTP),
- ``/dev/video0`` or a device number ``0`` (V4L2 / USB camera),
- a video file (played at its own frame rate and looped, for replays and tests).

A reader thread pulls frames continuously and keeps only the newest, so :meth:`CameraSource.next`
(Capture & map) never gets a stale buffered frame: it waits for a frame that arrived AFTER the
request. A picture that stops changing while frames keep arriving (a frozen MJPEG server, a relay
repeating its last frame, a source whose timestamps stop) is *stale* (:mod:`console.link.camera_freshness`):
:attr:`CameraSource.status` says ``camera stale: the same frame for 4.2 s``, the operator is told once,
and :meth:`CameraSource.next` refuses it; it only serves a frame that differs from the one before it.
:attr:`CameraSource.served_at` is the arrival time of the frame last served, to pair it with the robot's
pose at that time. Frames are upright (the camera's own orientation; no EXIF in a stream) and must have the
size of the camera file's intrinsics (checked, named). A lost stream (no frame for
``lost_after`` s, or the source failing) is logged as a warning once, :attr:`CameraSource.status`
says so, captures fail with a clear :class:`CameraSourceError`, and the reader reconnects every
``reconnect_every`` s until frames come back. :meth:`CameraSource.preview` gives a small, low-rate
copy of the newest frame for the camera panel.
"""

from __future__ import annotations

import logging
import threading
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable

import numpy as np

from pipeline.camera.geometry import CameraConfig, CameraError

from console.link.base import LinkError
from console.link.camera_freshness import STALE_AFTER_S, STILL_LEVEL, Freshness, FreshnessTracker
from console.link.captures import FolderPhoto

log = logging.getLogger(__name__)

STREAM_SCHEMES = ("rtsp://", "rtsps://", "http://", "https://")


class CameraSourceError(LinkError):
    """The camera source is unusable or has no fresh frame; the message says which and why."""


@dataclass(frozen=True)
class SourceSpec:
    """A parsed ``--camera`` value.

    Attributes:
        kind: ``stream`` (RTSP / HTTP URL), ``device`` (V4L2) or ``file`` (video file).
        target: What ``cv2.VideoCapture`` opens: the URL, the device index or path, or the file path.
        label: How to name the source in messages (URL credentials hidden).
    """

    kind: str
    target: str | int
    label: str


def parse_source(text: str) -> SourceSpec:
    """Parse ``--camera``: a URL, a device (``/dev/videoN`` or ``N``) or an existing video file.

    Raises:
        CameraSourceError: Empty text, an unsupported URL scheme, or a file that does not exist.
    """
    t = (text or "").strip()
    if not t:
        raise CameraSourceError("--camera: empty value; expected an rtsp:// or http:// URL, /dev/videoN, "
                                "a device number or a video file")
    low = t.lower()
    if low.startswith(STREAM_SCHEMES):
        label = t
        if "@" in t.split("://", 1)[1].split("/", 1)[0]:  # user:password@host: keep it out of logs
            scheme, rest = t.split("://", 1)
            label = f"{scheme}://***@{rest.split('@', 1)[1]}"
        return SourceSpec("stream", t, label)
    if "://" in t:
        raise CameraSourceError(f"--camera {t}: unsupported scheme; use rtsp://, http:// or https://, a device or a file")
    if t.isdigit():
        return SourceSpec("device", int(t), f"camera device {t}")
    if t.startswith("/dev/"):
        if not Path(t).exists():
            raise CameraSourceError(f"--camera {t}: no such device")
        return SourceSpec("device", t, t)
    p = Path(t).expanduser()
    if not p.exists():
        raise CameraSourceError(f"--camera {t}: no such file, device or URL")
    if p.is_dir():
        raise CameraSourceError(f"--camera {t}: is a folder (a folder of photos is --captures DIR)")
    return SourceSpec("file", str(p), p.name)


def _open_capture(spec: SourceSpec, open_timeout: float) -> Any:
    import cv2

    params = [cv2.CAP_PROP_OPEN_TIMEOUT_MSEC, int(open_timeout * 1000), cv2.CAP_PROP_READ_TIMEOUT_MSEC,
              int(open_timeout * 1000)]
    if spec.kind == "device":
        cap = cv2.VideoCapture(spec.target, cv2.CAP_V4L2) if isinstance(spec.target, str) \
            else cv2.VideoCapture(spec.target)
    else:
        cap = cv2.VideoCapture(spec.target, cv2.CAP_FFMPEG, params)
    if spec.kind == "stream" or spec.kind == "device":
        cap.set(cv2.CAP_PROP_BUFFERSIZE, 1)  # where the backend honours it; the reader drains anyway
    return cap


def _stamp_ms(cap: Any) -> float | None:
    """The source's timestamp of the frame just read [ms] (RTSP presentation time), ``None`` if none."""
    import cv2

    try:
        v = float(cap.get(cv2.CAP_PROP_POS_MSEC))
    except Exception:  # noqa: BLE001 - a backend without the property
        return None
    return v if v > 0 else None


class CameraSource:
    """A live camera serving upright RGB frames with the camera file's intrinsics.

    Args:
        source: The ``--camera`` value (see :func:`parse_source`).
        camera: Intrinsics of the frames and the camera's mount on the robot (``camera.toml``).
        lost_after: No frame for this long [s] means the stream is lost.
        reconnect_every: Seconds between reconnection attempts while lost.
        open_timeout: How long one open / read may block [s].
        preview_interval: Least time between two preview frames [s] (low-rate live preview).
        on_notice: Called with a sentence when the stream is lost or back, or its picture freezes or
            moves again (default: logged only).
        stale_after: The same picture (or source timestamp) for this long [s] is stale.
        still_level: Mean absolute difference [grey levels] under which two frames are the same picture.
        open_capture: Opens the source (``(spec, open_timeout) -> cv2.VideoCapture``-like); tests pass fakes.

    Call :meth:`start` (or use it as a context manager) and :meth:`close`.
    """

    def __init__(self, source: str, camera: CameraConfig, *, lost_after: float = 3.0, reconnect_every: float = 2.0,
                 open_timeout: float = 5.0, preview_interval: float = 0.5,
                 on_notice: Callable[[str], None] | None = None, stale_after: float = STALE_AFTER_S,
                 still_level: float = STILL_LEVEL, open_capture: Callable[[SourceSpec, float], Any] | None = None
                 ) -> None:
        self.spec = parse_source(source)
        self._freshness = FreshnessTracker(stale_after, still_level)  # validates both (ValueError, named)
        self._fresh = Freshness(False, proven=False)
        self._open_capture = open_capture or _open_capture
        self.served_at: float | None = None
        """Arrival time [s since the Unix epoch] of the frame :meth:`next` served last."""
        self.camera = camera
        self.lost_after = float(lost_after)
        self.reconnect_every = float(reconnect_every)
        self.open_timeout = float(open_timeout)
        self.preview_interval = float(preview_interval)
        self.on_notice = on_notice
        self.folder = self.spec.label  # what the links print as the photos' origin
        self._cond = threading.Condition()
        self._frame: np.ndarray | None = None
        self._frame_time = 0.0
        self._frame_wall = 0.0
        self._seq = 0
        self._preview: np.ndarray | None = None
        self._preview_time = 0.0
        self._lost_since: float | None = None
        self._error: str | None = None
        self._connected = False
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._cap: Any = None

    # --- life cycle ---------------------------------------------------------------------------------
    def start(self) -> "CameraSource":
        if self._thread is None:
            self._thread = threading.Thread(target=self._run, name=f"camera {self.spec.label}", daemon=True)
            self._thread.start()
        return self

    def close(self) -> None:
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=self.open_timeout + 2.0)
            self._thread = None
        with self._cond:
            self._cond.notify_all()

    def __enter__(self) -> "CameraSource":
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.close()

    # --- state ----------------------------------------------------------------------------------------
    @property
    def connected(self) -> bool:
        with self._cond:
            return self._connected and self._lost_since is None

    @property
    def status(self) -> str:
        """One line for the operator: receiving, lost (since when, why) or connecting."""
        with self._cond:
            if self._frame is not None and self._lost_since is None:
                age = time.monotonic() - self._frame_time
                if self._fresh.stale:
                    return f"{self.spec.label}: {self._fresh.describe()} (last frame {age:.1f} s ago)"
                return f"{self.spec.label}: live, last frame {age:.1f} s ago"
            if self._lost_since is not None:
                why = f" ({self._error})" if self._error else ""
                return (f"{self.spec.label}: stream lost {time.monotonic() - self._lost_since:.0f} s ago{why}; "
                        "reconnecting")
            return f"{self.spec.label}: connecting" + (f" ({self._error})" if self._error else "")

    @property
    def freshness(self) -> Freshness:
        """Whether the newest picture is frozen, and for how long."""
        with self._cond:
            return self._fresh

    @property
    def frames(self) -> int:
        """Frames received so far."""
        with self._cond:
            return self._seq

    def preview(self) -> np.ndarray | None:
        """The newest frame downscaled to at most 320 px wide (RGB), refreshed at most every
        ``preview_interval`` s; ``None`` before the first frame or while the stream is lost."""
        with self._cond:
            return None if self._lost_since is not None else self._preview

    def newest(self, after: float | None = None, timeout: float = 5.0) -> tuple[np.ndarray, float]:
        """``(frame, arrival time [time.monotonic()])`` of the newest frame that arrived after
        ``after`` (default: now) and shows a new picture (one that differs from the frame before it: a frame
        equal to its predecessor may be the start of a freeze), waiting up to ``timeout`` [s].

        Raises:
            CameraSourceError: No fresh frame in time (the message says whether the stream is lost), or
                a stale picture (``camera stale: the same frame for 4.2 s``).
        """
        since = time.monotonic() if after is None else after
        deadline = time.monotonic() + timeout

        def ready() -> bool:
            return (self._frame is not None and self._frame_time > since
                    and (self._fresh.stale or self._fresh.changed))

        with self._cond:
            while not ready():
                left = deadline - time.monotonic()
                if left <= 0 or self._stop.is_set():
                    break
                self._cond.wait(left)
            if ready() and self._fresh.stale:
                raise CameraSourceError(f"{self.spec.label}: {self._fresh.describe()}: a frozen picture is not "
                                        "mapped (check the camera and its stream)")
            if ready():
                self.served_at = self._frame_wall
                return self._frame, self._frame_time
            unchanged = self._frame is not None and self._frame_time > since and not self._fresh.changed
        if unchanged:
            raise CameraSourceError(f"{self.spec.label}: the picture has not changed for {timeout:.1f} s "
                                    "(a frozen source?): no new frame to map")
        raise CameraSourceError(f"no fresh frame from the camera within {timeout:.1f} s: {self.status}")

    def next(self, timeout: float = 5.0) -> FolderPhoto:
        """The newest frame after this call as a photo with the camera file's intrinsics and mount.

        Raises:
            CameraSourceError: No fresh frame in time, or a frame size that does not match the
                camera file's intrinsics (named).
        """
        self.start()
        frame, _ = self.newest(timeout=timeout)
        h, w = frame.shape[:2]
        try:
            self.camera.intrinsics.check_image(w, h)
        except CameraError as exc:
            raise CameraSourceError(f"{self.spec.label}: {exc}") from None
        with self._cond:
            n = self._seq
        # no [mount] in the camera file: no pose for the photo (the mapper fits it from the floor)
        mount = self.camera.mount if self.camera.mount_given else None
        return FolderPhoto(f"{self.spec.label}#{n}", frame, self.camera.intrinsics, None, mount, None)

    def __call__(self) -> tuple[np.ndarray, Any]:
        """``(RGB frame, Intrinsics)``: the camera callable a MAVLink link takes (``camera=``)."""
        photo = self.next()
        return photo.image, photo.intrinsics

    # --- reader -----------------------------------------------------------------------------------------
    def _notice(self, text: str, level: int) -> None:
        log.log(level, "%s", text)
        if self.on_notice is not None:
            try:
                self.on_notice(text)
            except Exception:  # noqa: BLE001 - a failing listener must not stop the camera
                log.exception("camera notice listener failed")

    def _mark_lost(self, why: str) -> None:
        with self._cond:
            first = self._lost_since is None and (self._connected or self._frame is not None)
            if self._lost_since is None:
                self._lost_since = time.monotonic()
            self._error = why
            self._connected = False
            self._cond.notify_all()
        if first:
            self._notice(f"camera {self.spec.label}: stream lost ({why}); reconnecting every "
                         f"{self.reconnect_every:g} s", logging.WARNING)

    def _got_frame(self, bgr: np.ndarray, stamp_ms: float | None = None) -> None:
        """A frame from the reader; ``stamp_ms`` is the source's own timestamp [ms] when it has one."""
        import cv2

        rgb = np.ascontiguousarray(bgr[:, :, ::-1]) if bgr.ndim == 3 and bgr.shape[2] == 3 else \
            np.ascontiguousarray(cv2.cvtColor(bgr, cv2.COLOR_GRAY2RGB if bgr.ndim == 2 else cv2.COLOR_BGRA2RGB))
        now = time.monotonic()
        back = False
        with self._cond:
            back = self._lost_since is not None and self._seq > 0
            was_stale = self._fresh.stale
            self._fresh = self._freshness.update(rgb, now, stamp_ms)
            froze, moved = self._fresh.stale and not was_stale, was_stale and not self._fresh.stale
            self._frame, self._frame_time, self._frame_wall = rgb, now, time.time()
            self._seq += 1
            self._lost_since = None
            self._error = None
            self._connected = True
            if now - self._preview_time >= self.preview_interval or self._preview is None:
                h, w = rgb.shape[:2]
                scale = min(1.0, 320.0 / w)
                self._preview = rgb if scale >= 1.0 else cv2.resize(rgb, (int(w * scale), int(h * scale)),
                                                                     interpolation=cv2.INTER_AREA)
                self._preview_time = now
            self._cond.notify_all()
        if back:
            self._notice(f"camera {self.spec.label}: stream back", logging.INFO)
        if froze:
            self._notice(f"camera {self.spec.label}: {self._fresh.describe()}; frames still arrive but the picture "
                         "does not change: Capture & map refuses it until it moves again", logging.WARNING)
        if moved:
            self._notice(f"camera {self.spec.label}: the picture is changing again (camera live)", logging.INFO)

    def _run(self) -> None:
        import cv2

        while not self._stop.is_set():
            cap = self._open_capture(self.spec, self.open_timeout)
            if not cap.isOpened():
                cap.release()
                self._mark_lost("cannot open the source")
                self._stop.wait(self.reconnect_every)
                continue
            period = 0.0
            if self.spec.kind == "file":  # play a file at its own rate, like a live camera
                fps = cap.get(cv2.CAP_PROP_FPS)
                period = 1.0 / fps if fps and 1.0 <= fps <= 240.0 else 1.0 / 25.0
            last = time.monotonic()
            next_due = last
            while not self._stop.is_set():
                ok, frame = cap.read()
                now = time.monotonic()
                if ok and frame is not None and frame.size:
                    self._got_frame(frame, _stamp_ms(cap) if self.spec.kind != "file" else None)
                    last = now
                    if period:
                        next_due += period
                        self._stop.wait(max(0.0, next_due - time.monotonic()))
                    continue
                if self.spec.kind == "file":  # end of the file: start it again (no notice, not a loss)
                    if now - last > self.lost_after or self.frames == 0:
                        self._mark_lost("the video file gives no frames")
                        self._stop.wait(self.reconnect_every)
                    break
                if now - last > self.lost_after or not cap.isOpened():
                    self._mark_lost(f"no frame for {now - last:.1f} s")
                    break
                self._stop.wait(0.02)
            cap.release()
            if self.spec.kind != "file" and not self._stop.is_set():
                self._stop.wait(self.reconnect_every)


def open_camera_source(source: str, camera_file: str | Path | None, **kw: Any) -> CameraSource:
    """A started :class:`CameraSource` for ``--camera SOURCE --camera-file camera.toml``.

    Raises:
        CameraSourceError: No camera file (a live camera needs its intrinsics), or a bad source.
        CameraError: The camera file is invalid (the message names the key).
    """
    from pipeline.camera.camera_file import load_camera_toml

    if camera_file is None:
        raise CameraSourceError("--camera needs --camera-file camera.toml (its intrinsics and mount; "
                                "`morphonavi calibrate` writes one)")
    return CameraSource(source, load_camera_toml(camera_file), **kw).start()


__all__ = ["CameraSource", "CameraSourceError", "SourceSpec", "open_camera_source", "parse_source"]
