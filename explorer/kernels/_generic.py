"""The generic step: block Newton on plans with coupled (non-dyad) blocks, and dense full-system Newton.

Dyad blocks reuse the fast path's :func:`~._dyads.dyad_step` one block at a time; coupled blocks
(e.g. an Assur triad) run :func:`~._blocks.solve_general`; the dense method runs
:func:`~._dense.solve_dense` on the whole system and then applies the same per-block branch, gap and
move checks. Only compiled when a study needs it.
"""

import numpy as np
from numba import njit

from ._blocks import INFEASIBLE, NOCONV, OK, SIGN, SUSPECT, dyad_sign, gap_suspect, general_sign, solve_general
from ._dense import solve_dense
from ._dyads import FOLD_SIN, dyad_context, dyad_step

BLOCK = 0
DENSE = 1
FOLD = -1  # internal to the dense check


@njit(cache=True)
def dyad_parents(k, vert_ptr, verts, link_ptr, blinks, link_a, link_b):
    """(vertex, parent a, parent b, link a, link b) of dyad block k."""
    v = verts[vert_ptr[k]]
    la = blinks[link_ptr[k]]
    lb = blinks[link_ptr[k] + 1]
    a = link_b[la] if link_a[la] == v else link_a[la]
    b = link_b[lb] if link_a[lb] == v else link_a[lb]
    return v, a, b, la, lb


@njit(cache=True)
def block_signs(P, kind, vert_ptr, verts, link_ptr, blinks, link_a, link_b, loc, M, rhs):
    """Branch sign (+1.0 / −1.0, 0.0 if singular) of every block at positions P, shape (n_blocks,)."""
    nb = kind.shape[0]
    out = np.zeros(nb)
    for k in range(nb):
        if kind[k] == 0:
            v, a, b, la, lb = dyad_parents(k, vert_ptr, verts, link_ptr, blinks, link_a, link_b)
            out[k] = np.sign(dyad_sign(P, v, a, b))
        else:
            out[k] = general_sign(P, verts[vert_ptr[k]:vert_ptr[k + 1]], blinks[link_ptr[k]:link_ptr[k + 1]],
                                  link_a, link_b, loc, M, rhs)
    return out


@njit(cache=True)
def generic_context(method, kind, vert_ptr, verts, link_ptr, blinks, link_a, link_b, known, fixed_pos, L):
    """Per-variant context of :func:`generic_step` (scratch included)."""
    nb = kind.shape[0]
    nv = 0
    for e in range(link_a.shape[0]):
        nv = max(nv, link_a[e] + 1, link_b[e] + 1)
    for i in range(known.shape[0]):
        nv = max(nv, known[i] + 1)
    dv = np.zeros(nb, dtype=np.int64)
    dpa = np.zeros(nb, dtype=np.int64)
    dpb = np.zeros(nb, dtype=np.int64)
    dla = np.zeros(nb, dtype=np.int64)
    dlb = np.zeros(nb, dtype=np.int64)
    for k in range(nb):
        if kind[k] == 0:
            v, a, b, la, lb = dyad_parents(k, vert_ptr, verts, link_ptr, blinks, link_a, link_b)
            dv[k] = v
            dpa[k] = a
            dpb[k] = b
            dla[k] = la
            dlb[k] = lb
    dctx = dyad_context(dv, dpa, dpb, dla, dlb, L, np.full(nb, -1, dtype=np.int64), -1, False, 0.0, 0.0, 1.0,
                        np.zeros((1, 2)))
    nk = known.shape[0]
    kpos = np.zeros((nk, 2))
    for i in range(1, nk):
        kpos[i, 0] = fixed_pos[i - 1, 0]
        kpos[i, 1] = fixed_pos[i - 1, 1]
    n = 2 * nv
    return (method, kind, vert_ptr, verts, link_ptr, blinks, link_a, link_b, known, kpos, np.zeros((nk, 2)),
            np.zeros((nk, 2)), L, dctx, np.full(nv, -1, dtype=np.int64), np.empty((n, n)), np.empty(n))


@njit(cache=True)
def _blocks_step(ctx, signs, P0, V0, Vp, P1, V1, A1, h, hp, tol, maxit, want_acc, checks):
    method, kind, vert_ptr, verts, link_ptr, blinks, link_a, link_b, known, kpos, kvel, kacc, L, dctx, loc, M, rhs = ctx
    iters = 0
    for k in range(kind.shape[0]):
        if kind[k] == 0:
            code, _, it = dyad_step(dctx[k:k + 1], signs[k:k + 1], P0, V0, Vp, P1, V1, A1, h, hp, tol, maxit, want_acc,
                                    checks)
        else:
            code, it = solve_general(P0, V0, Vp, P1, V1, A1, verts[vert_ptr[k]:vert_ptr[k + 1]],
                                     blinks[link_ptr[k]:link_ptr[k + 1]], link_a, link_b, L, h, hp, tol, maxit,
                                     signs[k], want_acc, checks, loc, M, rhs)
        iters += it
        if code != OK:
            return code, k, iters
    return OK, -1, iters


