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

from console.views.objects_view import label_color
from console.views.photo_marks import BAR_WIDTH, depth_colorbar, draw_labels, photo_labels
from console.wording import plural
from console.session.session import CAPTURE, SCENE, CaptureRecord, Session

FRUSTUM_RGB = (0, 170, 220)
PANEL_WIDTH = 480  # [px] of the pictures sent to the browser
FRUSTUM_SCALE = 0.25  # size of the frustum drawn at the capture pose [m]
FRUSTUM_PHOTO_ALPHA = 0.45  # opacity of the photo on the frustum: paths behind it stay in sight
NO_CAPTURE = "<small>No capture yet: press <b>Capture & map</b>.</small>"
NO_CAPTURE_REPLAY = "<small>No capture yet at this time of the recording.</small>"


def frustum_photo(image: np.ndarray, width: int = 240, alpha: float = FRUSTUM_PHOTO_ALPHA) -> np.ndarray:
    """The photo for the frustum: ``width`` px wide, RGBA with opacity ``alpha`` in [0, 1].

    The frustum stands in front of the robot, right where the first candidate path starts; viser
    draws see-through textures after the paths, so a translucent photo never hides them.
    """
    if not (0.0 <= alpha <= 1.0):
        raise ValueError(f"alpha: must be in [0, 1], got {alpha!r}")
    rgb, _ = _fit(np.ascontiguousarray(image[..., :3]), width)
    a = np.full(rgb.shape[:2] + (1,), round(255 * alpha), np.uint8)
    return np.ascontiguousarray(np.concatenate([rgb, a], axis=2))


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
    """The photo (RGB) scaled to ``width`` with every detection's box and readable labels.

    Touching boxes of one class share one label (``cardboard box ×19``) and a label that would
    cover another is left out (see :func:`~console.views.photo_marks.photo_labels`).
    """
    img, s = _fit(np.ascontiguousarray(rec.image[..., :3]), width)
    color_of = colors if colors is not None else label_color
    scaled = []
    for d in rec.detections:
        x1, y1, x2, y2 = (int(round(v * s)) for v in d.bbox)
        cv2.rectangle(img, (x1, y1), (x2, y2), color_of(d.label), 2, cv2.LINE_AA)
        scaled.append((d.label, float(d.score), (float(x1), float(y1), float(x2), float(y2))))
    labels, _ = photo_labels(scaled, img.shape[1], img.shape[0])
    draw_labels(img, labels, color_of)
    return img


def depth_with_scale(depth: np.ndarray, width: int = PANEL_WIDTH) -> tuple[np.ndarray, float, float]:
    """The depth picture with its colour scale in metres on the right, ``width`` px wide in all."""
    img, near, far = depth_picture(depth, width - BAR_WIDTH)
    bar, _ = depth_colorbar(near, far, img.shape[0], BAR_WIDTH)
    return np.ascontiguousarray(np.hstack([img, bar])), near, far


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

    def __init__(self, server: viser.ViserServer, session: Session, colors: Any = None, *,
                 read_only: bool = False) -> None:
        self._server = server
        self._empty = NO_CAPTURE_REPLAY if read_only else NO_CAPTURE  # replay: nothing to press
        self._session = session
        self._colors = colors
        self._lock = threading.Lock()
        gui = server.gui
        self._caption = gui.add_markdown(self._empty)
        self._photo = gui.add_image(placeholder("no photo yet"), label="Photo and detections", format="jpeg")
        self._depth = gui.add_image(placeholder("no depth map yet"), label="Depth", format="jpeg")
        self._frustum: Any = None
        self._shown: str | None = None  # id of the capture on screen
        session.subscribe(self._on_event)
        rec = session.capture
        if rec is not None:
            self.show(rec)

    def _on_event(self, topic: str, payload: Any) -> None:
        if topic == CAPTURE and payload is not None:
            self.show(payload)
        elif topic in (CAPTURE, SCENE) and self._session.capture is None:
            self.clear()  # an undo of the first capture (or a load / replay seek before it) emptied it

    def clear(self) -> None:
        """Show no capture: placeholders in the panel, no frustum (when the session has none)."""
        with self._lock:
            if self._shown is None or self._session.capture is not None:
                return
            self._photo.image = placeholder("no photo yet")
            self._depth.image = placeholder("no depth map yet")
            self._caption.content = self._empty
            if self._frustum is not None:
                self._frustum.remove()
                self._frustum = None
            self._shown = None

    @property
    def shown(self) -> str | None:
        """Id of the capture on screen, or ``None`` when the panel shows none."""
        with self._lock:
            return self._shown

    def show(self, rec: CaptureRecord) -> None:
        """Display a capture."""
        photo = draw_detections(rec, self._colors)
        if rec.depth is not None:
            depth, near, far = depth_with_scale(rec.depth)
            depth_note = f"depth {near:.1f}–{far:.1f} m (warm = near, scale in metres beside it)"
        else:
            depth, depth_note = placeholder("no depth map from this backend"), "no depth map"
        t = rec.camera_pose.translation
        total = rec.timings.get("total", sum(v for k, v in rec.timings.items() if k != "capture"))
        caption = (
            f"<small><b>{html.escape(rec.id)}</b> · {plural(len(rec.detections), 'detection')} · "
            f"{html.escape(depth_note)}<br>perception: <b>{html.escape(rec.backend or 'unknown')}</b>"
            f" · {total:.2f} s<br>camera at ({t[0]:.2f}, {t[1]:.2f}, {t[2]:.2f}) m</small>"
        )
        q = rec.camera_pose.quaternion  # x, y, z, w
        intr = rec.intrinsics
        thumb = frustum_photo(rec.image)
        with self._lock:
            latest = self._session.capture
            if latest is not None and latest is not rec:
                return  # a newer capture arrived meanwhile; its own event draws it
            self._photo.image = photo
            self._depth.image = depth
            self._caption.content = caption
            self._shown = rec.id
            if self._frustum is not None:
                self._frustum.remove()
            self._frustum = self._server.scene.add_camera_frustum(
                "/capture/frustum", fov=intr.vfov, aspect=intr.width / intr.height, scale=FRUSTUM_SCALE,
                color=FRUSTUM_RGB, image=thumb, format="png",
                wxyz=(q[3], q[0], q[1], q[2]), position=t, thickness=0.015, cast_shadow=False,
            )

    @property
    def has_frustum(self) -> bool:
        with self._lock:
            return self._frustum is not None
