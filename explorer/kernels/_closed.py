"""The exact closed form for all-dyad plans: sequential circle–circle intersections.

Each dyad vertex is the intersection of two circles about its parents, on the side given by the
starting branch sign. It is the error reference and the speed limit for the Newton methods; it
cannot detect a branch change by itself (it always takes the sign it is given). Where a design
cannot assemble, the limit is bisected between samples (to Δ/2**REFINE_LEVELS, like the sweep)
and, for a crank, the other end of the unreachable range is found from 2π going backward.
"""

import math

import numpy as np
from numba import njit

from ._batch import valid_lengths
from ._drive import drive
from ._sweep import REFINE_LEVELS, STATUS_ASSEMBLY, STATUS_INVALID, STATUS_OK


@njit(cache=True)
def _place(dv, dpa, dpb, dla, dlb, tip, cx, cy, scale, d, L, signs, P):
    """Place the driven vertex at (cx, cy) + scale * d[:2] and every dyad after it; returns the first
    dyad that cannot assemble, or −1."""
    P[tip, 0] = cx + scale * d[0]
    P[tip, 1] = cy + scale * d[1]
    for j in range(dv.shape[0]):
        a = dpa[j]
        b = dpb[j]
        r1 = L[dla[j]]
        r2 = L[dlb[j]]
        gx = P[b, 0] - P[a, 0]
        gy = P[b, 1] - P[a, 1]
        d2 = gx * gx + gy * gy
        if d2 == 0.0:
            return j
        x = 0.5 * (r1 * r1 - r2 * r2 + d2) / d2  # along a→b, as a fraction of |a−b|
        y2 = r1 * r1 / d2 - x * x  # squared offset across, same units
        if y2 < 0.0:
            return j
        y = math.sqrt(y2) if signs[j] > 0.0 else -math.sqrt(y2)
        P[dv[j], 0] = P[a, 0] + x * gx - y * gy
        P[dv[j], 1] = P[a, 1] + x * gy + y * gx
    return -1


@njit(cache=True)
def _limit(dv, dpa, dpb, dla, dlb, tip, kind, prm, cx, cy, scale, L, signs, P, good, bad, dmin):
    """Bisect between parameters ``good`` (assembles) and ``bad`` (does not) to within dmin; returns
    (the first failing parameter found, its failing dyad)."""
    d = np.empty(6)
    blk = -1
    while abs(bad - good) > dmin:
        mid = 0.5 * (good + bad)
        drive(kind, prm, mid, d)
        j = _place(dv, dpa, dpb, dla, dlb, tip, cx, cy, scale, d, L, signs, P)
        if j < 0:
            good = mid
        else:
            bad = mid
            blk = j
    if blk < 0:
        drive(kind, prm, bad, d)
        blk = _place(dv, dpa, dpb, dla, dlb, tip, cx, cy, scale, d, L, signs, P)
    return bad, blk


@njit(cache=True)
def _nan_rows(out_pos, lo, hi):
    """out_pos[lo:hi] = NaN, as loops (a slice assignment compiles for about a second more)."""
    for k in range(lo, hi):
        for i in range(out_pos.shape[1]):
            out_pos[k, i, 0] = np.nan
            out_pos[k, i, 1] = np.nan


@njit(cache=True, inline="always")
def closed_cycle(dv, dpa, dpb, dla, dlb, tip, kind, prm, tab, params, t_end, closed, cx, cy, L, scale, signs,
                 out_idx, out_pos, P):
    """Positions at every sample of one design into out_pos (S, n_out, 2); P (n_vertices, 2) holds the
    fixed vertices. Driver arguments as in ``_sweep.sweep``. Returns (status, failure parameter or
    NaN, end of the unreachable range or NaN, failing dyad or −1), like the sweep."""
    S = tab.shape[0]
    if not valid_lengths(L, scale):
        _nan_rows(out_pos, 0, S)
        return STATUS_INVALID, 0.0, np.nan, -1
    dmin = (t_end / S if closed else t_end / (S - 1)) / 2.0 ** REFINE_LEVELS
    status = STATUS_OK
    fail_t = np.nan
    fail_end = np.nan
    fail_block = -1
    reached = S
    back = S
    for k in range(S):
        j = _place(dv, dpa, dpb, dla, dlb, tip, cx, cy, scale, tab[k], L, signs, P)
        if j >= 0:
            status = STATUS_ASSEMBLY
            reached = k
            fail_block = j
            fail_t = params[k]
            if k > 0:
                fail_t, fail_block = _limit(dv, dpa, dpb, dla, dlb, tip, kind, prm, cx, cy, scale, L, signs, P,
                                            params[k - 1], params[k], dmin)
            break
        for i in range(out_idx.shape[0]):
            out_pos[k, i, 0] = P[out_idx[i], 0]
            out_pos[k, i, 1] = P[out_idx[i], 1]
    if status != STATUS_OK and closed and reached > 0:
        # going backward from 2π (= θ 0, which assembles): the first sample that fails, or else the
        # forward failure's own sample, brackets the other end of the unreachable range
        upper = t_end
        bad = reached
        for k in range(S - 1, reached, -1):
            if _place(dv, dpa, dpb, dla, dlb, tip, cx, cy, scale, tab[k], L, signs, P) >= 0:
                bad = k
                break
            back = k
            upper = params[k]
            for i in range(out_idx.shape[0]):
                out_pos[k, i, 0] = P[out_idx[i], 0]
                out_pos[k, i, 1] = P[out_idx[i], 1]
        fail_end, _ = _limit(dv, dpa, dpb, dla, dlb, tip, kind, prm, cx, cy, scale, L, signs, P, upper, params[bad],
                             dmin)
    _nan_rows(out_pos, reached, back)
    return status, fail_t, fail_end, fail_block


@njit(cache=True, nogil=True)
def closed_batch_jit(dv, dpa, dpb, dla, dlb, tip, kind, prm, tab, params, t_end, closed, cx, cy, P_init, signs, out_idx,
                     lengths, scale, out_pos, status, fail_t, fail_end, fail_block):
    """:func:`closed_cycle` for every row of ``lengths`` (N, n_links) / ``scale`` (N,), serially; the
    per-row arguments come last (from ``lengths`` on), for :func:`~._rows.parallel_rows`."""
    for i in range(lengths.shape[0]):
        P = P_init.copy()
        st, tf, te, bl = closed_cycle(dv, dpa, dpb, dla, dlb, tip, kind, prm, tab, params, t_end, closed, cx, cy,
                                      lengths[i], scale[i], signs, out_idx, out_pos[i], P)
        status[i] = st
        fail_t[i] = tf
        fail_end[i] = te
        fail_block[i] = bl
