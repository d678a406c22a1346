"""The known space in the 3D view: what the captures have seen, what they have not, and the
obstacles the detector missed; and the "Plan into unknown space" toggle.

Layers (each one batched mesh; world frame, z up [m]):

- **Unlabelled obstacles** (magenta cubes, on by default): occupied cells no mapped object explains,
  counted in the line under the grid counts ("12 unlabelled obstacle cells");
- **Known space** (off by default: it covers the floor; one click shows it): the floor coloured by
  what the robot's walking column holds there: seen free (pale green), not seen yet (grey, hatched
  look: smaller, darker squares), occupied (not drawn: the grid's own layer shows it).

The view only draws the session's state; the toggle calls :meth:`Session.set_plan_unknown`.
"""

from __future__ import annotations

import html
import math
import threading
from typing import Any

import numpy as np
import trimesh
import viser

from pipeline.mapping.known_space import KnownState, unlabelled_cells

from console.session.known_space_state import BODY_HEIGHT, KNOWN_SPACE
from console.session.session import GRID, ROUTE, SCENE, Session, SessionError
from console.views.client_notice import tell

UNLABELLED_RGB = (200, 40, 200)
SEEN_FREE_RGB = (120, 200, 120)
UNKNOWN_RGB = (120, 120, 132)


def floor_coverage(state: np.ndarray, resolution: float, height: float = BODY_HEIGHT) -> np.ndarray:
    """Per floor column ``(nx, ny)`` what the walking column (the cells up to ``height`` [m]) holds:
    ``OCCUPIED`` if any cell is, else ``FREE`` if all are seen free, else ``UNKNOWN``."""
    k = max(1, min(state.shape[2], int(math.ceil(height / resolution - 1e-9))))
    col = state[:, :, :k]
    out = np.full(state.shape[:2], KnownState.UNKNOWN, dtype=np.uint8)
    out[(col == KnownState.FREE).all(axis=2)] = KnownState.FREE
    out[(col == KnownState.OCCUPIED).any(axis=2)] = KnownState.OCCUPIED
    return out


