"""Replay of a search: the viewpoints it chose and the paths it flew and walked, drawn at the shown time.

:class:`SearchReplayView` draws, from the ``/search/step`` records up to the replay's time
(:attr:`console.recording.replay.ReplayState.search`): every viewpoint chosen so far (an arrow from the
camera position along the heading; the latest in orange with its gain and cost, earlier ones grey), the
path of every move (the mission's waypoints; the latest in blue) and, in a *Search* line in the replay
panel, the step shown and the search's end once it has ended. World frame (z up) [m], headings [rad].

The latest viewpoint's label ("viewpoint 3: gain 3.1 m³, cost 4.2") is drawn per tab through the label declutter
(:mod:`console.views.object_labels`, layer ``search``, as the live search's): it never sits on the robot's label
(which wins) nor on another label.
"""

from __future__ import annotations

import html
import math
from typing import Any, Sequence

import numpy as np

from console.views.object_labels import LabelSpot, board_for, show_in_layer

LABEL_NODE = "/search/replay/chosen_why"
"""The viewpoint label's server-wide node, used only on a server without a label declutter."""
CHOSEN_RGB = (255, 140, 0)
EARLIER_RGB = (150, 150, 150)
PATH_RGB = (30, 110, 230)
OLD_PATH_RGB = (140, 170, 220)
ARROW_M = 0.6
"""Length of a viewpoint's heading arrow [m]."""


def viewpoint_segments(viewpoints: Sequence[dict[str, Any]]) -> np.ndarray:
    """``N x 2 x 3`` arrows (camera position -> ``ARROW_M`` along the heading), world [m]."""
    out = np.zeros((len(viewpoints), 2, 3), dtype=np.float32)
    for n, vp in enumerate(viewpoints):
        e = np.asarray(vp["eye"], dtype=np.float32)
        yaw = float(vp["yaw"])
        out[n, 0] = e
        out[n, 1] = e + ARROW_M * np.array([math.cos(yaw), math.sin(yaw), 0.0], dtype=np.float32)
    return out


def path_segments(paths: Sequence[Sequence[Sequence[float]]]) -> np.ndarray:
    """``N x 2 x 3`` line pieces of polylines (world [m])."""
    pieces = [(p[k], p[k + 1]) for p in paths for k in range(len(p) - 1)]
    return np.asarray(pieces, dtype=np.float32).reshape(-1, 2, 3)


def viewpoint_text(n: int, vp: dict[str, Any]) -> str:
    """The label of the ``n``-th viewpoint (1-based): its information gain [m³] and cost."""
    return f"viewpoint {n}: gain {float(vp['gain']):.1f} m³, cost {float(vp['cost']):.1f}"


def search_line(steps: Sequence[dict[str, Any]], result: dict[str, Any] | None) -> str:
    """The replay panel's search line (HTML): the step shown, and the end when it has ended."""
    if not steps:
        return ""
    last = steps[-1]
    text = f"<b>Search</b> {html.escape(str(last.get('search_id', '')))} step {int(last.get('index', 0))}: " \
           f"{html.escape(str(last.get('text', '')))}"
    if result is not None:
        how = "found" if result.get("found") else "ended"
        text += f"<br><b>{how}</b>: {html.escape(str(result.get('reason', '')))}"
        contacts = result.get("contacts") or 0  # (recordings made before the field have none)
        if isinstance(contacts, int) and contacts > 0:
            text += f"; {contacts} move{'s' if contacts > 1 else ''} ended in a contact with something the map " \
                    "did not show"
        if result.get("left_unseen"):
            text += f"; left unseen: {html.escape(str(result['left_unseen']))}"
    return f"<small>{text}</small>"


class SearchReplayView:
    """Draws a recorded search (see the module docstring).

    Args:
        server: The replay's viser server.
        line: A markdown handle for the search line (in the Replay folder).
    """

    def __init__(self, server: Any, line: Any) -> None:
        self._server, self._line = server, line
        self._key: Any = None
        self._handles: dict[str, Any] = {}
        self._fallback: list[Any] = []  # server-wide label nodes (a server without a label declutter)
        self.drawn: dict[str, int] = {"viewpoints": 0, "paths": 0}

    def _put(self, name: str, make: Any) -> None:
        old = self._handles.pop(name, None)
        if old is not None:
            try:
                old.remove()
            except Exception:
                pass
        if make is not None:
            self._handles[name] = make()

    def show(self, state: Any) -> None:
        """Draw the search as recorded at ``state`` (a :class:`~console.recording.replay.ReplayState`)."""
        steps = tuple(getattr(state, "search", ()) or ())
        result = getattr(state, "search_result", None)
        key = (len(steps), steps[-1].get("search_id") if steps else None, result is not None)
        if key == self._key:
            return
        self._key = key
        vps = [s["viewpoint"] for s in steps if s.get("kind") == "viewpoint" and s.get("viewpoint")]
        paths = [s["mission"]["path"] for s in steps if s.get("kind") == "move" and s.get("mission")]
        sc = self._server.scene
        self._put("earlier", None if len(vps) < 2 else lambda: sc.add_line_segments(
            "/search/replay/viewpoints", viewpoint_segments(vps[:-1]), EARLIER_RGB, thickness=0.025))
        self._put("chosen", None if not vps else lambda: sc.add_line_segments(
            "/search/replay/chosen", viewpoint_segments(vps[-1:]), CHOSEN_RGB, thickness=0.05))
        self._show_label(vps)
        self._put("old_paths", None if len(paths) < 2 else lambda: sc.add_line_segments(
            "/search/replay/paths", path_segments(paths[:-1]), OLD_PATH_RGB, thickness=0.02))
        self._put("path", None if not paths or len(paths[-1]) < 2 else lambda: sc.add_line_segments(
            "/search/replay/path", path_segments(paths[-1:]), PATH_RGB, thickness=0.035))
        self.drawn = {"viewpoints": len(vps), "paths": len(paths)}
        self._line.content = search_line(steps, result)

    def _show_label(self, vps: Sequence[dict[str, Any]]) -> None:
        """The latest viewpoint's label (none without a viewpoint), in every tab's declutter."""
        for h in self._fallback:
            try:
                h.remove()
            except Exception:  # noqa: BLE001 - already gone with the scene
                pass
        spots = [] if not vps else [LabelSpot(viewpoint_text(len(vps), vps[-1]),
                                              tuple(float(v) for v in vps[-1]["eye"]), (), "top-left")]  # type: ignore[arg-type]
        self._fallback = show_in_layer(self._server, "search", spots, LABEL_NODE)

    def label_spots(self) -> list[LabelSpot]:
        """The viewpoint label placed now (in the declutter or server-wide), ``[]`` or one (tests)."""
        board = board_for(self._server)
        if board is not None:
            return board.spots("search")
        return [LabelSpot(str(h.text), tuple(float(v) for v in h.position), (), str(h.anchor))  # type: ignore[arg-type]
                for h in self._fallback]


__all__ = ["LABEL_NODE", "SearchReplayView", "path_segments", "search_line", "viewpoint_segments", "viewpoint_text"]
