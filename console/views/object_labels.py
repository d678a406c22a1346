"""Labels that never overlap: drawn per browser tab and decluttered for that tab's view.

viser draws a label as a billboard of constant screen size (``12 px * font_screen_scale`` per em,
whatever the distance). Every tab gets its own label nodes (``client.scene``) in *layers*: the mapped
objects' labels (``objects``), the search's viewpoint (``search``: the live search's next viewpoint, set by the
search view, or in a replay the recorded search's latest, set by :mod:`console.recording.replay_search`), the
agent's candidate goal (``agent``: "proposed by the agent", set by the approval view) and the mission's take-off
and landing spots (``paths``, set by the paths view). Whenever a tab's camera moves, or the robot or another label
moves, the labels are projected into that tab's picture and kept greedily, most important first (the selected
object's, then the search's viewpoint, the agent's, the paths', then the nearest objects'), skipping any whose
box would overlap one already kept, up to :data:`MAX_LABELS`.

Labels every tab shares (server-wide nodes: the robot's, the origin's) are always drawn and win:
the decluttered ones leave them free (:func:`fixed_labels` reads them, with their text and where they are now,
from the viser server), and the goal markers too (:meth:`ClientLabels.set_markers`).
Zooming in spreads the objects apart and shows more labels; selecting an object always shows its label.

Frames: world z up [m]; the tab's camera pose is viser's (``wxyz`` world <- camera, OpenCV optical
frame: x right, y down, z forward); pixels are the camera image's (x right, y down).
"""

from __future__ import annotations

import logging
import math
import threading
import weakref
from dataclasses import dataclass
from typing import Any, Callable, Sequence

import numpy as np

log = logging.getLogger(__name__)

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

MARKER_PX = 18.0
"""Side of the square kept free around a goal marker [CSS px] (a 0.07-0.08 m sphere seen from the default view)."""

LAYERS = ("search", "agent", "paths", "objects")
"""Label layers in order of importance (after the selected object's label, always first): the search's
viewpoint, the agent's candidate goal, the mission's take-off and landing spots, the mapped objects."""

MARKER_LAYERS = ("search", "agent", "paths")
"""Layers whose labels name a marker (a take-off spot, the viewpoint the robot goes to, the goal the agent
planned): they may touch it."""

Rect = tuple[float, float, float, float]  # x0, y0, x1, y1 [px], x right, y down


@dataclass(frozen=True)
class LabelSpot:
    """A label to place: its text, its anchor point (world [m]; by default the box's bottom centre) and the
    object ids it names; ``anchor`` is viser's (``"top-center"``: the box hangs below the point),
    ``font_scale`` viser's ``font_screen_scale``."""

    text: str
    position: tuple[float, float, float]
    ids: tuple[str, ...] = ()
    anchor: str = "bottom-center"
    font_scale: float = FONT_SCREEN_SCALE


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


def label_rect(text: str, u: float, v: float, px_per_css: float = 1.0, anchor: str = "bottom-center",
               font_scale: float = FONT_SCREEN_SCALE) -> Rect:
    """The screen box [px] of a label anchored at pixel ``(u, v)`` (viser's layout: one line of ``1.2`` em, a
    background padding of ``0.2`` line heights; ``anchor`` as viser's, e.g. ``bottom-center``: the point is the
    box's bottom centre), ``px_per_css`` picture pixels per CSS pixel."""
    em = 12.0 * font_scale * px_per_css
    line = 1.2 * em
    pad = 0.2 * line
    w = CHAR_EM * em * max(1, len(text)) + pad
    h = line + pad
    vert, _, horiz = anchor.partition("-")
    x0 = {"left": u, "right": u - w}.get(horiz, u - w / 2)
    y0 = {"top": v, "bottom": v - h}.get(vert, v - h / 2)
    return (x0, y0, x0 + w, y0 + h)


def overlaps(a: Rect, b: Rect, gap: float = GAP_PX) -> bool:
    """Whether two boxes overlap or come closer than ``gap`` [px]."""
    return a[0] < b[2] + gap and b[0] < a[2] + gap and a[1] < b[3] + gap and b[1] < a[3] + gap