class KnownSpaceView:
    """Known-space layers, their toggles (in ``layers``) and the summary line.

    Args:
        server: The viser server.
        session: The state it draws.
        layers: The GUI folder the toggles go in (the grid view's Layers folder), or ``None``.
    """

    def __init__(self, server: viser.ViserServer, session: Session, layers: Any = None) -> None:
        self._server = server
        self._session = session
        self._lock = threading.Lock()
        self._handles: dict[str, Any] = {}
        self._cube = trimesh.creation.box(extents=(1.0, 1.0, 1.0))
        gui = server.gui
        self.summary = gui.add_markdown("")
        if layers is not None:
            with layers:
                self._make_toggles(gui)
        else:
            self._make_toggles(gui)
        session.subscribe(self._on_event)
        self.redraw()

    def _make_toggles(self, gui: Any) -> None:
        self.show_unlabelled = gui.add_checkbox(
            "Unlabelled obstacles", True,
            hint="Occupied space the depth saw but no mapped object explains (magenta): the planner avoids it")
        self.show_known = gui.add_checkbox(
            "Known space", False,
            hint="The floor by what the captures saw: seen free (green), not seen yet (grey). Off by default")
        self.show_unlabelled.on_update(lambda _e: self.redraw())
        self.show_known.on_update(lambda _e: self.redraw())

    def _on_event(self, topic: str, _payload: Any) -> None:
        if topic in (GRID, SCENE, KNOWN_SPACE, ROUTE):
            threading.Thread(target=self.redraw, daemon=True).start()

    def _cubes(self, name: str, centres: np.ndarray, size: tuple[float, float, float], rgb: tuple[int, int, int],
               opacity: float) -> None:
        old = self._handles.pop(name, None)
        if len(centres) == 0:
            if old is not None:
                old.remove()
            return
        n = len(centres)
        self._handles[name] = self._server.scene.add_batched_meshes_simple(
            f"/known_space/{name}", vertices=self._cube.vertices * np.asarray(size), faces=self._cube.faces,
            batched_wxyzs=np.tile([1.0, 0.0, 0.0, 0.0], (n, 1)), batched_positions=centres.astype(np.float32),
            batched_colors=rgb, opacity=opacity, lod="off", cast_shadow=False, receive_shadow=False, flat_shading=True)

    def redraw(self) -> None:
        """Redraw the layers and the summary from the session's known space."""
        with self._lock:
            known = self._session.known_space
            summary = self._session.known_summary()
            segs, metres = self._session.unseen_route()
            self._dashes(segs)
            line = summary.text() + (f" · the route crosses {metres:.1f} m of unseen space (dashed)" if metres > 0 else "")
            self.summary.content = f"<small>{html.escape(line)}</small>"
            if known is None:
                for name in list(self._handles):
                    self._cubes(name, np.zeros((0, 3)), (1, 1, 1), (0, 0, 0), 1.0)
                return
            r = known.resolution
            unl = np.argwhere(unlabelled_cells(known, self._session.scene.objects)) if self.show_unlabelled.value \
                else np.zeros((0, 3), int)
            self._cubes("unlabelled", known.centers(unl), (0.8 * r, 0.8 * r, 0.8 * r), UNLABELLED_RGB, 0.85)
            free_xy = unknown_xy = np.zeros((0, 2), int)
            if self.show_known.value:
                cov = floor_coverage(known.state(), r)
                free_xy, unknown_xy = np.argwhere(cov == KnownState.FREE), np.argwhere(cov == KnownState.UNKNOWN)
            z = known.origin[2] + 0.004

            def flat(ij: np.ndarray) -> np.ndarray:
                c = np.asarray(known.origin[:2]) + (ij + 0.5) * r
                return np.column_stack([c, np.full(len(c), z)]) if len(c) else np.zeros((0, 3))

            self._cubes("seen_free", flat(free_xy), (0.92 * r, 0.92 * r, 0.004), SEEN_FREE_RGB, 0.45)
            self._cubes("unknown", flat(unknown_xy), (0.6 * r, 0.6 * r, 0.006), UNKNOWN_RGB, 0.55)

    def _dashes(self, segs: np.ndarray, dash: float = 0.12) -> None:
        """Draw ``segs`` (K x 2 x 3, world [m]) dashed: ``dash`` [m] on, ``dash`` off, over the route."""
        old = self._handles.pop("unseen_route", None)
        pieces = []
        for a, b in np.asarray(segs, dtype=np.float64).reshape(-1, 2, 3):
            n = max(1, int(np.linalg.norm(b - a) / dash))
            for i in range(0, n, 2):
                pieces.append((a + (b - a) * (i / n), a + (b - a) * (min(i + 1, n) / n)))
        if not pieces:
            if old is not None:
                old.remove()
            return
        arr = np.asarray(pieces, dtype=np.float32)
        arr[:, :, 2] += 0.06  # above the route's own line
        self._handles["unseen_route"] = self._server.scene.add_line_segments(
            "/known_space/unseen_route", arr, (250, 250, 250), thickness=0.035)

    def drawn_counts(self) -> dict[str, int]:
        """Instances drawn per layer (tests); ``unseen_route`` counts dashes."""
        with self._lock:
            out = {}
            for name, h in self._handles.items():
                pos = getattr(h, "batched_positions", None)
                out[name] = int(len(pos)) if pos is not None else int(len(h.points))
            return out


class UnknownToggle:
    """The "Plan into unknown space" checkbox (in the current GUI container, e.g. the Plan folder)."""

    def __init__(self, server: viser.ViserServer, session: Session) -> None:
        self._session = session
        self.box = server.gui.add_checkbox(
            "Plan into unknown space", session.plan_unknown == "allow",
            hint="Off: routes only through space the captures saw free. On: routes may cross unseen space "
                 "(drawn dashed, its metres said); the robot may meet what no capture saw")
        self.box.on_update(self._on_update)
        session.subscribe(self._on_event)

    def _on_update(self, event: Any) -> None:
        want = bool(self.box.value)
        try:
            text = self._session.set_plan_unknown(want)
        except SessionError as exc:
            self.box.value = self._session.plan_unknown == "allow"
            tell(event.client, "Not possible", str(exc), "yellow", 7.0)
            return
        tell(event.client, "Planning rule", text, "blue", 5.0)

    def _on_event(self, topic: str, _payload: Any) -> None:
        if topic == KNOWN_SPACE:
            allow = self._session.plan_unknown == "allow"
            if bool(self.box.value) != allow:
                self.box.value = allow


__all__ = ["KnownSpaceView", "UnknownToggle", "floor_coverage", "UNLABELLED_RGB", "SEEN_FREE_RGB", "UNKNOWN_RGB"]
