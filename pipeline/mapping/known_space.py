"""Known space: which cells of the room the captures have seen free, seen occupied, or not seen.

A :class:`KnownSpace` is a 3D voxel grid in the world frame (z up) [m]: cell ``(i, j, k)`` spans
``origin + (i, j, k) * resolution`` to ``origin + (i+1, j+1, k+1) * resolution`` (the same cell
convention as the planner's :class:`planner.grid.Workspace`; make one with
:meth:`KnownSpace.empty` from the planning workspace's bounds and resolution, or a finer one).

Each cell holds an occupancy log-odds value, as OctoMap does (Hornung et al. 2013): a capture's ray
that passes through a cell lowers it (a *miss*), a depth surface in a cell raises it (a *hit*);
each cell is updated at most once per capture, a hit winning over a miss; values are clamped so a
cell can change its mind after a few captures. The value is stored as an ``int8`` in units of
:data:`LOG_ODDS_UNIT` (1/32 of a nat), so updates are exact integer additions and a saved
grid merges and reloads bit for bit:

============== ===================== =========================================================
 constant       value (units / nats)  meaning
============== ===================== =========================================================
 ``LOG_HIT``    +55 / +1.72           OctoMap's hit probability 0.85
 ``LOG_MISS``   -13 / -0.41           OctoMap's miss probability 0.40
 ``LOG_MIN``    -64 / -2.0            clamping (OctoMap: 0.12)
 ``LOG_MAX``    +112 / +3.5           clamping (OctoMap: 0.97)
============== ===================== =========================================================

The three states (:class:`KnownState`, :meth:`KnownSpace.state`): ``UNKNOWN`` (0: log-odds 0, no
capture said anything), ``FREE`` (1: log-odds < 0, *seen free*), ``OCCUPIED`` (2: log-odds > 0).

Known space is immutable: every update returns a new object (the session keeps one per capture
for undo). The update from one capture's depth map is in :mod:`pipeline.mapping.known_space_update`;
the planner reads it through :meth:`KnownSpace.planning_view` (occupancy state and *unlabelled*
obstacle cells on the planning grid), so :mod:`planner` never imports this module.

Serialised form (:meth:`KnownSpace.to_dict`, JSON-safe, compact: the session file, the MCAP and a
scene file's optional top-level ``"known_space"`` key)::

    {"format": "morphonavi.known_space", "version": 1, "origin": [x, y, z], "resolution": r,
     "shape": [nx, ny, nz], "encoding": "int8 log-odds/32, C order, zlib, base64", "data": "..."}
"""

from __future__ import annotations

import base64
import math
import zlib
from dataclasses import dataclass
from enum import IntEnum
from typing import Any, Mapping, Sequence

import numpy as np

from pipeline.scene import SceneObject

LOG_ODDS_UNIT = 1.0 / 32.0
"""Nats per stored log-odds unit."""
LOG_HIT = 55
LOG_MISS = -13
LOG_MIN = -64
LOG_MAX = 112

FORMAT = "morphonavi.known_space"
VERSION = 1
ENCODING = "int8 log-odds/32, C order, zlib, base64"
MAX_CELLS = 50_000_000
"""Largest grid accepted (cells), e.g. 25 x 25 x 5 m at 0.05 m."""

EXPLAINED_TOLERANCE = 0.15
"""How far [m] outside a mapped object's box a seen surface still counts as that object (about the
mapper's mean position error, 13.6 cm in the paper)."""


class KnownSpaceError(ValueError):
    """Bad known-space parameters or serialised data; the message names the field."""


class KnownState(IntEnum):
    """What the captures say about a cell."""

    UNKNOWN = 0
    FREE = 1
    OCCUPIED = 2


def _finite3(v: Any, name: str) -> tuple[float, float, float]:
    try:
        t = tuple(float(x) for x in v)
    except (TypeError, ValueError):
        raise KnownSpaceError(f"{name}: must be 3 numbers [m], got {v!r}") from None
    if len(t) != 3 or not all(math.isfinite(x) for x in t):
        raise KnownSpaceError(f"{name}: must be 3 finite numbers [m], got {v!r}")
    return (t[0], t[1], t[2])