def declutter(rects: Sequence[Rect | None], order: Sequence[int], reserved: Sequence[Rect] = (),
              limit: int = MAX_LABELS, gap: float = GAP_PX, soft: Sequence[Rect] = (),
              exempt: frozenset[int] | set[int] = frozenset()) -> list[int]:
    """Indices of ``rects`` to show: taken in ``order``, each kept when it overlaps no box kept before
    it nor a ``reserved`` one nor (unless its index is in ``exempt``) a ``soft`` one (markers), at most
    ``limit``; ``None`` (off the picture) is never kept."""
    kept: list[int] = []
    boxes = list(reserved)
    for i in order:
        r = rects[i]
        if r is None or len(kept) >= limit:
            continue
        if any(overlaps(r, b, gap) for b in boxes):
            continue
        if i not in exempt and any(overlaps(r, b, gap) for b in soft):
            continue
        kept.append(i)
        boxes.append(r)
    return kept


def px_per_css(image_height: float) -> float:
    """A guess of the picture's device pixels per CSS pixel: 1 up to 1100 px tall, more above (a
    taller picture is most likely a high-density screen); too big a guess only shows fewer labels."""
    return max(1.0, float(image_height) / 1100.0)


@dataclass(frozen=True)
class FixedLabel:
    """A label every tab shows (a server-wide node): text, anchor point (world [m]), viser's anchor and scale."""

    text: str
    position: tuple[float, float, float]
    anchor: str = "bottom-center"
    font_scale: float = FONT_SCREEN_SCALE


def _as_fixed(r: Any) -> FixedLabel:
    return r if isinstance(r, FixedLabel) else FixedLabel(str(r[0]), tuple(float(v) for v in r[1]))  # type: ignore[arg-type]


def choose(spots: Sequence[LabelSpot], camera: Any, selected: str | None = None,
           reserved_spots: Sequence[Any] = (), limit: int = MAX_LABELS,
           markers: Sequence[Sequence[float]] = (), rank: Sequence[int] | None = None,
           marker_exempt: Sequence[int] = (), frame: Rect | None = None) -> list[tuple[int, Rect]]:
    """Which labels a camera shows: ``(index into spots, screen box [px])``, most important first.

    ``camera`` has viser's ``wxyz``, ``position``, ``fov``, ``image_width`` and ``image_height``;
    ``selected`` is the selected object's id (its label first); ``reserved_spots`` are labels every tab shows
    (:class:`FixedLabel`, or ``(text, anchor point)`` with a bottom-centre anchor: the robot's) and
    ``markers`` world points (goal markers) that the chosen labels must leave free, except the spots indexed in
    ``marker_exempt`` (a take-off spot's label names the marker it hangs from); ``rank`` orders the spots
    after the selected one (lower first; default all equal), then the nearest first. ``frame`` is the part of
    the picture the operator sees ``(x0, y0, x1, y1)`` [px] (on a phone, above the control sheet): a label not
    wholly inside it is not shown (default: the whole picture; a label cut by its edge is never shown).
    """
    W, H = float(camera.image_width), float(camera.image_height)
    if W <= 0 or H <= 0:
        return []
    frame = frame if frame is not None else (0.0, 0.0, W, H)
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
        r = label_rect(s.text, p[0], p[1], scale, s.anchor, s.font_scale)
        if not (frame[0] <= r[0] and r[2] <= frame[2] and frame[1] <= r[1] and r[3] <= frame[3]):
            rects.append(None)  # cut by the picture's edge or under the phone's sheet: part of it at best
            depth.append(math.inf)
            continue
        rects.append(r)
        depth.append(p[2])
    reserved = []
    for r in map(_as_fixed, reserved_spots):
        p = project(*pose, r.position)
        if p is not None:
            reserved.append(label_rect(r.text, p[0], p[1], scale, r.anchor, r.font_scale))
    half = MARKER_PX * scale / 2
    soft = []
    for m in markers:
        p = project(*pose, m)
        if p is not None:
            soft.append((p[0] - half, p[1] - half, p[0] + half, p[1] + half))
    ranks = list(rank) if rank is not None else [0] * len(spots)
    order = sorted(range(len(spots)), key=lambda i: (0 if selected is not None and selected in spots[i].ids else 1,
                                                     ranks[i], depth[i]))
    keep = declutter(rects, order, reserved, limit, GAP_PX * scale, soft, frozenset(marker_exempt))
    return [(i, rects[i]) for i in keep]  # type: ignore[misc]


def _quat_rotate(wxyz: Sequence[float], p: np.ndarray) -> np.ndarray:
    w, x, y, z = (float(v) for v in wxyz)
    R = np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                  [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                  [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])
    return R @ p


