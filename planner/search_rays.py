"""The compiled ray-casting kernel of the search's viewpoint gain (numba): :func:`planner.search_viewpoints.view_gain`.

World frame (z up) [m]. For each eye, each ray (azimuth ``a``, elevation ``e``) is sampled at the
distances ``r`` [m]; a ray ends at the first sample outside the grid or in a blocking cell; every
sample before that in an unknown cell adds ``zweight[k] * vol[e, s]`` (the volume the sample stands
for [m³], weighted by its layer) to the eye's azimuth ``a``. The same samples and the same sums as
the numpy expression it replaces (``view_gain``'s docstring), without its temporaries and with the
ray's early end.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit


@njit(cache=True)
def per_azimuth(eyes: np.ndarray, dirs: np.ndarray, r: np.ndarray, vol: np.ndarray, unknown: np.ndarray,
                blocked: np.ndarray, zweight: np.ndarray, lo: np.ndarray, res: float, nx: int, ny: int,
                nz: int) -> np.ndarray:  # pragma: no cover - compiled
    """``[N, A]``: each eye's weighted unknown volume [m³] per azimuth (see the module docstring).

    ``eyes [N, 3]``, ``dirs [A, E, 3]`` unit vectors, ``r [R]``, ``vol [E, R]``, ``unknown`` and
    ``blocked`` flat ``bool`` grids (C order over ``nx, ny, nz``), ``zweight [nz]``, ``lo [3]`` the
    grid's corner [m], ``res`` its cell [m]."""
    n_eye = eyes.shape[0]
    A, E = dirs.shape[0], dirs.shape[1]
    R = r.shape[0]
    out = np.zeros((n_eye, A))
    for n in range(n_eye):
        ex, ey, ez = eyes[n, 0], eyes[n, 1], eyes[n, 2]
        for a in range(A):
            acc = 0.0
            for e in range(E):
                dx, dy, dz = dirs[a, e, 0], dirs[a, e, 1], dirs[a, e, 2]
                for s in range(R):
                    i = int(math.floor((ex + dx * r[s] - lo[0]) / res))
                    j = int(math.floor((ey + dy * r[s] - lo[1]) / res))
                    k = int(math.floor((ez + dz * r[s] - lo[2]) / res))
                    if i < 0 or j < 0 or k < 0 or i >= nx or j >= ny or k >= nz:
                        break
                    f = (i * ny + j) * nz + k
                    if blocked[f]:
                        break
                    if unknown[f]:
                        acc += zweight[k] * vol[e, s]
            out[n, a] = acc
    return out


__all__ = ["per_azimuth"]
