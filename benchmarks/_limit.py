"""The speed limit for the Jansen leg: its exact closed form written for that one topology, vectorised.

What a compiler of equation-based models would generate for this model once, written so that the
machine runs it at its own pace: the ten squared link lengths and the crank radius as scalars per
design, the five dyads as five circle–circle intersections in construction order with the branch of
each dyad a constant (the nominal's), the crank's cos/sin computed once per step count, a ``prange``
over the designs and, inside, one loop over the steps that is **branch-free** (a circle pair that
does not meet gives NaN through the square root of a negative number, no test; Numba's "numpy"
error model, so a division carries no zero check) with x and y written to **two arrays**
(``out_x``, ``out_y``), so LLVM vectorises the step loop: 8 steps per ``vdivpd``/``vsqrtpd`` on
AVX-512 (:func:`vector_width` reads the instructions from the compiled code). Nothing is checked and
nothing but the foot is stored. explorer's kernels are measured against it in the same run
(``bench_kernels.py``, ``bench_peers.py``, ``bench_vector.py``); it is not part of explorer.

How far the limit itself is from the CPU: each configuration costs :data:`DIVS` divisions and
:data:`SQRTS` square roots, which share the divider. :func:`probe` measures
this CPU's vectorised divisions and square roots per second (same threads, data in L1) and
:func:`ceiling` turns them into configurations per second; ``bench_kernels.py`` prints the limit's
share of that ceiling.

:func:`jansen_foot_scalar` keeps the earlier form of this baseline (the same arithmetic, one
configuration at a time: a branch per dyad and (x, y) pairs interleaved), which LLVM leaves scalar
(``vdivsd``/``vsqrtsd``); it is timed beside the limit only to show what vectorising buys.
"""

import math
import re
import time

import numpy as np
from numba import njit, prange

#: The fixed pivot (vertex 2) of the built-in jansen.toml; link order 1-3, 3-4, 2-3, 2-4, 4-5, 2-6,
#: 1-6, 5-6, 5-7, 6-7; the crank turns about the origin.
PIVOT = (-38.0, -7.8)
#: Divisions and square roots per configuration in the limit: one of each per dyad, less the one
#: division LLVM shares between dyads 3 and 6 (both are placed from the crank tip and vertex 2, so
#: their parents' squared distance is the same); :func:`vector_width` counts them in the machine code.
DIVS = 4
SQRTS = 5


@njit(inline="always", error_model="numpy")
def _cc2(ax, ay, bx, by, ra2, rb2, side):
    """The point at √ra2 from a and √rb2 from b on ``side`` (±1) of a→b, branch-free: NaN where the
    circles do not meet (the square root of a negative number), one division and one square root."""
    gx = bx - ax
    gy = by - ay
    d2 = gx * gx + gy * gy
    inv = 1.0 / d2
    x = 0.5 * (ra2 - rb2 + d2) * inv
    y = side * np.sqrt(ra2 * inv - x * x)
    return ax + x * gx - y * gy, ay + x * gy + y * gx


@njit(parallel=True, cache=True, error_model="numpy")
def jansen_foot_vec(L, crank, cos_t, sin_t, out_x, out_y):
    """out_x[i, k], out_y[i, k] = the foot (vertex 7) of design i at θ_k. L (N, 10) in jansen.toml's
    link order, crank (N,), cos_t/sin_t (S,), out_x/out_y (N, S). Branches: the nominal design's (the
    side of its parents each dyad's vertex takes at θ = 0: 3 −, 4 −, 6 +, 5 −, 7 −)."""
    px, py = PIVOT
    for i in prange(L.shape[0]):
        s13 = L[i, 0] * L[i, 0]
        s34 = L[i, 1] * L[i, 1]
        s23 = L[i, 2] * L[i, 2]
        s24 = L[i, 3] * L[i, 3]
        s45 = L[i, 4] * L[i, 4]
        s26 = L[i, 5] * L[i, 5]
        s16 = L[i, 6] * L[i, 6]
        s56 = L[i, 7] * L[i, 7]
        s57 = L[i, 8] * L[i, 8]
        s67 = L[i, 9] * L[i, 9]
        r = crank[i]
        ox = out_x[i]
        oy = out_y[i]
        for k in range(cos_t.shape[0]):
            x1 = r * cos_t[k]
            y1 = r * sin_t[k]
            x3, y3 = _cc2(x1, y1, px, py, s13, s23, -1.0)
            x4, y4 = _cc2(x3, y3, px, py, s34, s24, -1.0)
            x6, y6 = _cc2(x1, y1, px, py, s16, s26, 1.0)
            x5, y5 = _cc2(x4, y4, x6, y6, s45, s56, -1.0)
            x7, y7 = _cc2(x5, y5, x6, y6, s57, s67, -1.0)
            ox[k] = x7
            oy[k] = y7