def fixed_labels(server: Any, skip: str = "/labels/") -> list[FixedLabel]:
    """The labels every tab of ``server`` shows now (server-wide label nodes, visible with all their parents),
    each with its world anchor point [m] (its position through its parents' poses); per-tab nodes under
    ``skip`` are not included. Read from viser's own node table; empty if it cannot be read."""
    from viser._scene_handles import LabelHandle

    nodes: dict[str, Any] = {}
    for _ in range(3):  # another thread adding a node meanwhile: read again
        try:
            nodes = dict(server.scene._handle_from_node_name)
            break
        except (RuntimeError, AttributeError):
            nodes = {}
    out = []
    for name, h in nodes.items():
        if not isinstance(h, LabelHandle) or name.startswith(skip):
            continue
        try:
            if not h.visible:
                continue
            p = np.asarray(h.position, dtype=np.float64)
            parent, shown = name.rsplit("/", 1)[0], True
            while parent:
                frame = nodes.get(parent)
                if frame is not None:
                    if not frame.visible:
                        shown = False
                        break
                    p = _quat_rotate(frame.wxyz, p) + np.asarray(frame.position, dtype=np.float64)
                parent = parent.rsplit("/", 1)[0]
            if shown:
                out.append(FixedLabel(str(h.text), (float(p[0]), float(p[1]), float(p[2])), str(h.anchor),
                                      float(h.font_screen_scale)))
        except Exception:  # noqa: BLE001 - a node removed meanwhile: not drawn any more
            continue
    return out


_boards: "weakref.WeakValueDictionary[int, ClientLabels]" = weakref.WeakValueDictionary()


def board_for(server: Any) -> "ClientLabels | None":
    """The decluttered labels of ``server`` (the objects view makes them), or ``None`` when it has none."""
    return _boards.get(id(server))


def show_in_layer(server: Any, layer: str, spots: Sequence[LabelSpot], fallback: str) -> Any:
    """Put ``spots`` in ``layer`` of ``server``'s per-tab declutter (:func:`board_for`), which places them in every
    tab (the robot's label wins); a server without one (no objects view) gets them as server-wide labels named
    ``fallback``, ``fallback_1``, ... Returns those server-wide handles (remove them before the next call), or
    ``[]`` with a declutter. Raises ``ValueError`` naming ``layer`` when it is not one of :data:`LAYERS`."""
    if layer not in LAYERS:
        raise ValueError(f"layer: must be one of {', '.join(LAYERS)}, got {layer!r}")
    board = board_for(server)
    if board is not None:
        board.set_layer(layer, spots)
        return []
    return [server.scene.add_label(fallback if n == 0 else f"{fallback}_{n}", s.text, position=s.position,
                                   anchor=s.anchor, font_screen_scale=s.font_scale) for n, s in enumerate(spots)]


