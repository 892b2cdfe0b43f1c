"""The exact closed form for plans of DYAD and ATTACH blocks: sequential circle–circle intersections
and rigid transforms.

Each dyad vertex is the intersection of two circles about its parents, on the side given by the
starting branch sign; each body joint follows its base pair by the body's rigid transform. It is the error reference and the speed limit for the Newton methods; it
cannot detect a branch change by itself (it always takes the sign it is given). Where a design
cannot assemble, the limit is bisected between samples (to Δ/2**REFINE_LEVELS, like the sweep)
and, for a crank, the other end of the unreachable range is found from 2π going backward.
"""

import numpy as np
from numba import njit

from ._batch import valid_lengths
from ._kinds_array import place_closed
from ._drive import drive
from ._sweep import REFINE_LEVELS, STATUS_ASSEMBLY, STATUS_INVALID, STATUS_OK


@njit(cache=True)
def _limit(tab, tip, kind, prm, cx, cy, scale, signs, P, good, bad, dmin):
    """Bisect between parameters ``good`` (assembles) and ``bad`` (does not) to within dmin; returns
    (the first failing parameter found, its failing dyad)."""
    d = np.empty(6)
    blk = -1
    while abs(bad - good) > dmin:
        mid = 0.5 * (good + bad)
        drive(kind, prm, mid, d)
        j = place_closed(tab, tip, cx, cy, scale, d, signs, P, False)
        if j < 0:
            good = mid
        else:
            bad = mid
            blk = j
    if blk < 0:
        drive(kind, prm, bad, d)
        blk = place_closed(tab, tip, cx, cy, scale, d, signs, P, False)
    return bad, blk


@njit(cache=True)
def _nan_rows(out_pos, lo, hi):
    """out_pos[lo:hi] = NaN, as loops (a slice assignment compiles for about a second more)."""
    for k in range(lo, hi):
        for i in range(out_pos.shape[1]):
            out_pos[k, i, 0] = np.nan
            out_pos[k, i, 1] = np.nan


@njit(cache=True, inline="always")
def closed_cycle(blocks, tip, kind, prm, tab, params, t_end, closed, cx, cy, scale, signs, out_idx, out_pos, P):
    """Positions at every sample of one design into out_pos (S, n_out, 2); blocks: its block table;
    P (n_vertices, 2) holds the fixed vertices. Driver arguments as in ``_sweep.sweep``. Returns
    (status, failure parameter or NaN, end of the unreachable range or NaN, failing dyad or −1),
    like the sweep."""
    S = tab.shape[0]
    dmin = (t_end / S if closed else t_end / (S - 1)) / 2.0 ** REFINE_LEVELS
    status = STATUS_OK
    fail_t = np.nan
    fail_end = np.nan
    fail_block = -1
    reached = S
    back = S
    for k in range(S):
        j = place_closed(blocks, tip, cx, cy, scale, tab[k], signs, P, False)
        if j >= 0:
            status = STATUS_ASSEMBLY
            reached = k
            fail_block = j
            fail_t = params[k]
            if k > 0:
                fail_t, fail_block = _limit(blocks, tip, kind, prm, cx, cy, scale, signs, P, params[k - 1], params[k],
                                            dmin)
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
            if place_closed(blocks, tip, cx, cy, scale, tab[k], signs, P, False) >= 0:
                bad = k
                break
            back = k
            upper = params[k]
            for i in range(out_idx.shape[0]):
                out_pos[k, i, 0] = P[out_idx[i], 0]
                out_pos[k, i, 1] = P[out_idx[i], 1]
        fail_end, _ = _limit(blocks, tip, kind, prm, cx, cy, scale, signs, P, upper, params[bad], dmin)
    _nan_rows(out_pos, reached, back)
    return status, fail_t, fail_end, fail_block


@njit(cache=True, nogil=True)
def closed_batch_jit(topo, drv, signs, designs, outs):
    """:func:`closed_cycle` for every design (row) of ``designs``, serially, into ``outs`` (positions
    and failures only); the ``_inputs`` named tuples, per-row ones last, for
    :func:`~._rows.parallel_rows`."""
    for i in range(designs.scale.shape[0]):
        L = designs.dist[i]
        scale = designs.scale[i]
        out_pos = outs.pos[i]
        if not valid_lengths(L, scale):
            _nan_rows(out_pos, 0, out_pos.shape[0])
            st, tf, te, bl = STATUS_INVALID, 0.0, np.nan, -1
        else:
            P = designs.start[i].copy()
            cx = designs.center[i, 0]
            cy = designs.center[i, 1]
            st, tf, te, bl = closed_cycle(designs.table[i], topo.tip, drv.kind, drv.prm, drv.table, drv.params, drv.t_end,
                                          drv.closed, cx, cy, scale, signs, topo.out_idx, out_pos, P)
        outs.status[i] = st
        outs.fail_t[i] = tf
        outs.fail_end[i] = te
        outs.fail_block[i] = bl
