"""The compiled kernel of the Aerial-Ground A* (numba): move tables, indexed binary heap, the
search loop and the path trace. The Python API and its documentation are in :mod:`planner.astar`;
the layer-aware heuristic in :mod:`planner.heuristic`.

Cells are flat C-order indices ``(i * ny + j) * nz + k`` of a ``cost[nx, ny, nz]`` grid.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass
from typing import Sequence

import numpy as np
from numba import njit

_SQ2 = 2.0 ** 0.5
_SQ3 = 3.0 ** 0.5
_S2M1 = _SQ2 - 1.0
# The layer-aware heuristic (planner/heuristic.py): (a, b) pairs with a h + b v <= len - (√2-1) h
# for all five move shapes (h, v), shrunk by 1e-9.
_A1 = (2.0 - _SQ2) * (1 - 1e-9)
_B1 = (_SQ3 - _SQ2) * (1 - 1e-9)
_A2 = (_SQ3 + _SQ2 - 3.0) / _S2M1 * (1 - 1e-9)
_B2 = (1.0 - (_SQ3 + _SQ2 - 3.0) / _S2M1) * (1 - 1e-9)


# --------------------------------------------------------------------------- moves


def _moves() -> list[tuple[int, int, int]]:
    """The 26 neighbour offsets, in a fixed order."""
    return [d for d in itertools.product((-1, 0, 1), repeat=3) if d != (0, 0, 0)]


def _swept(d: tuple[int, int, int]) -> list[tuple[int, int, int]]:
    """Axis-aligned cells a diagonal move ``d`` sweeps past: every non-empty proper subset
    of its non-zero components (2 cells for a planar diagonal, 6 for a 3D diagonal)."""
    axes = [a for a in range(3) if d[a] != 0]
    out = []
    for r in range(1, len(axes)):
        for sub in itertools.combinations(axes, r):
            out.append(tuple(d[a] if a in sub else 0 for a in range(3)))
    return out


@dataclass(frozen=True)
class _MoveTable:
    """Per-shape move tables for the kernel."""

    flat: np.ndarray  # int64[26] flat index offsets
    dx: np.ndarray  # int64[26]
    dy: np.ndarray
    dz: np.ndarray
    swept: np.ndarray  # int64[26, 6] flat offsets of swept cells
    n_swept: np.ndarray  # int64[26]


def _move_table(shape: tuple[int, int, int]) -> _MoveTable:
    _, ny, nz = shape
    moves = _moves()
    d = np.array(moves, dtype=np.int64)
    flat = d[:, 0] * (ny * nz) + d[:, 1] * nz + d[:, 2]
    swept = np.zeros((26, 6), dtype=np.int64)
    n_swept = np.zeros(26, dtype=np.int64)
    for i, m in enumerate(moves):
        cells = _swept(m)
        n_swept[i] = len(cells)
        for j, c in enumerate(cells):
            swept[i, j] = c[0] * (ny * nz) + c[1] * nz + c[2]
    return _MoveTable(flat, d[:, 0].copy(), d[:, 1].copy(), d[:, 2].copy(), swept, n_swept)


def octile_distance(a: Sequence[int], b: Sequence[int]) -> float:
    """3D octile distance [cells]: the shortest 26-connected lattice path length between two
    cells when a move of ``n`` non-zero components has length ``sqrt(n)``."""
    d = sorted((abs(int(a[0]) - int(b[0])), abs(int(a[1]) - int(b[1])), abs(int(a[2]) - int(b[2]))))
    c, m, x = d
    return x + (_SQ2 - 1.0) * m + (_SQ3 - _SQ2) * c


# --------------------------------------------------------------------------- kernel


@njit(cache=True, inline="always")
def _sift_up(hk, hi, hpos, pos, f, g, v):
    """Move the record ``(f, g, v)`` from slot ``pos`` towards the root; returns its final slot.
    Order: smaller f first; on equal f, larger g first (deeper nodes, fewer expansions)."""
    while pos > 0:
        par = (pos - 1) >> 1
        pf = hk[par, 0]
        pg = hk[par, 1]
        if pf < f or (pf == f and pg >= g):
            break
        hk[pos, 0] = pf
        hk[pos, 1] = pg
        w = hi[par]
        hi[pos] = w
        hpos[w] = pos
        pos = par
    hk[pos, 0] = f
    hk[pos, 1] = g
    hi[pos] = v
    hpos[v] = pos
    return pos


@njit(cache=True, inline="always")
def _sift_down(hk, hi, hpos, pos, n, f, g, v):
    """Move the record ``(f, g, v)`` from slot ``pos`` towards the leaves of a heap of size ``n``."""
    while True:
        c = 2 * pos + 1
        if c >= n:
            break
        cf = hk[c, 0]
        cg = hk[c, 1]
        r = c + 1
        if r < n:
            rf = hk[r, 0]
            rg = hk[r, 1]
            if rf < cf or (rf == cf and rg > cg):
                c = r
                cf = rf
                cg = rg
        if cf < f or (cf == f and cg > g):
            hk[pos, 0] = cf
            hk[pos, 1] = cg
            w = hi[c]
            hi[pos] = w
            hpos[w] = pos
            pos = c
        else:
            break
    hk[pos, 0] = f
    hk[pos, 1] = g
    hi[pos] = v
    hpos[v] = pos


@njit(cache=True, inline="always")
def _octile(ax, ay, az, bx, by, bz):
    """3D octile distance [cells] (see :func:`octile_distance`)."""
    a = abs(ax - bx)
    b = abs(ay - by)
    c = abs(az - bz)
    if a < b:
        a, b = b, a
    if b < c:
        b, c = c, b
    if a < b:
        a, b = b, a
    return a + 0.41421356237309515 * b + 0.31783724519578205 * c


@njit(cache=True, inline="always")
def layer_h(vx, vy, vz, ny, d2, rcol, levels, dw, s, mfres, zg):
    """The layer-aware bound ``max(hA, max_T h_T)`` of cell ``(vx, vy, vz)`` (see :mod:`planner.heuristic`).
    ``dw[i]`` holds level ``i``'s entry distances (``nx * ny``), then ``κ_T(H)`` (``nz``), then
    ``κ0_T``."""
    col = vx * ny + vy
    d = d2[col]
    if d == np.inf:
        return np.inf
    r = rcol[col]
    hh = r
    if vz > hh:
        hh = vz
    if zg > hh:
        hh = zg
    sz = s[vz]
    szg = s[zg]
    base = d + 2.0 * s[hh] - sz - szg
    best = base
    nz = s.size
    ncol = dw.shape[1] - nz - 1
    for i in range(levels.size):
        t = levels[i]
        if r < t:
            continue
        ha = base + dw[i, ncol + hh]
        v = ha
        if vz >= 2:
            tg = t if t > zg else zg
            hl = d + sz - 2.0 * s[1] + 2.0 * s[tg] + dw[i, ncol + tg] - szg
            w = dw[i, col]
            dv = vz - t if vz > t else t - vz
            c1 = _A1 * w + _B1 * dv
            c2 = _A2 * w + _B2 * dv
            if c2 > c1:
                c1 = c2
            hf = d + mfres * c1 + s[t] - szg + dw[i, ncol + nz]
            m = hl if hl < hf else hf
            if m > v:
                v = m
        if v > best:
            best = v
    return best


@njit(cache=True, inline="always")
def _h(vx, vy, vz, tx, ty, tz, ny, hscale, lay, lw, d2, rcol, levels, dw, s, mfres, zg):
    """Heuristic of a cell: the octile bound, and with ``lay`` the layer-aware one (times
    ``lw``, the weight with the rounding margin) if larger."""
    ho = hscale * _octile(vx, vy, vz, tx, ty, tz)
    if lay:
        hl = lw * layer_h(vx, vy, vz, ny, d2, rcol, levels, dw, s, mfres, zg)
        if hl > ho:
            return hl
    return ho


@njit(cache=True, inline="always")
def _hc(vx, vy, vz, tx, ty, tz, ny, hscale, lw, d2, rcol, levels, dw, s, mfres, zg):
    """:func:`_h` chosen by type: the octile bound when ``d2`` is ``None`` (numba compiles that case
    without the layer-aware code), else the larger of the two."""
    if d2 is None:
        return hscale * _octile(vx, vy, vz, tx, ty, tz)
    return _h(vx, vy, vz, tx, ty, tz, ny, hscale, True, lw, d2, rcol, levels, dw, s, mfres, zg)


@njit(cache=True)
def _core(cost, nx, ny, nz, t, elen, hscale, no_cc, gated, no_land,
          offs, ddx, ddy, ddz, swept, n_swept,
          gbuf, state, parent, hpos, open_tag, hk, hi, n, expanded,
          budget, lw, d2, rcol, levels, dw, s, mfres, zg):
    """Run A* until the goal is closed (status 1), the heap empties (0), it might overflow during the
    next expansion (2, resumable: grow the heap and call again) or, with the octile heuristic
    (``d2 is None``), ``budget`` expansions are reached (3, resumable: switch to the layer-aware
    heuristic). ``state[i] == open_tag`` marks a cell whose g is valid in this search (and, until it is
    closed, whose heap slot is ``hpos[i]``), ``open_tag + 1`` a closed one. With ``gated``, a move from
    the air (``k >= 1``) down to a ground cell ``(i, j, 0)`` with ``no_land[i * ny + j]`` set is not
    taken (a landing there is refused; walking through the cell is not). Returns ``(status, heap size,
    expanded, cost)``. One loop for both heuristics: numba compiles it once with ``d2`` an array
    (layer-aware) and once with ``None`` (octile), where the layer-aware code and the budget's
    counterpart are left out, so the walk cases' hot loop stays as small as a loop of its own."""
    closed_tag = open_tag + 1
    nyz = ny * nz
    tx = t // nyz
    ty = (t // nz) % ny
    tz = t % nz
    cap = hi.size
    while n > 0:
        if n + 26 > cap:
            return 2, n, expanded, 0.0
        if d2 is None:
            if expanded >= budget:
                return 3, n, expanded, 0.0
        g0 = hk[0, 1]
        u = hi[0]
        n -= 1
        if n > 0:
            _sift_down(hk, hi, hpos, 0, n, hk[n, 0], hk[n, 1], hi[n])
        state[u] = closed_tag
        expanded += 1
        if u == t:
            return 1, n, expanded, g0
        ux = u // nyz
        uy = (u // nz) % ny
        uz = u % nz
        cu = cost[u]
        interior = 0 < ux < nx - 1 and 0 < uy < ny - 1 and 0 < uz < nz - 1
        for d in range(26):
            vx = ux + ddx[d]
            vy = uy + ddy[d]
            vz = uz + ddz[d]
            if not interior:
                if vx < 0 or vx >= nx or vy < 0 or vy >= ny or vz < 0 or vz >= nz:
                    continue
            v = u + offs[d]
            cv = cost[v]
            if cv == np.inf:
                continue
            if gated:
                if vz == 0 and uz > 0 and no_land[vx * ny + vy]:
                    continue
            sv = state[v]
            if sv == closed_tag:
                continue
            if no_cc:
                blocked = False
                for j in range(n_swept[d]):
                    if cost[u + swept[d, j]] == np.inf:
                        blocked = True
                        break
                if blocked:
                    continue
            ng = g0 + elen[d] * (cu + cv)
            if sv == open_tag:
                if ng >= gbuf[v]:
                    continue
                gbuf[v] = ng
                parent[v] = d
                p = hpos[v]
                nf = ng + _hc(vx, vy, vz, tx, ty, tz, ny, hscale, lw, d2, rcol, levels, dw, s, mfres, zg)
                if _sift_up(hk, hi, hpos, p, nf, ng, v) == p:
                    _sift_down(hk, hi, hpos, p, n, nf, ng, v)
            elif ng != np.inf:
                gbuf[v] = ng
                state[v] = open_tag
                parent[v] = d
                nf = ng + _hc(vx, vy, vz, tx, ty, tz, ny, hscale, lw, d2, rcol, levels, dw, s, mfres, zg)
                _sift_up(hk, hi, hpos, n, nf, ng, v)
                n += 1
    return 0, n, expanded, np.inf


@njit(cache=True)
def _search(cost, nx, ny, nz, s0, t, step, hscale, no_cc, gated, no_land,
            offs, ddx, ddy, ddz, swept, n_swept,
            gbuf, state, parent, hpos, gen, hk, hi, n, expanded,
            lay, lw, d2, rcol, levels, dw, s, mfres, zg, budget):
    """A* from flat index ``s0`` to ``t``; returns ``(status, cost, expanded, n, hk, hi)`` (status
    as :func:`_core`, never 2) where the heap arrays may have been replaced by larger ones. ``gated`` and
    ``no_land`` (``uint8 [nx * ny]``; any one-element array when not gated): the landings refused.
    ``n == 0`` starts a new search, otherwise the heap ``hk[:n], hi[:n]`` is resumed. ``step`` is
    the cell size [m], ``hscale = weight * min_cost * step``. Keeping the growth out of the hot
    loop lets numba treat the heap arrays there as loop-invariant."""
    open_tag = 2 * gen
    elen = np.empty(26)
    for d in range(26):
        ex = step * ddx[d]
        ey = step * ddy[d]
        ez = step * ddz[d]
        elen[d] = np.sqrt(ex * ex + ey * ey + ez * ez) * 0.5
    nyz = ny * nz
    tx = t // nyz
    ty = (t // nz) % ny
    tz = t % nz
    if n == 0:
        gbuf[s0] = 0.0
        state[s0] = open_tag
        parent[s0] = -1
        h0 = _h(s0 // nyz, (s0 // nz) % ny, s0 % nz, tx, ty, tz, ny, hscale, lay, lw, d2, rcol, levels, dw, s,
                mfres, zg)
        _sift_up(hk, hi, hpos, 0, h0, 0.0, s0)
        n = 1
    while True:
        if lay:
            status, n, expanded, c = _core(cost, nx, ny, nz, t, elen, hscale, no_cc, gated, no_land, offs, ddx, ddy, ddz, swept,
                                           n_swept, gbuf, state, parent, hpos, open_tag, hk, hi, n, expanded,
                                           budget, lw, d2, rcol, levels, dw, s, mfres, zg)
        else:
            status, n, expanded, c = _core(cost, nx, ny, nz, t, elen, hscale, no_cc, gated, no_land, offs, ddx, ddy, ddz, swept,
                                           n_swept, gbuf, state, parent, hpos, open_tag, hk, hi, n, expanded,
                                           budget, lw, None, rcol, levels, dw, s, mfres, zg)
        if status != 2:
            return status, c, expanded, n, hk, hi
        cap = 2 * hi.size
        nk = np.empty((cap, 2))
        ni = np.empty(cap, hi.dtype)
        nk[:n] = hk[:n]
        ni[:n] = hi[:n]
        hk, hi = nk, ni


@njit(cache=True)
def _rekey(hk, hi, hpos, n, nx, ny, nz, t, hscale, lw, d2, rcol, levels, dw, s, mfres, zg):
    """Re-key the open list ``hk[:n], hi[:n]`` with the layer-aware heuristic (rebuilt heap).
    Valid mid-search: every closed cell already has its optimal g, and the new heuristic is
    consistent, so A* continues to return an optimal path."""
    nyz = ny * nz
    tx = t // nyz
    ty = (t // nz) % ny
    tz = t % nz
    gs = hk[:n, 1].copy()
    vs = hi[:n].copy()
    for i in range(n):
        v = vs[i]
        f = gs[i] + _h(v // nyz, (v // nz) % ny, v % nz, tx, ty, tz, ny, hscale, True, lw, d2, rcol, levels,
                       dw, s, mfres, zg)
        _sift_up(hk, hi, hpos, i, f, gs[i], v)


@njit(cache=True)
def _trace(parent, s, t, ny, nz, offs, ddx, ddy, ddz):
    """Cell path ``[K, 3]`` from ``s`` to ``t`` following the parent move indices."""
    k = 1
    v = t
    while v != s:
        v -= offs[parent[v]]
        k += 1
    path = np.empty((k, 3), np.int64)
    nyz = ny * nz
    v = t
    x = t // nyz
    y = (t // nz) % ny
    z = t % nz
    for i in range(k - 1, -1, -1):
        path[i, 0] = x
        path[i, 1] = y
        path[i, 2] = z
        if i > 0:
            d = parent[v]
            v -= offs[d]
            x -= ddx[d]
            y -= ddy[d]
            z -= ddz[d]
    return path


@njit(cache=True)
def _field(nx, ny, nz, tx, ty, tz, hscale, d2, rcol, levels, dw, s, mfres, zg):
    out = np.empty((nx, ny, nz))
    for x in range(nx):
        for y in range(ny):
            for z in range(nz):
                a = abs(x - tx)
                b = abs(y - ty)
                c = abs(z - tz)
                if a < b:
                    a, b = b, a
                if b < c:
                    b, c = c, b
                if a < b:
                    a, b = b, a
                ho = hscale * (a + 0.41421356237309515 * b + 0.31783724519578205 * c)
                hl = layer_h(x, y, z, ny, d2, rcol, levels, dw, s, mfres, zg)
                out[x, y, z] = ho if ho > hl else hl
    return out