class ClientLabels:
    """The decluttered labels of every tab of a viser server (one per server: :func:`board_for` finds it).

    Args:
        server: The viser server.
        selected: Returns the selected object's id, or ``None``.
        reserved: Returns more labels ``(text, anchor world [m])`` the others must leave free (beside the
            server-wide ones, which :func:`fixed_labels` finds by itself).
    """

    def __init__(self, server: Any, selected: Callable[[], str | None],
                 reserved: Callable[[], Sequence[Any]] = lambda: ()) -> None:
        from console.views.refresher import Refresher

        self._server = server
        self._selected = selected
        self._reserved = reserved
        self._lock = threading.RLock()
        self._layers: dict[str, list[LabelSpot]] = {name: [] for name in LAYERS}
        self._markers: dict[str, list[tuple[float, float, float]]] = {}
        self._enabled = True
        self._tabs: dict[int, dict[str, Any]] = {}  # client id -> {"client", "handles", "shown"}
        self._later = Refresher(self.refresh_all, "labels")  # moved(): one coalesced re-choice off the caller
        _boards[id(server)] = self
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

    def _all(self) -> list[tuple[str, LabelSpot]]:
        return [(layer, s) for layer, spots in self._layers.items() for s in spots]

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
        counts: dict[str, int] = {}
        handles = []
        for layer, s in self._all():
            n = counts[layer] = counts.get(layer, -1) + 1
            name = f"/labels/{n}" if layer == "objects" else f"/labels/{layer}/{n}"
            handles.append(client.scene.add_label(name, s.text, position=s.position, anchor=s.anchor,
                                                  font_screen_scale=s.font_scale, visible=False))
        tab["handles"] = handles
        tab["shown"] = []
        self.refresh(client_id)

    # --- what the views say -------------------------------------------------------------------------
    def spots(self, layer: str = "objects") -> list[LabelSpot]:
        """The labels of ``layer`` (shown or not)."""
        with self._lock:
            return list(self._layers.get(layer, []))

    def set_spots(self, spots: Sequence[LabelSpot]) -> None:
        """Replace the object labels (a new scene) in every tab."""
        self.set_layer("objects", spots)

    def set_layer(self, layer: str, spots: Sequence[LabelSpot]) -> None:
        """Replace the labels of ``layer`` (one of :data:`LAYERS`) in every tab (nothing when unchanged)."""
        if layer not in LAYERS:
            raise ValueError(f"layer: must be one of {', '.join(LAYERS)}, got {layer!r}")
        with self._lock:
            if list(spots) == self._layers[layer]:
                return
            self._layers[layer] = list(spots)
            for cid in list(self._tabs):
                self._rebuild(cid)

    def set_markers(self, name: str, points: Sequence[Sequence[float]]) -> None:
        """World points [m] (goal markers) labels leave free, under ``name``; re-chosen at once in every tab."""
        pts = [tuple(float(v) for v in p) for p in points]
        with self._lock:
            if self._markers.get(name, []) == pts:
                return
            self._markers[name] = pts  # type: ignore[assignment]
        self.moved()

    @staticmethod
    def _frame(camera: Any) -> Rect:
        """The part of a tab's picture the operator sees [px]: all of it (the docked panels sit beside the 3D
        view), on a phone the part above the control sheet laid over it."""
        from console.views.screen_layout import PHONE_ASPECT, PHONE_SHEET_VH

        W, H = float(camera.image_width), float(camera.image_height)
        if H > 0 and W / H < PHONE_ASPECT:  # a phone held upright (as screen_layout tells it; a desktop view between the
            # panels at 1280 x 720 is only about 580 px wide, but wider than tall)
            return (0.0, 0.0, W, H * (1.0 - PHONE_SHEET_VH / 100.0))
        return (0.0, 0.0, W, H)

    def set_enabled(self, enabled: bool) -> None:
        """Show (decluttered) or hide every object label (the search's and the paths' labels stay)."""
        with self._lock:
            self._enabled = bool(enabled)
            self.refresh_all()

    def moved(self) -> None:
        """Something every tab shows moved (the robot, a server-wide label): choose again in every tab, on the
        labels' own worker (returns at once; a burst of calls costs one re-choice)."""
        self._later.poke()

    def close(self) -> None:
        """Stop the worker of :meth:`moved`."""
        self._later.close()

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
            layered = self._all() if self._enabled else [(la, s) for la, s in self._all() if la != "objects"]
            index = {id(s): i for i, (_, s) in enumerate(self._all())}
            chosen: list[tuple[int, Rect]] = []
            if layered:
                try:
                    spots = [s for _, s in layered]
                    rank = [LAYERS.index(la) for la, _ in layered]
                    reserved = list(fixed_labels(self._server)) + list(self._reserved())
                    markers = [m for pts in self._markers.values() for m in pts]
                    camera = tab["client"].camera
                    picked = choose(spots, camera, self._selected(), reserved, markers=markers, rank=rank,
                                    marker_exempt=[i for i, (la, _) in enumerate(layered) if la in MARKER_LAYERS],
                                    frame=self._frame(camera))
                    chosen = [(index[id(spots[i])], rect) for i, rect in picked]
                except Exception:  # noqa: BLE001 - no camera state from the tab yet: show none until it moves
                    chosen = []
            keep = {i for i, _ in chosen}
            for i, h in enumerate(tab["handles"]):
                want = i in keep
                if bool(h.visible) != want:
                    h.visible = want
            all_spots = self._all()
            tab["shown"] = [(all_spots[i][1].text, rect) for i, rect in chosen]
            tab["layers"] = [all_spots[i][0] for i, _ in chosen]

    def shown(self, client_id: int | None = None, layer: str | None = None) -> list[tuple[str, Rect]]:
        """The labels a tab shows now, ``(text, screen box [px])`` (the first tab when ``None``; only ``layer``'s
        when given; tests)."""
        with self._lock:
            if not self._tabs:
                return []
            tab = self._tabs[client_id] if client_id is not None else next(iter(self._tabs.values()))
            pairs = list(zip(tab["shown"], tab.get("layers", [])))
            return [s for s, la in pairs if layer is None or la == layer]


__all__ = ["ClientLabels", "FixedLabel", "LAYERS", "LabelSpot", "MAX_LABELS", "board_for", "choose", "declutter",
           "fixed_labels", "label_rect", "overlaps", "project", "show_in_layer"]
