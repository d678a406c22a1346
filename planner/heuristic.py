"""The layer-aware A* heuristic: a per-goal lower bound from 2D tables, admissible and consistent.

Grid ``cost[nx, ny, nz]`` as in :mod:`planner.astar` (per-cell cost [1/m], ``inf`` impassable,
``k = 0`` ground); an edge ``a -> b`` costs ``res * len * (c_a + c_b) / 2`` with
``len = sqrt(h² + v²)``, ``h`` its horizontal length (0, 1 or √2 cells) and ``v`` its vertical
one (0 or 1). Columns ``q = (i, j)``; ``zlo(q)`` is the lowest passable layer of column ``q``.

**Per goal** (``t = (tx, ty, zg)``), all on the ``nx x ny`` columns plus one pass over the grid:

- ``mc[k]``: smallest cost of layer ``k``; ``mf`` the smallest over the flight layers ``k >= 2``;
  ``S(k) = Σ_{j<k} P(j)`` with ``P(j) = res (mc[j] + mc[j+1]) / 2``: a lower bound of the cost of
  crossing layer boundaries ``0..k`` vertically (each such crossing is a move whose mean cost is
  at least ``(mc[j] + mc[j+1]) / 2`` and whose length is at least 1).
- ``π(q) = min(μ(q), (√2-1) λ(q), (√2-1) mf)`` with ``μ(q)`` the column's smallest cost and
  ``λ(q)`` a lower bound of the mean cost of any climbing move touching the column;
  ``D2(q)``: 8-connected 2D Dijkstra from the goal column with edge ``res h (π(q) + π(q')) / 2``.
- ``R(q)``: the bottleneck altitude, min over 2D column paths to the goal of the largest ``zlo``
  on the way (every 3D path is over a column path and is at altitude >= zlo in each column).
- For a few levels ``T`` (``T >= 2``, ``zlo(goal column) < T``): ``Ω_T = {q: R(q) < T}``
  (where the goal is reachable below ``T``) and ``dW_T(q)``, the 2D octile distance [cells] from
  ``q`` to the columns outside ``Ω_T`` next to it (where a path enters ``Ω_T`` from, at altitude
  ``>= T``); ``ρ_T(e)``, the least *rest* (cost minus the credits below) of an *entry move* from
  outside ``Ω_T`` at altitude ``e`` into it (one pass over those boundary columns),
  ``κ_T(H) = min_e [ρ_T(e) + 2 S(max(e, H))] - 2 S(H)`` and ``κ0_T = min_e ρ_T(e)``.

**The bound.** Split every edge's cost into a horizontal credit ``res h π̄`` and the rest. Over a
path the horizontal credits sum to at least ``D2`` and the rest to at least the vertical credits
(``P`` per layer crossed: for a vertical move the rest is ``res c̄ >= P``; for a climbing diagonal
``π̄ <= (√2-1) c̄``, so the rest is ``>= res c̄ (len - (√2-1) h) >= res c̄``). A path from
``a = (q, z)`` must reach altitude ``>= R(q)``, so

  ``hA(a) = D2(q) + 2 S(H) - S(z) - S(zg)``,  ``H = max(R(q), z, zg)``.

Every path from a cell outside ``Ω_T`` makes an entry move at some altitude ``e``, whose rest is
not part of any credit, after peaking at ``>= max(H, e)``: ``A_T = hA + κ_T(H)`` there. For a cell
in the air (``z >= 2``) outside ``Ω_T`` every path either (L) comes down to layer ``<= 1`` before it
enters ``Ω_T``, then climbs again to ``>= T``, or (F) stays in the air until it enters ``Ω_T``,
which is at least ``dW_T(q)`` cells away horizontally and ``|z - T|`` layers away vertically. In
the air ``c̄ >= mf`` and ``π̄ <= (√2-1) mf``, so a move's rest is at least
``res mf (len - (√2-1) h)``, which is ``>= res mf (a h + b v)`` for ``(a, b) = (2-√2, √3-√2)``
and ``((√3+√2-3)/(√2-1), 1-a)`` (checked on the five move shapes). Hence, with
``tg = max(T, zg)``,

  ``hL = D2 + S(z) - 2 S(1) + 2 S(tg) + κ_T(tg) - S(zg)``,
  ``X = D2 + res mf max_(a,b) (a dW_T + b |z - T|) + S(T) - S(zg) + κ0_T``,
  ``h_T = max(A_T, min(hL, X))`` there (``A_T`` on the floor layers), ``hA`` inside ``Ω_T``;
  ``h = max(octile bound, hA, max_T h_T)``.

*Admissible*: each term is a lower bound of every path (of its class; the classes cover all
paths). *Consistent*, i.e. ``h(a) <= e + h(b)`` for a move ``a = (q, z) -> b = (q', z')`` of cost
``e`` (horizontal ``h``, vertical ``v``):

- ``D2(q) - D2(q') <= res h π̄`` (triangle inequality of the 2D Dijkstra; 0 when ``h = 0``).
- ``hA``: ``R(q) <= max(zlo(q), R(q'))`` (minimax) and ``z >= zlo(q)`` give
  ``H(a) <= max(z, R(q'), zg)``. Flat move: ``H(a) <= H(b)``. Climb: ``H(a) <= H(b)`` and
  ``S(z + 1) - S(z) = P(z)``. Descent: ``H(b) >= z`` gives ``H(a) <= H(b)``, else ``H(b) = z - 1``
  and ``H(a) <= z``. In every case the ``S`` part drops by at most the move's vertical credit, so
  ``hA(a) - hA(b) <= e``.
- ``A_T``: ``ψ(H) = 2 S(H) + κ_T(H)`` is non-decreasing with ``ψ(H + 1) - ψ(H) <= 2 P(H)``, so
  the case analysis of ``hA`` holds for it; an entry move out of ``a`` has
  ``ψ(H(a)) <= its rest + 2 S(H(a))``, so ``A_T(a) <= hA(a) + rest <= e + hA(b)``.
- ``M = min(hL, X)`` inside ``{z >= 2, q ∉ Ω_T}`` (moves between air cells, ``c̄ >= mf``): ``hL``
  drops by at most ``res h π̄ + v P``, ``X`` by at most ``res h π̄ + res mf (a h + b v)``
  (``dW_T`` and ``|z - T|`` are 1-Lipschitz), both ``<= e``. Down to layer 1 outside ``Ω_T``:
  ``hL(a) - A_T(b) <= D2(q) - D2(q') + P(1) + ψ(tg) - ψ(H(b)) <= e`` as ``H(b) >= tg``. Into
  ``Ω_T``: ``q`` is next to it, ``dW_T(q) = 0``, and since ``b <= 0.65 < 1`` and
  ``P(j) >= res mf`` for ``j >= 2``, ``X(a) <= hA(a) + κ0_T <= hA(a) + rest <= e + hA(b)``.
- So each part of ``h_T(a)`` is at most ``e`` plus a part of ``h_T(b)``: ``h_T`` is consistent.
- The octile bound is consistent (:func:`planner.astar.astar`); a min or max of consistent
  functions is consistent.

``tests/planner/test_heuristic.py`` checks ``h(a) <= e + h(b)`` on every edge and ``h <=`` the true
cost-to-go on random and aerial-ground grids.

The search multiplies ``h`` by ``1 - 1e-9`` (still consistent) as a margin for rounding. The
per-cell formula is :func:`planner.astar_kernel.layer_h`, kept in the kernel's file: numba's
on-disk cache only watches a function's own file, so a kernel that inlined it from here would
keep a stale copy after an edit.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numba import njit

from planner.astar_kernel import _field

__all__ = ["LayerHeuristic", "build_layer_heuristic", "heuristic_field", "MAX_LEVELS"]

MAX_LEVELS = 3
_S2M1 = math.sqrt(2.0) - 1.0


@dataclass(frozen=True)
class LayerHeuristic:
    """Per-goal tables of the layer-aware heuristic (columns flattened as ``i * ny + j``).

    Attributes:
        d2: float64 ``[nx*ny]`` 2D lower bound of the horizontal credits to the goal [cost·m].
        rcol: int64 ``[nx*ny]`` bottleneck altitude ``R`` [layers]; ``nz`` when cut off in 2D.
        levels: int64 ``[L]`` the altitudes ``T`` with a distance table (``L <= MAX_LEVELS``).
        dw: float64 ``[L, nx*ny + nz + 1]``: per level, the octile distance [cells] from each
            column to where a path enters ``Ω_T``, then ``κ_T(H)`` for ``H < nz``, then ``κ0_T``
            [cost·m] (see the module).
        s: float64 ``[nz]`` cumulative vertical credits ``S(k)`` [cost·m].
        mfres: ``mf * resolution`` [cost·m per cell]; 0 when there is no flight layer.
        zg: The goal's layer.
    """

    d2: np.ndarray
    rcol: np.ndarray
    levels: np.ndarray
    dw: np.ndarray
    s: np.ndarray
    mfres: float
    zg: int


# --------------------------------------------------------------------------- per-grid scans


@njit(cache=True)
def _grid_scan(cost):
    """One pass over the grid: layer minima ``mc[nz]``, and per column the lowest passable
    layer ``zlo`` (``nz`` if none), the smallest cost ``mu``, the costs of layers 0, 1, 2 and the
    smallest cost of layers ``>= 3`` (``low[4, nx*ny]``)."""
    nx, ny, nz = cost.shape
    mc = np.full(nz, np.inf)
    zlo = np.full(nx * ny, nz, np.int64)
    mu = np.full(nx * ny, np.inf)
    low = np.full((4, nx * ny), np.inf)
    for x in range(nx):
        for y in range(ny):
            col = x * ny + y
            lo = nz
            m = np.inf
            m3 = np.inf
            for z in range(nz):
                c = cost[x, y, z]
                if c < mc[z]:
                    mc[z] = c
                if c < m:
                    m = c
                if lo == nz and c < np.inf:
                    lo = z
                if z >= 3 and c < m3:
                    m3 = c
            zlo[col] = lo
            mu[col] = m
            for z in range(min(nz, 3)):
                low[z, col] = cost[x, y, z]
            low[3, col] = m3
    return mc, zlo, mu, low


def _column_price(mc: np.ndarray, mu: np.ndarray, low: np.ndarray, mf: float) -> np.ndarray:
    """The 2D price ``π = min(μ, (√2-1) λ, (√2-1) mf)`` per column, where
    ``λ = min_k (c_k + adj_k) / 2`` over the column's cells, ``adj_k`` the cheapest layer next to
    ``k``; for ``k >= 3`` ``c_k >= low[3]`` and ``adj_k >= min(mc[2:])``, a lower bound of ``λ``."""
    nz = mc.size
    inf = np.inf
    adj = [min(mc[k - 1] if k > 0 else inf, mc[k + 1] if k + 1 < nz else inf) for k in range(min(nz, 3))]
    lam = np.full(mu.shape, inf)
    with np.errstate(invalid="ignore"):
        for k in range(min(nz, 3)):
            lam = np.minimum(lam, 0.5 * (low[k] + adj[k]))
        if nz > 3:
            lam = np.minimum(lam, 0.5 * (low[3] + float(mc[2:].min())))
    price = np.minimum(mu, _S2M1 * lam)
    if math.isfinite(mf):
        price = np.minimum(price, _S2M1 * mf)
    price[~np.isfinite(mu)] = inf
    return np.ascontiguousarray(price)


# --------------------------------------------------------------------------- 2D searches


@njit(cache=True, inline="always")
def _push(hk, hv, n, key, val):
    i = n
    while i > 0:
        p = (i - 1) >> 1
        if hk[p] <= key:
            break
        hk[i] = hk[p]
        hv[i] = hv[p]
        i = p
    hk[i] = key
    hv[i] = val


@njit(cache=True, inline="always")
def _pop(hk, hv, n):
    """Remove the root of a heap of size ``n`` (the caller reads it first)."""
    n -= 1
    key = hk[n]
    val = hv[n]
    i = 0
    while True:
        c = 2 * i + 1
        if c >= n:
            break
        if c + 1 < n and hk[c + 1] < hk[c]:
            c += 1
        if hk[c] < key:
            hk[i] = hk[c]
            hv[i] = hv[c]
            i = c
        else:
            break
    if n > 0:
        hk[i] = key
        hv[i] = val


@njit(cache=True)
def _dijkstra2d(price, nx, ny, g, res):
    """8-connected 2D Dijkstra from column ``g``: edge ``res * h * (π(q) + π(q')) / 2``."""
    n_cols = nx * ny
    d = np.full(n_cols, np.inf)
    done = np.zeros(n_cols, np.bool_)
    cap = 8 * n_cols + 1
    hk = np.empty(cap)
    hv = np.empty(cap, np.int64)
    d[g] = 0.0
    hk[0] = 0.0
    hv[0] = g
    n = 1
    sq2 = math.sqrt(2.0)
    while n > 0:
        du = hk[0]
        u = hv[0]
        _pop(hk, hv, n)
        n -= 1
        if done[u]:
            continue
        done[u] = True
        ux = u // ny
        uy = u % ny
        pu = price[u]
        for dx in range(-1, 2):
            vx = ux + dx
            if vx < 0 or vx >= nx:
                continue
            for dy in range(-1, 2):
                vy = uy + dy
                if (dx == 0 and dy == 0) or vy < 0 or vy >= ny:
                    continue
                v = vx * ny + vy
                pv = price[v]
                if pv == np.inf or done[v]:
                    continue
                step = res if (dx == 0 or dy == 0) else res * sq2
                nd = du + step * 0.5 * (pu + pv)
                if nd < d[v]:
                    d[v] = nd
                    _push(hk, hv, n, nd, v)
                    n += 1
    return d


@njit(cache=True)
def _bottleneck(zlo, nx, ny, nz, g):
    """Minimax over 8-connected column paths from ``g`` of ``zlo`` (``nz`` when cut off):
    a bucket queue, since the values are layer indices."""
    n_cols = nx * ny
    r = np.full(n_cols, nz, np.int64)
    if zlo[g] >= nz:
        return r
    # buckets as linked stacks
    head = np.full(nz, -1, np.int64)
    nxt = np.empty(9 * n_cols + 1, np.int64)
    item = np.empty(9 * n_cols + 1, np.int64)
    m = 0
    r[g] = zlo[g]
    item[m] = g
    nxt[m] = head[r[g]]
    head[r[g]] = m
    m += 1
    done = np.zeros(n_cols, np.bool_)
    for lev in range(nz):
        while head[lev] >= 0:
            e = head[lev]
            head[lev] = nxt[e]
            u = item[e]
            if done[u] or r[u] != lev:
                continue
            done[u] = True
            ux = u // ny
            uy = u % ny
            for dx in range(-1, 2):
                vx = ux + dx
                if vx < 0 or vx >= nx:
                    continue
                for dy in range(-1, 2):
                    vy = uy + dy
                    if (dx == 0 and dy == 0) or vy < 0 or vy >= ny:
                        continue
                    v = vx * ny + vy
                    zv = zlo[v]
                    if zv >= nz or done[v]:
                        continue
                    nr = lev if zv < lev else zv
                    if nr < r[v]:
                        r[v] = nr
                        item[m] = v
                        nxt[m] = head[nr]
                        head[nr] = m
                        m += 1
    return r


@njit(cache=True)
def _entry_distance(rcol, nx, ny, t):
    """Octile distance [cells] from each column to the nearest column with ``R >= t`` that
    touches one with ``R < t`` (two-pass chamfer with weights 1 and √2, exact in the plane)."""
    sq2 = math.sqrt(2.0)
    d = np.full((nx, ny), np.inf)
    for x in range(nx):
        for y in range(ny):
            if rcol[x * ny + y] < t:
                continue
            edge = False
            for dx in range(-1, 2):
                for dy in range(-1, 2):
                    vx = x + dx
                    vy = y + dy
                    if 0 <= vx < nx and 0 <= vy < ny and rcol[vx * ny + vy] < t:
                        edge = True
            if edge:
                d[x, y] = 0.0
    for x in range(nx):
        for y in range(ny):
            v = d[x, y]
            if x > 0:
                v = min(v, d[x - 1, y] + 1.0)
                if y > 0:
                    v = min(v, d[x - 1, y - 1] + sq2)
                if y + 1 < ny:
                    v = min(v, d[x - 1, y + 1] + sq2)
            if y > 0:
                v = min(v, d[x, y - 1] + 1.0)
            d[x, y] = v
    for x in range(nx - 1, -1, -1):
        for y in range(ny - 1, -1, -1):
            v = d[x, y]
            if x + 1 < nx:
                v = min(v, d[x + 1, y] + 1.0)
                if y > 0:
                    v = min(v, d[x + 1, y - 1] + sq2)
                if y + 1 < ny:
                    v = min(v, d[x + 1, y + 1] + sq2)
            if y + 1 < ny:
                v = min(v, d[x, y + 1] + 1.0)
            d[x, y] = v
    return d.reshape(-1)


@njit(cache=True)
def _entry_rest(cost, rcol, price, t, s, res):
    """``ρ[e]``: the least *rest* (cost minus its horizontal credit ``res h π̄`` and its vertical
    credit ``P``) of a move from a column with ``R >= t`` at altitude ``e`` into one with ``R < t``
    (every path from outside ``Ω_t`` to the goal makes such an entry move once at least)."""
    nx, ny, nz = cost.shape
    rho = np.full(nz, np.inf)
    sq2 = math.sqrt(2.0)
    for x in range(nx):
        for y in range(ny):
            col = x * ny + y
            if rcol[col] < t:
                continue
            for dx in range(-1, 2):
                x2 = x + dx
                if x2 < 0 or x2 >= nx:
                    continue
                for dy in range(-1, 2):
                    y2 = y + dy
                    if (dx == 0 and dy == 0) or y2 < 0 or y2 >= ny:
                        continue
                    col2 = x2 * ny + y2
                    if rcol[col2] >= t:
                        continue
                    hz = 1.0 if (dx == 0 or dy == 0) else sq2
                    hcred = res * hz * 0.5 * (price[col] + price[col2])
                    for e in range(nz):
                        cu = cost[x, y, e]
                        if cu == np.inf:
                            continue
                        for de in range(-1, 2):
                            e2 = e + de
                            if e2 < 0 or e2 >= nz:
                                continue
                            cv = cost[x2, y2, e2]
                            if cv == np.inf:
                                continue
                            ln = math.sqrt(hz * hz + de * de)
                            rest = res * ln * 0.5 * (cu + cv) - hcred
                            if de != 0:
                                j = e if e < e2 else e2
                                rest -= s[j + 1] - s[j]
                            if rest < 0.0:
                                rest = 0.0
                            if rest < rho[e]:
                                rho[e] = rest
    return rho


def _entry_terms(rho: np.ndarray, s: np.ndarray) -> tuple[np.ndarray, float]:
    """``κ(H) = min_e [ρ(e) + 2 S(max(e, H))] - 2 S(H)`` for ``H < nz`` and ``κ0 = min ρ``: what
    the entry move and the climb to its altitude add to the vertical credits ``2 S(H)``."""
    nz = s.size
    e = np.arange(nz)
    kap = np.empty(nz)
    for hh in range(nz):
        kap[hh] = float(np.min(rho + 2.0 * s[np.maximum(e, hh)])) - 2.0 * s[hh]
    kap = np.where(np.isfinite(kap), np.maximum(kap, 0.0), np.inf)
    return kap, float(rho.min())


# --------------------------------------------------------------------------- build / evaluate


def _pick_levels(rcol: np.ndarray, zlo: np.ndarray, nz: int, zgc: int) -> np.ndarray:
    """The (at most ``MAX_LEVELS``) bottleneck altitudes that constrain the most columns:
    ``R(q) > zlo(q)`` (the column itself is not the bottleneck), ``R >= 2``, ``R > zlo(goal col)``."""
    ok = (rcol < nz) & (rcol > zlo) & (rcol >= 2) & (rcol > zgc)
    if not ok.any():
        return np.zeros(0, np.int64)
    counts = np.bincount(rcol[ok], minlength=nz)
    order = np.argsort(-counts, kind="stable")
    lv = [int(t) for t in order[:MAX_LEVELS] if counts[t] > 0]
    return np.array(sorted(lv), dtype=np.int64)


def build_layer_heuristic(cost: np.ndarray, goal: tuple[int, int, int], resolution: float) -> LayerHeuristic:
    """Tables of the layer-aware heuristic for ``goal`` on ``cost`` (C-contiguous float64,
    validated by the caller): two passes over the grid, then O(nx * ny) work per level."""
    nx, ny, nz = cost.shape
    res = float(resolution)
    mc, zlo, mu, low = _grid_scan(cost)
    fl = mc[2:]
    fl = fl[np.isfinite(fl)]
    mf = float(fl.min()) if fl.size else math.inf
    price = _column_price(mc, mu, low, mf)
    g = goal[0] * ny + goal[1]
    d2 = _dijkstra2d(price, nx, ny, g, res)
    rcol = _bottleneck(zlo, nx, ny, nz, g)
    pv = np.where(np.isfinite(mc[:-1]) & np.isfinite(mc[1:]), 0.5 * res * (mc[:-1] + mc[1:]), 0.0)
    s = np.concatenate(([0.0], np.cumsum(pv)))
    levels = _pick_levels(rcol, zlo, nz, int(zlo[g])) if math.isfinite(mf) else np.zeros(0, np.int64)
    ncol = nx * ny
    dw = np.empty((len(levels), ncol + nz + 1))
    for i, t in enumerate(levels):
        dw[i, :ncol] = _entry_distance(rcol, nx, ny, int(t))
        kap, k0 = _entry_terms(_entry_rest(cost, rcol, price, int(t), s, res), s)
        dw[i, ncol:ncol + nz] = kap
        dw[i, ncol + nz] = k0
    return LayerHeuristic(d2, rcol, levels, dw, s, mf * res if math.isfinite(mf) else 0.0, int(goal[2]))




def heuristic_field(cost: np.ndarray, goal: tuple[int, int, int], resolution: float,
                    min_cost: float | None = None) -> np.ndarray:
    """The full heuristic ``h`` [cost·m] (octile bound included, before the 1e-9 margin) of
    every cell for ``goal``: ``[nx, ny, nz]``; for tests and plots (the search evaluates it
    lazily per cell)."""
    arr = np.ascontiguousarray(cost, dtype=np.float64)
    lh = build_layer_heuristic(arr, goal, resolution)
    mc = float(arr.min()) if min_cost is None else float(min_cost)
    return _field(arr.shape[0], arr.shape[1], arr.shape[2], goal[0], goal[1], goal[2], mc * resolution,
                  lh.d2, lh.rcol, lh.levels, lh.dw, lh.s, lh.mfres, lh.zg)