def _check_resolution(r: Any) -> float:
    if isinstance(r, bool) or not isinstance(r, (int, float, np.floating, np.integer)):
        raise KnownSpaceError(f"resolution: must be a number [m], got {r!r}")
    r = float(r)
    if not (math.isfinite(r) and r > 0):
        raise KnownSpaceError(f"resolution: must be finite and > 0 m, got {r}")
    return r


@dataclass(frozen=True, eq=False)
class KnownSpace:
    """An occupancy log-odds grid (see the module docstring). Build with :meth:`empty`.

    Attributes:
        origin: Minimum corner of cell ``(0, 0, 0)`` [m] (world).
        resolution: Cell edge [m].
        log_odds: ``int8 [nx, ny, nz]`` in units of :data:`LOG_ODDS_UNIT` (read-only).
    """

    origin: tuple[float, float, float]
    resolution: float
    log_odds: np.ndarray

    def __post_init__(self) -> None:
        object.__setattr__(self, "origin", _finite3(self.origin, "origin"))
        object.__setattr__(self, "resolution", _check_resolution(self.resolution))
        a = np.asarray(self.log_odds)
        if a.ndim != 3 or 0 in a.shape:
            raise KnownSpaceError(f"log_odds: must be a non-empty 3D array, got shape {a.shape}")
        a = np.ascontiguousarray(a, dtype=np.int8)
        if a.base is not None or a.flags.writeable:
            a = a.copy()
        a.flags.writeable = False
        object.__setattr__(self, "log_odds", a)

    # --- construction ------------------------------------------------------------------------
    @staticmethod
    def empty(bounds_min: Sequence[float], bounds_max: Sequence[float], resolution: float) -> "KnownSpace":
        """All cells unknown over the box ``bounds_min``..``bounds_max`` [m] (world), cubic cells of
        ``resolution`` [m]; cells per axis ``round(extent / resolution)`` (as the planning workspace)."""
        lo = _finite3(bounds_min, "bounds_min")
        hi = _finite3(bounds_max, "bounds_max")
        r = _check_resolution(resolution)
        for a, name in enumerate("xyz"):
            if not hi[a] > lo[a]:
                raise KnownSpaceError(f"bounds_max.{name}: must exceed bounds_min.{name}, got {hi[a]} <= {lo[a]}")
        shape = tuple(max(1, int(round((hi[a] - lo[a]) / r))) for a in range(3))
        if math.prod(shape) > MAX_CELLS:
            raise KnownSpaceError(f"resolution: {shape} cells is too many (limit {MAX_CELLS}); use coarser cells")
        return KnownSpace(lo, r, np.zeros(shape, dtype=np.int8))

    # --- geometry ------------------------------------------------------------------------------
    @property
    def shape(self) -> tuple[int, int, int]:
        s = self.log_odds.shape
        return (int(s[0]), int(s[1]), int(s[2]))

    @property
    def bounds_max(self) -> tuple[float, float, float]:
        """Maximum corner [m] (world)."""
        return tuple(self.origin[a] + self.shape[a] * self.resolution for a in range(3))  # type: ignore[return-value]

    def centers(self, cells: np.ndarray) -> np.ndarray:
        """World centres [m] of cells ``(N, 3)`` int."""
        c = np.asarray(cells, dtype=np.float64).reshape(-1, 3)
        return np.asarray(self.origin) + (c + 0.5) * self.resolution

    # --- states ----------------------------------------------------------------------------------
    def state(self) -> np.ndarray:
        """``uint8 [nx, ny, nz]`` of :class:`KnownState` values."""
        out = np.zeros(self.shape, dtype=np.uint8)
        out[self.log_odds < 0] = KnownState.FREE
        out[self.log_odds > 0] = KnownState.OCCUPIED
        return out

    def counts(self) -> dict[str, int]:
        """Cells per state: ``{"unknown": n, "free": n, "occupied": n}``."""
        st = self.state()
        return {s.name.lower(): int(np.count_nonzero(st == s)) for s in KnownState}

    def is_blank(self) -> bool:
        """No capture has said anything yet (every cell unknown)."""
        return not bool(np.any(self.log_odds))

    # --- updates (each returns a new KnownSpace) ---------------------------------------------------
    def updated(self, free: np.ndarray, occupied: np.ndarray) -> "KnownSpace":
        """One observation: ``free`` cells get a miss, ``occupied`` cells a hit (a cell in both
        gets the hit only). Both ``bool [nx, ny, nz]``."""
        f = np.asarray(free, dtype=bool)
        o = np.asarray(occupied, dtype=bool)
        if f.shape != self.shape or o.shape != self.shape:
            raise KnownSpaceError(f"free/occupied: must have the grid's shape {self.shape}, got {f.shape} and {o.shape}")
        lo = self.log_odds.astype(np.int16)
        lo[f & ~o] += LOG_MISS
        lo[o] += LOG_HIT
        np.clip(lo, LOG_MIN, LOG_MAX, out=lo)
        return KnownSpace(self.origin, self.resolution, lo.astype(np.int8))

    def merged(self, other: "KnownSpace") -> "KnownSpace":
        """Both grids' evidence added (log-odds sum, clamped), e.g. two sessions of one room.
        The grids must be the same (origin, resolution, shape)."""
        if not self.same_grid(other):
            raise KnownSpaceError(
                f"cannot merge known space on different grids: origin {other.origin} resolution {other.resolution} "
                f"shape {other.shape} vs origin {self.origin} resolution {self.resolution} shape {self.shape}")
        lo = self.log_odds.astype(np.int16) + other.log_odds.astype(np.int16)
        np.clip(lo, LOG_MIN, LOG_MAX, out=lo)
        return KnownSpace(self.origin, self.resolution, lo.astype(np.int8))

    def with_free_body(self, position: Sequence[float], radius: float, height: float) -> "KnownSpace":
        """The robot's own body is seen free by definition: cells whose centre lies within the
        vertical cylinder of ``radius`` [m] around ``position`` (world [m], the body's bottom
        centre) from its bottom up to ``height`` [m] above it are set to free (:data:`LOG_MIN`),
        whatever they held. Call it with the robot's pose when it captures (it stood there)."""
        p = _finite3(position, "position")
        for name, v in (("radius", radius), ("height", height)):
            if not (isinstance(v, (int, float)) and math.isfinite(v) and v >= 0):
                raise KnownSpaceError(f"{name}: must be a finite number >= 0 [m], got {v!r}")
        xs, ys, zs = (self.origin[a] + (np.arange(n) + 0.5) * self.resolution for a, n in enumerate(self.shape))
        foot = np.hypot(xs[:, None] - p[0], ys[None, :] - p[1]) <= radius + 1e-9
        col = (zs >= p[2] - 1e-9) & (zs <= p[2] + height + 1e-9)
        own = foot[:, :, None] & col[None, None, :]
        cell = self.cell_of(p)
        if cell is not None:
            own[cell] = True
        if not own.any():
            return self
        lo = self.log_odds.copy()
        lo[own] = LOG_MIN
        return KnownSpace(self.origin, self.resolution, lo)

    def cell_of(self, point: Sequence[float]) -> tuple[int, int, int] | None:
        """The cell holding a world point [m], ``None`` outside (the maximum faces belong to the
        last cells, as in the planning workspace)."""
        idx = []
        for a in range(3):
            v = float(point[a])
            if not (self.origin[a] <= v <= self.bounds_max[a]):
                return None
            idx.append(min(int((v - self.origin[a]) / self.resolution), self.shape[a] - 1))
        return (idx[0], idx[1], idx[2])

    def same_grid(self, other: "KnownSpace") -> bool:
        return (self.shape == other.shape and abs(self.resolution - other.resolution) < 1e-9
                and all(abs(a - b) < 1e-9 for a, b in zip(self.origin, other.origin)))

    # --- what the planner reads ------------------------------------------------------------------
    def planning_view(self, origin: Sequence[float], shape: Sequence[int], resolution: float,
                      objects: Sequence[SceneObject] = (), tolerance: float = EXPLAINED_TOLERANCE
                      ) -> tuple[np.ndarray, np.ndarray]:
        """``(state, unlabelled)`` on a planning grid (``origin`` [m], ``shape`` cells, ``resolution`` [m]).

        ``state``: ``uint8 [nx, ny, nz]`` of :class:`KnownState` per planning cell. When this grid is
        finer (an integer ``factor`` of sub-cells per axis, aligned) a planning cell is occupied if
        any sub-cell is, else seen free if at least half its sub-cells are (a ray sampled past a
        corner leaves a few unseen), else unknown. Planning cells outside this grid are unknown.
        ``unlabelled``: occupied planning cells not explained by any object of ``objects`` (see
        :func:`unlabelled_mask`).

        Raises :class:`KnownSpaceError` when the grids do not align (resolution not this grid's times
        a whole number, or origins not on this grid's cell corners).
        """
        o = _finite3(origin, "origin")
        res = _check_resolution(resolution)
        nshape = tuple(int(v) for v in shape)
        factor = res / self.resolution
        f = int(round(factor))
        if f < 1 or abs(factor - f) > 1e-6:
            raise KnownSpaceError(f"resolution: the planning cells ({res} m) must be a whole multiple of the known-space "
                                  f"cells ({self.resolution} m)")
        off = [(o[a] - self.origin[a]) / self.resolution for a in range(3)]
        if any(abs(v - round(v)) > 1e-6 for v in off):
            raise KnownSpaceError(f"origin: the planning grid's origin {o} is not on a known-space cell corner "
                                  f"(known space origin {self.origin}, cells {self.resolution} m)")
        off_i = [int(round(v)) for v in off]
        st = self.state()
        # sub-cell states of every planning cell, UNKNOWN where the known space does not reach
        sub = np.zeros((nshape[0] * f, nshape[1] * f, nshape[2] * f), dtype=np.uint8)
        src = []
        dst = []
        for a in range(3):
            s0 = max(0, off_i[a])
            s1 = min(st.shape[a], off_i[a] + nshape[a] * f)
            if s1 <= s0:
                return np.zeros(nshape, np.uint8), np.zeros(nshape, bool)
            src.append(slice(s0, s1))
            dst.append(slice(s0 - off_i[a], s1 - off_i[a]))
        sub[dst[0], dst[1], dst[2]] = st[src[0], src[1], src[2]]
        blocks = sub.reshape(nshape[0], f, nshape[1], f, nshape[2], f)
        occ = (blocks == KnownState.OCCUPIED).any(axis=(1, 3, 5))
        free_n = (blocks == KnownState.FREE).sum(axis=(1, 3, 5))
        out = np.zeros(nshape, dtype=np.uint8)
        out[free_n * 2 >= f ** 3] = KnownState.FREE
        out[occ] = KnownState.OCCUPIED
        centres_of = (lambda idx: np.asarray(o) + (idx + 0.5) * res)
        unl = unlabelled_mask(out == KnownState.OCCUPIED, centres_of, res, objects, tolerance)
        return out, unl

    # --- serialisation -----------------------------------------------------------------------------
    def to_dict(self) -> dict[str, Any]:
        """JSON-safe compact form (see the module docstring)."""
        raw = zlib.compress(self.log_odds.tobytes(order="C"), 6)
        return {"format": FORMAT, "version": VERSION, "origin": list(self.origin), "resolution": self.resolution,
                "shape": list(self.shape), "encoding": ENCODING, "data": base64.b64encode(raw).decode("ascii")}

    @staticmethod
    def from_dict(data: Mapping[str, Any], where: str = "known_space") -> "KnownSpace":
        """Read :meth:`to_dict` output; raises :class:`KnownSpaceError` naming the bad field."""
        if not isinstance(data, Mapping):
            raise KnownSpaceError(f"{where}: must be an object, got {type(data).__name__}")
        if data.get("format") != FORMAT:
            raise KnownSpaceError(f"{where}.format: must be {FORMAT!r}, got {data.get('format')!r}")
        v = data.get("version")
        if not isinstance(v, int) or isinstance(v, bool) or not 1 <= v <= VERSION:
            raise KnownSpaceError(f"{where}.version: must be 1..{VERSION}, got {v!r}")
        if data.get("encoding") != ENCODING:
            raise KnownSpaceError(f"{where}.encoding: must be {ENCODING!r}, got {data.get('encoding')!r}")
        try:
            origin = _finite3(data.get("origin"), f"{where}.origin")
            res = _check_resolution(data.get("resolution"))
        except KnownSpaceError as exc:
            msg = str(exc)
            raise KnownSpaceError(msg if msg.startswith(where) else f"{where}.{msg}") from None
        shape = data.get("shape")
        if (not isinstance(shape, list) or len(shape) != 3
                or not all(isinstance(n, int) and not isinstance(n, bool) and n > 0 for n in shape)):
            raise KnownSpaceError(f"{where}.shape: must be 3 whole numbers > 0, got {shape!r}")
        if math.prod(shape) > MAX_CELLS:
            raise KnownSpaceError(f"{where}.shape: {shape} is too many cells (limit {MAX_CELLS})")
        text = data.get("data")
        if not isinstance(text, str):
            raise KnownSpaceError(f"{where}.data: must be a base64 string")
        try:
            raw = zlib.decompressobj().decompress(base64.b64decode(text, validate=True), math.prod(shape) + 1)
        except (ValueError, zlib.error) as exc:
            raise KnownSpaceError(f"{where}.data: not zlib-compressed base64 ({exc})") from None
        if len(raw) != math.prod(shape):
            raise KnownSpaceError(f"{where}.data: holds {len(raw)} cells, the shape {shape} needs {math.prod(shape)}")
        arr = np.frombuffer(raw, dtype=np.int8).reshape(shape)
        if arr.min() < LOG_MIN or arr.max() > LOG_MAX:
            raise KnownSpaceError(f"{where}.data: log-odds outside {LOG_MIN}..{LOG_MAX}")
        return KnownSpace(origin, res, arr.copy())


