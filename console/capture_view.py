"""The last capture: the photo with its detection boxes, the depth map, and the camera frustum.

The photo and the depth picture go in a camera panel; the frustum is drawn in the 3D view at the
camera pose of the capture (``world <- camera``, OpenCV optical frame: x right, y down, z forward,
which is also viser's camera convention) with the photo on it.
"""

from __future__ import annotations

import html
import math
import threading
from typing import Any

import cv2
import numpy as np
import viser

from .objects_view import label_color
from .session import CAPTURE, CaptureRecord, Session

FRUSTUM_RGB = (0, 170, 220)
PANEL_WIDTH = 480  # [px] of the pictures sent to the browser


def placeholder(text: str, width: int = PANEL_WIDTH, height: int = 300) -> np.ndarray:
    """A grey picture with a centred line of text (RGB uint8)."""
    img = np.full((height, width, 3), 236, np.uint8)
    (tw, th), _ = cv2.getTextSize(text, cv2.FONT_HERSHEY_SIMPLEX, 0.55, 1)
    cv2.putText(img, text, ((width - tw) // 2, (height + th) // 2), cv2.FONT_HERSHEY_SIMPLEX, 0.55,
                (120, 120, 128), 1, cv2.LINE_AA)
    return img


def _fit(img: np.ndarray, width: int = PANEL_WIDTH) -> tuple[np.ndarray, float]:
    """Resize to ``width`` px wide; returns the image and the scale applied."""
    s = width / img.shape[1]
    if abs(s - 1.0) < 1e-6:
        return img.copy(), 1.0
    return cv2.resize(img, (width, max(1, round(img.shape[0] * s))), interpolation=cv2.INTER_AREA), s


def draw_detections(rec: CaptureRecord, colors: Any = None, width: int = PANEL_WIDTH) -> np.ndarray:
    """The photo (RGB) scaled to ``width`` with every detection's box, label and score."""
    img, s = _fit(np.ascontiguousarray(rec.image[..., :3]), width)
    for d in rec.detections:
        x1, y1, x2, y2 = (int(round(v * s)) for v in d.bbox)
        rgb = colors(d.label) if colors is not None else label_color(d.label)
        cv2.rectangle(img, (x1, y1), (x2, y2), rgb, 2, cv2.LINE_AA)
        text = f"{d.label.replace('_', ' ')} {d.score:.2f}"
        (tw, th), base = cv2.getTextSize(text, cv2.FONT_HERSHEY_SIMPLEX, 0.45, 1)
        ty = y1 - 4 if y1 - th - 6 >= 0 else y1 + th + 4
        cv2.rectangle(img, (x1, ty - th - 3), (x1 + tw + 4, ty + base - 1), rgb, -1)
        lum = 0.299 * rgb[0] + 0.587 * rgb[1] + 0.114 * rgb[2]
        cv2.putText(img, text, (x1 + 2, ty - 1), cv2.FONT_HERSHEY_SIMPLEX, 0.45,
                    (0, 0, 0) if lum > 150 else (255, 255, 255), 1, cv2.LINE_AA)
    return img


def depth_picture(depth: np.ndarray, width: int = PANEL_WIDTH) -> tuple[np.ndarray, float, float]:
    """A colour picture of a depth map [m] (near = warm) and its ``(near, far)`` range [m]."""
    d = np.asarray(depth, dtype=np.float32)
    valid = np.isfinite(d) & (d > 0)
    if not valid.any():
        return placeholder("depth map empty", width), math.nan, math.nan
    near, far = np.percentile(d[valid], [2, 98])
    far = max(far, near + 1e-3)
    norm = np.clip((d - near) / (far - near), 0, 1)
    u8 = (255 * (1.0 - norm)).astype(np.uint8)
    img = cv2.cvtColor(cv2.applyColorMap(u8, cv2.COLORMAP_TURBO), cv2.COLOR_BGR2RGB)
    img[~valid] = (30, 30, 30)
    img, _ = _fit(img, width)
    return img, float(near), float(far)


class CaptureView:
    """Photo with boxes, depth picture and caption in the GUI; frustum in the 3D view.

    Args:
        server: The viser server.
        session: The state it shows.
        colors: ``label -> (r, g, b)`` for the boxes (the catalog's colours).
    """

    def __init__(self, server: viser.ViserServer, session: Session, colors: Any = None) -> None:
        self._server = server
        self._session = session
        self._colors = colors
        self._lock = threading.Lock()
        gui = server.gui
        self._caption = gui.add_markdown("<small>No capture yet: press <b>Capture & map</b>.</small>")
        self._photo = gui.add_image(placeholder("no photo yet"), label="Photo and detections", format="jpeg")
        self._depth = gui.add_image(placeholder("no depth map yet"), label="Depth", format="jpeg")
        self._frustum: Any = None
        session.subscribe(self._on_event)
        rec = session.capture
        if rec is not None:
            self.show(rec)

    def _on_event(self, topic: str, payload: Any) -> None:
        if topic == CAPTURE and payload is not None:
            self.show(payload)

    def show(self, rec: CaptureRecord) -> None:
        """Display a capture."""
        photo = draw_detections(rec, self._colors)
        if rec.depth is not None:
            depth, near, far = depth_picture(rec.depth)
            depth_note = f"depth {near:.1f}–{far:.1f} m (warm = near)"
        else:
            depth, depth_note = placeholder("no depth map from this backend"), "no depth map"
        t = rec.camera_pose.translation
        total = rec.timings.get("total", sum(v for k, v in rec.timings.items() if k != "capture"))
        caption = (
            f"<small><b>{html.escape(rec.id)}</b> · {len(rec.detections)} detections · "
            f"{html.escape(depth_note)}<br>perception: <b>{html.escape(rec.backend or 'unknown')}</b>"
            f" · {total:.2f} s<br>camera at ({t[0]:.2f}, {t[1]:.2f}, {t[2]:.2f}) m</small>"
        )
        q = rec.camera_pose.quaternion  # x, y, z, w
        intr = rec.intrinsics
        thumb, _ = _fit(np.ascontiguousarray(rec.image[..., :3]), 320)
        with self._lock:
            latest = self._session.capture
            if latest is not None and latest is not rec:
                return  # a newer capture arrived meanwhile; its own event draws it
            self._photo.image = photo
            self._depth.image = depth
            self._caption.content = caption
            if self._frustum is not None:
                self._frustum.remove()
            self._frustum = self._server.scene.add_camera_frustum(
                "/capture/frustum", fov=intr.vfov, aspect=intr.width / intr.height, scale=0.3,
                color=FRUSTUM_RGB, image=thumb, format="jpeg", jpeg_quality=80,
                wxyz=(q[3], q[0], q[1], q[2]), position=t, thickness=0.015, cast_shadow=False,
            )

    @property
    def has_frustum(self) -> bool:
        with self._lock:
            return self._frustum is not None
