"""Object labels that never overlap: drawn per browser tab and decluttered for that tab's view.

viser draws a label as a billboard of constant screen size (``12 px * font_screen_scale`` per em,
whatever the distance). Every tab gets its own label nodes (``client.scene``); whenever its camera
moves, the labels are projected into that tab's picture and kept greedily, most important first
(the selected object's, then the nearest to the camera), skipping any whose box would overlap one
already kept or the robot's own label, up to :data:`MAX_LABELS`. Zooming in spreads the objects
apart and shows more labels; selecting an object always shows its label.

Frames: world z up [m]; the tab's camera pose is viser's (``wxyz`` world <- camera, OpenCV optical
frame: x right, y down, z forward); pixels are the camera image's (x right, y down).
"""

from __future__ import annotations

import math
import threading
from dataclasses import dataclass
from typing import Any, Callable, Sequence

import numpy as np

FONT_SCREEN_SCALE = 0.8
"""Label size (viser's ``font_screen_scale``): an em of ``12 * 0.8`` CSS px."""

EM_PX = 12.0 * FONT_SCREEN_SCALE
"""Height of one em of a label [CSS px]."""

CHAR_EM = 0.58
"""Mean advance of one character of the label font [em] (system sans serif, a little generous)."""

MAX_LABELS = 14
"""Most object labels one view shows at once."""

GAP_PX = 3.0
"""Space kept between two label boxes [CSS px]."""

Rect = tuple[float, float, float, float]  # x0, y0, x1, y1 [px], x right, y down


@dataclass(frozen=True)
class LabelSpot:
    """A label to place: its text, anchor (world [m], the box's bottom centre) and the object ids it names."""

    text: str
    position: tuple[float, float, float]
    ids: tuple[str, ...]


def project(wxyz: Sequence[float], position: Sequence[float], fov: float, width: float, height: float,
            point: Sequence[float]) -> tuple[float, float, float] | None:
    """Pixel ``(u, v)`` and depth [m] of a world point in a pinhole camera, or ``None`` behind it.

    Args:
        wxyz: The camera's orientation (world <- camera, OpenCV optical frame), quaternion w, x, y, z.
        position: The camera's position (world [m]).
        fov: Vertical field of view [rad].
        width, height: Picture size [px].
        point: The world point [m].
    """
    w, x, y, z = (float(v) for v in wxyz)
    R = np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
        [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
        [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
    ])
    p = R.T @ (np.asarray(point, dtype=np.float64) - np.asarray(position, dtype=np.float64))
    if p[2] <= 1e-6:
        return None
    f = (height / 2) / math.tan(fov / 2)
    return (width / 2 + f * p[0] / p[2], height / 2 + f * p[1] / p[2], float(p[2]))


def label_rect(text: str, u: float, v: float, px_per_css: float = 1.0) -> Rect:
    """The screen box [px] of a bottom-centre-anchored label at pixel ``(u, v)`` (viser's layout: one
    line of ``1.2`` em, a background padding of ``0.2`` line heights), ``px_per_css`` picture pixels
    per CSS pixel."""
    em = EM_PX * px_per_css
    line = 1.2 * em
    pad = 0.2 * line
    w = CHAR_EM * em * max(1, len(text)) + pad
    h = line + pad
    return (u - w / 2, v - h, u + w / 2, v)


def overlaps(a: Rect, b: Rect, gap: float = GAP_PX) -> bool:
    """Whether two boxes overlap or come closer than ``gap`` [px]."""
    return a[0] < b[2] + gap and b[0] < a[2] + gap and a[1] < b[3] + gap and b[1] < a[3] + gap


def declutter(rects: Sequence[Rect | None], order: Sequence[int], reserved: Sequence[Rect] = (),
              limit: int = MAX_LABELS, gap: float = GAP_PX) -> list[int]:
    """Indices of ``rects`` to show: taken in ``order``, each kept when it overlaps no box kept before
    it nor a ``reserved`` one, at most ``limit``; ``None`` (off the picture) is never kept."""
    kept: list[int] = []
    boxes = list(reserved)
    for i in order:
        r = rects[i]
        if r is None or len(kept) >= limit:
            continue
        if any(overlaps(r, b, gap) for b in boxes):
            continue
        kept.append(i)
        boxes.append(r)
    return kept


def px_per_css(image_height: float) -> float:
    """A guess of the picture's device pixels per CSS pixel: 1 up to 1100 px tall, more above (a
    taller picture is most likely a high-density screen); too big a guess only shows fewer labels."""
    return max(1.0, float(image_height) / 1100.0)