def box_contains(obj: SceneObject, points: np.ndarray, grow: float | np.ndarray = 0.0) -> np.ndarray:
    """Which world points ``(N, 3)`` [m] lie inside ``obj``'s oriented box grown by ``grow`` [m]
    on every side (a scalar, or per axis ``(along the length, across, vertical)``)."""
    p = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    w, h, l = obj.size
    g = np.broadcast_to(np.asarray(grow, dtype=np.float64), (3,))
    c, s = math.cos(obj.yaw), math.sin(obj.yaw)
    d = p - np.asarray(obj.position)
    along = c * d[:, 0] + s * d[:, 1]
    across = -s * d[:, 0] + c * d[:, 1]
    return ((np.abs(along) <= l / 2 + g[0]) & (np.abs(across) <= w / 2 + g[1])
            & (np.abs(d[:, 2]) <= h / 2 + g[2]))


def unlabelled_mask(occupied: np.ndarray, centres_of: Any, resolution: float, objects: Sequence[SceneObject],
                    tolerance: float = EXPLAINED_TOLERANCE) -> np.ndarray:
    """Occupied cells no mapped object explains: ``bool`` like ``occupied``.

    A cell is explained when it overlaps some object's box grown by ``tolerance`` [m] (its centre
    lies within that box grown by another half cell; for a yawed box the half cell is taken along
    the box's axes: slightly generous). ``centres_of(idx (N, 3) int) -> (N, 3)`` world centres [m].
    Objects not in the world frame are ignored.
    """
    out = np.asarray(occupied, dtype=bool).copy()
    idx = np.argwhere(out)
    if len(idx) == 0 or not objects:
        return out
    pts = centres_of(idx)
    explained = np.zeros(len(idx), dtype=bool)
    grow = tolerance + resolution / 2.0
    for obj in objects:
        if obj.frame != "world":
            continue
        explained |= box_contains(obj, pts, grow)
    keep = idx[explained]
    out[keep[:, 0], keep[:, 1], keep[:, 2]] = False
    return out


def unlabelled_cells(space: KnownSpace, objects: Sequence[SceneObject],
                     tolerance: float = EXPLAINED_TOLERANCE) -> np.ndarray:
    """``bool [nx, ny, nz]``: the known space's occupied cells no mapped object explains
    (*unlabelled obstacles*: depth surfaces the detector did not name); count them with ``.sum()``."""
    return unlabelled_mask(space.state() == KnownState.OCCUPIED, space.centers, space.resolution, objects, tolerance)


__all__ = ["EXPLAINED_TOLERANCE", "KnownSpace", "KnownSpaceError", "KnownState", "LOG_HIT", "LOG_MAX", "LOG_MIN",
           "LOG_MISS", "box_contains", "unlabelled_cells", "unlabelled_mask"]
