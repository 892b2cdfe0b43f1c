"""The dense reference method: Newton on seed 000's full square system, and its eq. 29–30 tangent.

Unknowns are the x, y of every vertex (2 n_vertices); equations are one squared-length residual per
distance equation (links, bodies' base pairs), two linear rows per body attach equation, one row
per slide equation (``_blocks.slide_eval``), and the
coordinate equations of the crank tip and the fixed vertices. No structure is used,
which makes this the simple, slow reference the block method is checked against.
"""

import numpy as np
from numba import njit

from ..kinds import eq_attach, eq_distance, eq_slide
from ..kinds._common import MAX_MOVE, NOCONV, OK, ROUNDING, lu_solve
from ..kinds.eq_slide import slide_curvature, slide_row


@njit(cache=True)
def _assemble(P, link_a, link_b, L, att_vpq, uv, slide, sd, known, known_pos, M, rhs, with_residual, ident):
    """Fill M (2nv, 2nv) with the full Jacobian at P (each row's gradient from its equation type, every
    vertex an unknown: ``ident`` maps vertex v to column pair v); if ``with_residual``, rhs = −F(P) and
    return the worst scaled residual.

    Rows: the distance equations, then two rows (x, y) per attach equation, one per slide equation,
    then two per known vertex."""
    nv = P.shape[0]
    n = 2 * nv
    n0 = link_a.shape[0] + 2 * att_vpq.shape[0]
    nl = n0 + slide.shape[0]
    for i in range(n):
        for j in range(n):
            M[i, j] = 0.0
    worst = 0.0
    for e in range(link_a.shape[0]):
        eq_distance.jacobian(P, e, link_a, link_b, ident, M, e)
        if with_residual:
            res, d2 = eq_distance.residual(P, e, link_a, link_b, L)
            rhs[e] = -res
            worst = max(worst, abs(res) / d2)
    for t in range(att_vpq.shape[0]):
        p = att_vpq[t, 1]
        q = att_vpq[t, 2]
        gx = P[q, 0] - P[p, 0]
        gy = P[q, 1] - P[p, 1]
        for ax in range(2):
            r = link_a.shape[0] + 2 * t + ax
            eq_attach.jacobian(t, ax, att_vpq, uv, ident, M, r)
            if with_residual:
                res = eq_attach.residual(P, t, ax, att_vpq, uv)
                rhs[r] = -res
                worst = max(worst, abs(res) / np.sqrt(gx * gx + gy * gy))
    ref = np.inf
    for e in range(L.shape[0]):
        ref = min(ref, L[e])
    for k in range(slide.shape[0]):
        r = n0 + k
        eq_slide.jacobian(P, k, slide, sd, ident, M, r)
        if with_residual:
            res = slide_row(P, k, slide, sd)[0]
            rhs[r] = -res
            worst = max(worst, abs(res) / ref)
    for k in range(known.shape[0]):
        v = known[k]
        for ax in range(2):
            r = nl + 2 * k + ax
            M[r, 2 * v + ax] = 1.0
            if with_residual:
                res = P[v, ax] - known_pos[k, ax]
                rhs[r] = -res
                worst = max(worst, abs(res) / (1.0 + abs(known_pos[k, ax])))
    return worst


@njit(cache=True)
def solve_dense(P0, V0, Vp, P1, V1, A1, link_a, link_b, L, att_vpq, uv, slide, sd, known, known_pos, known_vel,
                known_acc, h, hp, tol, maxit, want_acc, M, rhs, ident):
    """Predict from P0/V0/Vp, then full-system Newton; on success fill P1, V1 (and A1).

    ``known`` (n_known,) lists the crank tip then the fixed vertices, with their target positions,
    velocities and accelerations ``known_pos``/``known_vel``/``known_acc`` (n_known, 2).
    Returns (code, iterations); code is OK or NOCONV.
    """
    nv = P0.shape[0]
    n = 2 * nv
    shortest = np.inf
    for e in range(L.shape[0]):
        shortest = min(shortest, L[e])
    lim = MAX_MOVE * shortest
    c = 0.5 * h * h / hp if hp != 0.0 else 0.0
    for v in range(nv):
        for ax in range(2):
            P1[v, ax] = P0[v, ax] + h * V0[v, ax] + c * (V0[v, ax] - Vp[v, ax])
    for k in range(known.shape[0]):  # the known rows exactly: their equations then hold throughout
        P1[known[k], 0] = known_pos[k, 0]
        P1[known[k], 1] = known_pos[k, 1]
    it = 0
    while True:
        if _assemble(P1, link_a, link_b, L, att_vpq, uv, slide, sd, known, known_pos, M, rhs, True, ident) <= ROUNDING:
            break
        if it >= maxit or lu_solve(M, rhs, n) == 0.0:
            return NOCONV, it
        norm = 0.0
        for v in range(nv):
            norm = max(norm, rhs[2 * v] * rhs[2 * v] + rhs[2 * v + 1] * rhs[2 * v + 1])
        s = 1.0 if norm <= lim * lim else lim / np.sqrt(norm)
        for v in range(nv):
            P1[v, 0] += s * rhs[2 * v]
            P1[v, 1] += s * rhs[2 * v + 1]
        it += 1
        if norm <= tol * tol:  # the correction just kept moved no vertex further than tol: converged
            break
    # seed 000 eq. 29–30: M dV/dθ = B, B = the known vertices' rates, zero for the link and attach rows
    nl = link_a.shape[0] + 2 * att_vpq.shape[0] + slide.shape[0]
    _assemble(P1, link_a, link_b, L, att_vpq, uv, slide, sd, known, known_pos, M, rhs, False, ident)
    for e in range(nl):
        rhs[e] = 0.0
    for k in range(known.shape[0]):
        rhs[nl + 2 * k] = known_vel[k, 0]
        rhs[nl + 2 * k + 1] = known_vel[k, 1]
    if lu_solve(M, rhs, n) == 0.0:
        return NOCONV, it
    for v in range(nv):
        V1[v, 0] = rhs[2 * v]
        V1[v, 1] = rhs[2 * v + 1]
    if want_acc:
        _assemble(P1, link_a, link_b, L, att_vpq, uv, slide, sd, known, known_pos, M, rhs, False, ident)
        for e in range(nl):
            rhs[e] = 0.0  # attach rows are linear: no curvature term
        for k in range(slide.shape[0]):
            rhs[link_a.shape[0] + 2 * att_vpq.shape[0] + k] = -slide_curvature(V1, k, slide, sd)
        for e in range(link_a.shape[0]):
            wx = V1[link_b[e], 0] - V1[link_a[e], 0]
            wy = V1[link_b[e], 1] - V1[link_a[e], 1]
            rhs[e] = -2.0 * (wx * wx + wy * wy)
        for k in range(known.shape[0]):
            rhs[nl + 2 * k] = known_acc[k, 0]
            rhs[nl + 2 * k + 1] = known_acc[k, 1]
        lu_solve(M, rhs, n)
        for v in range(nv):
            A1[v, 0] = rhs[2 * v]
            A1[v, 1] = rhs[2 * v + 1]
    return OK, it
