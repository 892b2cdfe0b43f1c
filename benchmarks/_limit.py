"""The true speed limit for the Jansen leg: its exact closed form written for that one topology.

A plain Numba kernel, as a compiler of equation-based models would generate it for this model once:
the ten link lengths and the crank radius as scalars, the five dyads as five circle–circle
intersections in construction order, the branch of each dyad fixed (the nominal's), the crank's
cos/sin computed once per step count, a ``prange`` over the variants, the foot only. Nothing is
checked and nothing but the foot is stored. explorer's kernels are measured against this in the
same run (``bench_kernels.py``, ``bench_peers.py``); it is not part of explorer.
"""

import math

import numpy as np
from numba import njit, prange

#: Link order of the built-in jansen.toml: 1-3, 3-4, 2-3, 2-4, 4-5, 2-6, 1-6, 5-6, 5-7, 6-7.
PIVOT = (-38.0, -7.8)


@njit(inline="always")
def _cc(ax, ay, bx, by, ra, rb, side):
    """The point at ra from a and rb from b on ``side`` (±1) of a→b; NaN where the circles do not meet."""
    gx = bx - ax
    gy = by - ay
    d2 = gx * gx + gy * gy
    x = 0.5 * (ra * ra - rb * rb + d2) / d2
    h = ra * ra / d2 - x * x
    if h < 0.0:
        return math.nan, math.nan
    y = side * math.sqrt(h)
    return ax + x * gx - y * gy, ay + x * gy + y * gx


@njit(parallel=True, cache=True)
def jansen_foot_limit(L, crank, cos_t, sin_t, out):
    """out[i, k] = foot (vertex 7) of variant i at θ_k. L (N, 10) in jansen.toml's link order,
    crank (N,), cos_t/sin_t (S,), out (N, S, 2). Branches: the nominal design's (the side of its
    parents each dyad's vertex takes at θ = 0: 3 −, 4 −, 6 +, 5 −, 7 −)."""
    px, py = PIVOT
    for i in prange(L.shape[0]):
        l13 = L[i, 0]
        l34 = L[i, 1]
        l23 = L[i, 2]
        l24 = L[i, 3]
        l45 = L[i, 4]
        l26 = L[i, 5]
        l16 = L[i, 6]
        l56 = L[i, 7]
        l57 = L[i, 8]
        l67 = L[i, 9]
        r = crank[i]
        for k in range(cos_t.shape[0]):
            x1 = r * cos_t[k]
            y1 = r * sin_t[k]
            x3, y3 = _cc(x1, y1, px, py, l13, l23, -1.0)
            x4, y4 = _cc(x3, y3, px, py, l34, l24, -1.0)
            x6, y6 = _cc(x1, y1, px, py, l16, l26, 1.0)
            x5, y5 = _cc(x4, y4, x6, y6, l45, l56, -1.0)
            x7, y7 = _cc(x5, y5, x6, y6, l57, l67, -1.0)
            out[i, k, 0] = x7
            out[i, k, 1] = y7


def foot_limit(lengths, crank, steps):
    """Foot paths (N, steps, 2) of N Jansen variants by the specialised closed form."""
    theta = 2.0 * np.pi * np.arange(steps) / steps
    out = np.empty((lengths.shape[0], steps, 2))
    jansen_foot_limit(np.ascontiguousarray(lengths), np.ascontiguousarray(crank), np.cos(theta), np.sin(theta), out)
    return out