def choose(spots: Sequence[LabelSpot], camera: Any, selected: str | None = None,
           reserved_spots: Sequence[tuple[str, Sequence[float]]] = (), limit: int = MAX_LABELS) -> list[tuple[int, Rect]]:
    """Which labels a camera shows: ``(index into spots, screen box [px])``, most important first.

    ``camera`` has viser's ``wxyz``, ``position``, ``fov``, ``image_width`` and ``image_height``;
    ``selected`` is the selected object's id (its label first); ``reserved_spots`` are other labels
    ``(text, anchor)`` (e.g. the robot's) that object labels must leave free.
    """
    W, H = float(camera.image_width), float(camera.image_height)
    if W <= 0 or H <= 0:
        return []
    scale = px_per_css(H)
    pose = (camera.wxyz, camera.position, float(camera.fov), W, H)
    rects: list[Rect | None] = []
    depth: list[float] = []
    for s in spots:
        p = project(*pose, s.position)
        if p is None or not (0 <= p[0] <= W and 0 <= p[1] <= H):
            rects.append(None)
            depth.append(math.inf)
            continue
        rects.append(label_rect(s.text, p[0], p[1], scale))
        depth.append(p[2])
    reserved = []
    for text, anchor in reserved_spots:
        p = project(*pose, anchor)
        if p is not None:
            reserved.append(label_rect(text, p[0], p[1], scale))
    order = sorted(range(len(spots)), key=lambda i: (0 if selected is not None and selected in spots[i].ids else 1,
                                                     depth[i]))
    keep = declutter(rects, order, reserved, limit, GAP_PX * scale)
    return [(i, rects[i]) for i in keep]  # type: ignore[misc]


class ClientLabels:
    """The object labels of every tab of a viser server, decluttered per tab.

    Args:
        server: The viser server.
        selected: Returns the selected object's id, or ``None``.
        reserved: Returns other labels ``(text, anchor world [m])`` object labels must leave free.
    """

    def __init__(self, server: Any, selected: Callable[[], str | None],
                 reserved: Callable[[], Sequence[tuple[str, Sequence[float]]]] = lambda: ()) -> None:
        self._server = server
        self._selected = selected
        self._reserved = reserved
        self._lock = threading.RLock()
        self._spots: list[LabelSpot] = []
        self._enabled = True
        self._tabs: dict[int, dict[str, Any]] = {}  # client id -> {"client", "handles", "shown"}
        server.on_client_connect(self._connect)
        server.on_client_disconnect(lambda client: self._drop(client.client_id))
        for client in server.get_clients().values():
            self._connect(client)

    # --- tabs ---------------------------------------------------------------------------------------
    def _connect(self, client: Any) -> None:
        with self._lock:
            self._tabs[client.client_id] = {"client": client, "handles": [], "shown": []}
            self._rebuild(client.client_id)
        client.camera.on_update(lambda _cam: self.refresh(client.client_id))

    def _drop(self, client_id: int) -> None:
        with self._lock:
            self._tabs.pop(client_id, None)

    def _rebuild(self, client_id: int) -> None:
        tab = self._tabs.get(client_id)
        if tab is None:
            return
        for h in tab["handles"]:
            try:
                h.remove()
            except Exception:  # noqa: BLE001 - a tab that went away: nothing left to remove
                pass
        client = tab["client"]
        tab["handles"] = [client.scene.add_label(f"/labels/{n}", s.text, position=s.position, anchor="bottom-center",
                                                 font_screen_scale=FONT_SCREEN_SCALE, visible=False)
                          for n, s in enumerate(self._spots)]
        tab["shown"] = []
        self.refresh(client_id)

    # --- what the session says ----------------------------------------------------------------------
    def set_spots(self, spots: Sequence[LabelSpot]) -> None:
        """Replace the labels (a new scene) in every tab."""
        with self._lock:
            self._spots = list(spots)
            for cid in list(self._tabs):
                self._rebuild(cid)

    def set_enabled(self, enabled: bool) -> None:
        """Show (decluttered) or hide every object label."""
        with self._lock:
            self._enabled = bool(enabled)
            self.refresh_all()

    def refresh_all(self) -> None:
        """Choose again in every tab (the selection or the robot moved)."""
        with self._lock:
            for cid in list(self._tabs):
                self.refresh(cid)

    def refresh(self, client_id: int) -> None:
        """Choose the labels ``client_id``'s view shows and show only those."""
        with self._lock:
            tab = self._tabs.get(client_id)
            if tab is None:
                return
            chosen: list[tuple[int, Rect]] = []
            if self._enabled and self._spots:
                try:
                    chosen = choose(self._spots, tab["client"].camera, self._selected(), self._reserved())
                except Exception:  # noqa: BLE001 - no camera state from the tab yet: show none until it moves
                    chosen = []
            keep = {i for i, _ in chosen}
            for i, h in enumerate(tab["handles"]):
                want = i in keep
                if bool(h.visible) != want:
                    h.visible = want
            tab["shown"] = [(self._spots[i].text, rect) for i, rect in chosen]

    def shown(self, client_id: int | None = None) -> list[tuple[str, Rect]]:
        """The labels a tab shows now, ``(text, screen box [px])`` (the first tab when ``None``; tests)."""
        with self._lock:
            if not self._tabs:
                return []
            tab = self._tabs[client_id] if client_id is not None else next(iter(self._tabs.values()))
            return list(tab["shown"])


__all__ = ["ClientLabels", "LabelSpot", "choose", "declutter", "label_rect", "overlaps", "project", "MAX_LABELS"]
