"""What the robot has not seen yet, for an agent: the known space's counts and the floor's frontier.

Reads :attr:`console.session.session.Session.known_space` (world frame, z up [m]); pure, no I/O.
The *frontier* is the seen-free floor next to floor that no capture has seen: where to go or look
next (the same idea as a frontier-based explorer's). Before the first capture there is no known
space: ``known`` is false and ``text`` says which rule holds (the console's own map: nothing seen yet,
every cell unknown; a map of scene files: taken as fully known, as the planner does).
"""

from __future__ import annotations

from typing import Any, Sequence

import numpy as np

from pipeline.mapping.known_space import KnownState

FRONTIER_MAX = 12
"""Frontier points returned, nearest to the robot first."""


def frontier_floor(state: np.ndarray) -> np.ndarray:
    """Floor-layer cells ``(i, j)`` that are seen free with an unknown 4-neighbour. ``state``: the known
    space's ``(nx, ny, nz)`` :class:`KnownState` array; returns ``(K, 2)`` int indices."""
    floor = state[:, :, 0]
    unknown = floor == KnownState.UNKNOWN
    near = np.zeros_like(unknown)
    near[1:, :] |= unknown[:-1, :]
    near[:-1, :] |= unknown[1:, :]
    near[:, 1:] |= unknown[:, :-1]
    near[:, :-1] |= unknown[:, 1:]
    return np.argwhere((floor == KnownState.FREE) & near)


def unseen_space(session: Any, robot_xy: Sequence[float] | None = None) -> dict[str, Any]:
    """The known space for an agent: ``{"known": bool, "text", "seen_share", "floor_seen_share",
    "cells": {...}, "policy", "frontier": [[x, y, z], ...] (world [m], nearest the robot first),
    "frontier_cells": int}``."""
    summary = session.known_summary()
    space = session.known_space
    out: dict[str, Any] = {"known": space is not None, "text": summary.text(), "policy": summary.policy,
                           "seen_share": round(summary.seen_share, 4),
                           "cells": {"total": summary.cells, "free": summary.free, "occupied": summary.occupied,
                                     "unknown": summary.unknown, "unlabelled_obstacles": summary.unlabelled}}
    if space is None:
        out.update(floor_seen_share=None, frontier=[], frontier_cells=0)
        return out
    state = space.state()
    floor = state[:, :, 0]
    out["floor_seen_share"] = round(float(np.mean(floor != KnownState.UNKNOWN)), 4)
    cells = frontier_floor(state)
    out["frontier_cells"] = int(len(cells))
    if len(cells):
        ijk = np.concatenate([cells, np.zeros((len(cells), 1), dtype=cells.dtype)], axis=1)
        pts = space.centers(ijk)
        pts[:, 2] = space.origin[2]
        if robot_xy is not None:
            order = np.argsort(np.hypot(pts[:, 0] - robot_xy[0], pts[:, 1] - robot_xy[1]), kind="stable")
            pts = pts[order]
        out["frontier"] = [[round(float(v), 3) for v in p] for p in pts[:FRONTIER_MAX]]
    else:
        out["frontier"] = []
    return out
