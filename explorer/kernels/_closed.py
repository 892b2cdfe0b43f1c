"""The exact closed form for all-dyad plans: sequential circle–circle intersections.

Each dyad vertex is the intersection of two circles about its parents, on the side given by the
nominal design's branch sign. It is the error reference and the speed limit for the Newton methods
(it cannot detect a branch change by itself: it always takes the sign it is given).
"""

import math

import numpy as np
from numba import njit, prange

from ._cycle import STATUS_ASSEMBLY, STATUS_INVALID, STATUS_OK


@njit(cache=True)
def closed_cycle(dv, dpa, dpb, dla, dlb, tip, fixed, fixed_pos, L, radius, cx, cy, signs, cth, sth, out_idx, out_pos,
                 P):
    """Positions at every θ_k of one design into out_pos (S, n_out, 2). Returns (status, failure angle)."""
    S = cth.shape[0]
    ok = math.isfinite(radius) and radius > 0.0
    for e in range(L.shape[0]):
        ok = ok and math.isfinite(L[e]) and L[e] > 0.0
    if not ok:
        out_pos[:, :, :] = np.nan
        return STATUS_INVALID, 0.0
    for i in range(fixed.shape[0]):
        P[fixed[i], 0] = fixed_pos[i, 0]
        P[fixed[i], 1] = fixed_pos[i, 1]
    for k in range(S):
        P[tip, 0] = cx + radius * cth[k]
        P[tip, 1] = cy + radius * sth[k]
        for j in range(dv.shape[0]):
            a = dpa[j]
            b = dpb[j]
            r1 = L[dla[j]]
            r2 = L[dlb[j]]
            gx = P[b, 0] - P[a, 0]
            gy = P[b, 1] - P[a, 1]
            d2 = gx * gx + gy * gy
            x = 0.5 * (r1 * r1 - r2 * r2 + d2) / d2  # along a→b, as a fraction of |a−b|
            y2 = r1 * r1 / d2 - x * x  # squared offset across, same units
            if y2 < 0.0 or d2 == 0.0:
                out_pos[k:, :, :] = np.nan
                return STATUS_ASSEMBLY, 2.0 * np.pi * k / S
            y = math.sqrt(y2) if signs[j] > 0.0 else -math.sqrt(y2)
            P[dv[j], 0] = P[a, 0] + x * gx - y * gy
            P[dv[j], 1] = P[a, 1] + x * gy + y * gx
        for j in range(out_idx.shape[0]):
            out_pos[k, j, 0] = P[out_idx[j], 0]
            out_pos[k, j, 1] = P[out_idx[j], 1]
    return STATUS_OK, np.nan


@njit(parallel=True, cache=True)
def closed_batch_jit(dv, dpa, dpb, dla, dlb, tip, fixed, fixed_pos, lengths, radius, cx, cy, P_init, signs, cth, sth,
                     out_idx, out_pos, status, fail_theta):
    """:func:`closed_cycle` for every row of ``lengths`` (N, n_links), in parallel."""
    for i in prange(lengths.shape[0]):
        P = P_init.copy()
        st, th = closed_cycle(dv, dpa, dpb, dla, dlb, tip, fixed, fixed_pos, lengths[i], radius[i], cx, cy, signs,
                              cth, sth, out_idx, out_pos[i], P)
        status[i] = st
        fail_theta[i] = th