@njit(cache=True)
def _check_dense(ctx, signs, P0, V0, P1, V1, h, checks):
    """The per-block branch, gap and move checks on a full-system solution. Returns (code, block);
    code FOLD marks a dyad on the mirror root at a fold (not a branch change: both roots meet there)."""
    method, kind, vert_ptr, verts, link_ptr, blinks, link_a, link_b, known, kpos, kvel, kacc, L, dctx, loc, M, rhs = ctx
    for k in range(kind.shape[0]):
        if kind[k] == 0:
            v, a, b = int(dctx[k, 0]), int(dctx[k, 1]), int(dctx[k, 2])
            hi2, lo2, lim2 = dctx[k, 5], dctx[k, 6], dctx[k, 7]
            sg = dyad_sign(P1, v, a, b)
            if sg == 0.0 or (sg > 0.0) != (signs[k] > 0.0):
                ea = (P1[v, 0] - P1[a, 0]) ** 2 + (P1[v, 1] - P1[a, 1]) ** 2
                eb = (P1[v, 0] - P1[b, 0]) ** 2 + (P1[v, 1] - P1[b, 1]) ** 2
                return (FOLD if abs(sg) <= FOLD_SIN * np.sqrt(ea * eb) else SIGN), k
            if checks:
                ux = P0[b, 0] - P0[a, 0]
                uy = P0[b, 1] - P0[a, 1]
                gx = P1[b, 0] - P1[a, 0]
                gy = P1[b, 1] - P1[a, 1]
                m0 = 2.0 * (ux * (V0[b, 0] - V0[a, 0]) + uy * (V0[b, 1] - V0[a, 1]))
                m1 = 2.0 * (gx * (V1[b, 0] - V1[a, 0]) + gy * (V1[b, 1] - V1[a, 1]))
                if gap_suspect(ux * ux + uy * uy, m0, gx * gx + gy * gy, m1, h, hi2, lo2):
                    return SUSPECT, k
                mx = P1[v, 0] - P0[v, 0] - h * V0[v, 0]
                my = P1[v, 1] - P0[v, 1] - h * V0[v, 1]
                if mx * mx + my * my > lim2:
                    return SUSPECT, k
        else:
            sg = general_sign(P1, verts[vert_ptr[k]:vert_ptr[k + 1]], blinks[link_ptr[k]:link_ptr[k + 1]],
                              link_a, link_b, loc, M, rhs)
            if sg == 0.0 or (sg > 0.0) != (signs[k] > 0.0):
                return SIGN, k
    return OK, -1


@njit(cache=True)
def generic_step(ctx, signs, P0, V0, Vp, P1, V1, A1, h, hp, tol, maxit, want_acc, checks):
    """One step of the sweep for the block method on any plan, or the dense method. Returns (code, block, iterations)."""
    method, kind, vert_ptr, verts, link_ptr, blinks, link_a, link_b, known, kpos, kvel, kacc, L, dctx, loc, M, rhs = ctx
    if method == BLOCK:
        return _blocks_step(ctx, signs, P0, V0, Vp, P1, V1, A1, h, hp, tol, maxit, want_acc, checks)
    tip = known[0]
    for ax in range(2):
        kpos[0, ax] = P1[tip, ax]
        kvel[0, ax] = V1[tip, ax]
        kacc[0, ax] = A1[tip, ax]
    code, iters = solve_dense(P0, V0, Vp, P1, V1, A1, link_a, link_b, L, known, kpos, kvel, kacc, h, hp, tol, maxit,
                              want_acc, M, rhs)
    for i in range(known.shape[0]):  # the known rows exactly as given
        for ax in range(2):
            P1[known[i], ax] = kpos[i, ax]
            V1[known[i], ax] = kvel[i, ax]
            A1[known[i], ax] = kacc[i, ax]
    if code != OK:
        # tell a design that cannot assemble here from one where Newton merely failed: next to a fold
        # the full-system Newton converges only linearly and may run out of iterations, where the
        # block step (which keeps each dyad's branch, as for FOLD below) still solves
        c2, b2, it2 = _blocks_step(ctx, signs, P0, V0, Vp, P1, V1, A1, h, hp, tol, maxit, want_acc, checks)
        if c2 == INFEASIBLE or c2 == SUSPECT:
            return c2, b2, iters + it2
        if c2 == OK:
            return OK, -1, iters + it2
        return NOCONV, -1, iters
    code, blk = _check_dense(ctx, signs, P0, V0, P1, V1, h, checks)
    if code == FOLD:
        # at a fold both roots meet and the full-system Newton may take either: this step is redone
        # block by block, which keeps each dyad's branch (see dyad_step)
        code, blk, it = _blocks_step(ctx, signs, P0, V0, Vp, P1, V1, A1, h, hp, tol, maxit, want_acc, checks)
        iters += it
    return code, blk, iters