def foot_limit(lengths, crank, steps, out=None):
    """Foot paths of N Jansen variants by the vectorised closed form: (x, y), each (N, steps)."""
    theta = 2.0 * np.pi * np.arange(steps) / steps
    n = lengths.shape[0]
    ox, oy = (np.empty((n, steps)), np.empty((n, steps))) if out is None else out
    jansen_foot_vec(np.ascontiguousarray(lengths), np.ascontiguousarray(crank), np.cos(theta), np.sin(theta), ox, oy)
    return ox, oy


# -- the earlier, scalar form (for the comparison only) --------------------------------------------
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
def jansen_foot_scalar(L, crank, cos_t, sin_t, out):
    """The same foot as :func:`jansen_foot_vec`, one configuration at a time into out (N, S, 2)."""
    px, py = PIVOT
    for i in prange(L.shape[0]):
        l13, l34, l23, l24, l45 = L[i, 0], L[i, 1], L[i, 2], L[i, 3], L[i, 4]
        l26, l16, l56, l57, l67 = L[i, 5], L[i, 6], L[i, 7], L[i, 8], L[i, 9]
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


def foot_scalar(lengths, crank, steps):
    """Foot paths (N, steps, 2) by the scalar form."""
    theta = 2.0 * np.pi * np.arange(steps) / steps
    out = np.empty((lengths.shape[0], steps, 2))
    jansen_foot_scalar(np.ascontiguousarray(lengths), np.ascontiguousarray(crank), np.cos(theta), np.sin(theta), out)
    return out


# -- what the machine code says, and the CPU's own ceiling -------------------------------------------
def vector_width(fn=jansen_foot_vec) -> dict:
    """Counts of the packed and scalar double-precision divisions and square roots in ``fn``'s compiled
    code (x86: ``vdivpd``/``vsqrtpd`` on xmm/ymm/zmm registers, ``vdivsd``/``vsqrtsd``), per signature
    ``fn`` has been called with. The scalar counts include the vector loop's remainder."""
    from numba import njit as _njit

    # a fresh copy, compiled here: code loaded from Numba's on-disk cache keeps no assembly to read
    copy = _njit(**{k: v for k, v in fn.targetoptions.items() if k not in ("cache", "nopython")})(fn.py_func)
    for sig in fn.signatures:
        copy.compile(sig)
    asms = copy.inspect_asm()
    counts = {}
    for sig, asm in asms.items():
        c = {}
        for op in ("vdivpd", "vsqrtpd", "vdivsd", "vsqrtsd", "divsd", "sqrtsd"):
            for m in re.finditer(rf"\s{op}\s+[^\n]*", asm):
                reg = re.search(r"%([xyz])mm", m.group(0))
                key = op + (f"({reg.group(1)}mm)" if reg and op.endswith("pd") else "")
                c[key] = c.get(key, 0) + 1
        counts[str(sig)] = c
    return counts


@njit(parallel=True, cache=True, error_model="numpy")
def _div_probe(a, b, out, reps):
    """reps × a.size independent divisions per row (a, b (R, n), rows in prange, data in L1)."""
    for r in prange(a.shape[0]):
        ar = a[r]
        br = b[r]
        o = out[r]
        for _ in range(reps):
            for j in range(ar.shape[0]):
                o[j] += ar[j] / br[j]


@njit(parallel=True, cache=True, error_model="numpy")
def _sqrt_probe(a, b, out, reps):
    """reps × a.size independent square roots per row."""
    for r in prange(a.shape[0]):
        ar = a[r]
        o = out[r]
        for _ in range(reps):
            for j in range(ar.shape[0]):
                o[j] += np.sqrt(ar[j])


def probe(threads: int | None = None, n: int = 512, reps: int = 20_000, repeat: int = 3) -> dict:
    """This CPU's vectorised double-precision divisions and square roots per second on ``threads``
    threads (default: Numba's), each over its own 512 doubles (in L1) many times: {"div": /s, "sqrt": /s}.
    Best of ``repeat`` after a warm-up; the accumulate adds one addition per operation, which runs on
    other ports and does not bound these loops."""
    import numba
    t = numba.get_num_threads() if threads is None else int(threads)
    rng = np.random.default_rng(0)
    a = rng.uniform(1.0, 2.0, (t, n))
    b = rng.uniform(1.0, 2.0, (t, n))
    res = {}
    for name, fn in (("div", _div_probe), ("sqrt", _sqrt_probe)):
        out = np.zeros((t, n))
        fn(a, b, out, 1)
        best = math.inf
        for _ in range(repeat):
            t0 = time.perf_counter()
            fn(a, b, out, reps)
            best = min(best, time.perf_counter() - t0)
        res[name] = t * n * reps / best
    return res


def ceiling(rates: dict) -> float:
    """Configurations per second if the limit did nothing but its divisions and square roots (they
    share the divider, so their times add)."""
    return 1.0 / (DIVS / rates["div"] + SQRTS / rates["sqrt"])
