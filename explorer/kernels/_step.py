"""One step of the sweep: place every block at the driver's new position, in plan order.

The per-variant *block table* (:func:`block_table`, a record array of ``_inputs.BLOCK_DTYPE``) holds
each block's kind and the numbers its kernel reads; a step loops over it and places each block with
its kind's kernel. Two steps:

* ``_fast.fast_step`` — plans of DYAD and ATTACH blocks only (Jansen, Hoeken, Klann, most legs):
  scalar code, nothing of the dense or coupled-block machinery compiled in.
* :func:`generic_step` — any plan (GENERAL blocks too) with the block method (DYAD and ATTACH
  rows through ``_fast.fast_step``, GENERAL ones through ``_blocks.solve_general``), or the dense
  full-system method followed by the same per-block checks. Its context is a
  :class:`GenericContext`.

Both return (code, failing block or −1, Newton iterations); codes are ``_blocks``' OK, INFEASIBLE,
SIGN, NOCONV, SUSPECT.
"""

from collections import namedtuple

import numpy as np
from numba import njit

from ..plan import ATTACH, DYAD, GENERAL, SLIDE
from ._blocks import (INFEASIBLE, MAX_MOVE, NOCONV, OK, SIGN, SUSPECT, dyad_sign, gap_suspect, general_sign,
                      solve_general)
from ._dense import solve_dense
from ._fast import FOLD_SIN, dyad_fill, fast_step, slide_sign
from ._inputs import BLOCK_DTYPE

BLOCK = 0
DENSE = 1
FOLD = -1  # internal to the dense check

GenericContext = namedtuple("GenericContext", [
    "method",     # BLOCK or DENSE
    "table",      # (nb,) BLOCK_DTYPE, the block table
    "gen_vptr", "gen_verts", "gen_rptr", "gen_rows",   # GENERAL blocks (``_inputs.Topology``)
    "dist_a", "dist_b", "att_vpq",                      # every equation's vertices
    "dist",       # (n_dist,) the distance equations' lengths
    "uv",         # (n_attach, 2) the attach equations' (u, v)
    "slide",      # (n_slide, 3) the slide equations' vertices (``_inputs.Topology.slide``)
    "sd",         # (n_slide, 6) their lines (``_inputs.Designs.slide``)
    "known",      # (n_known,) int64: the driven vertex, then the fixed ones (dense)
    "kpos", "kvel", "kacc",  # (n_known, 2) their targets (dense)
    "loc", "M", "rhs",       # scratch
])


@njit(cache=True)
def block_table(kind, dyad, join, attach, gen, att_vpq, tip, dist, uv, P, cx, cy, scale, crank, slid, slide, sd):
    """The block table of one design: (nb,) records of ``BLOCK_DTYPE`` in plan order.

    kind, dyad, join, attach, gen, att_vpq, tip, slid, slide: the ``_inputs.Topology`` fields; dist
    (n_dist,), uv (n_attach, 2) and sd (n_slide, 6): the design's equations; P (n_vertices, 2): its
    start (fixed vertices in place); (cx, cy), scale: its crank centre and radius; crank: whether the
    driver is a crank. slid, slide and sd are None for a plan without SLIDE blocks: Numba then prunes
    the SLIDE branch (an argument typed None is a compile-time constant) and does not compile it.
    """
    nb = kind.shape[0]
    tab = np.zeros(nb, dtype=BLOCK_DTYPE)
    for k in range(nb):
        rec = tab[k]
        rec.kind = kind[k]
        if kind[k] == DYAD:
            v = dyad[k, 0]
            a = dyad[k, 1]
            b = dyad[k, 2]
            qmin = -1.0
            qmax = -1.0
            if join[k] >= 0:
                qmin = dist[join[k]] * dist[join[k]]
                qmax = qmin
            elif join[k] == -2 and crank:
                other = b if a == tip else a
                D = np.hypot(P[other, 0] - cx, P[other, 1] - cy)
                qmin = (D - scale) * (D - scale)
                qmax = (D + scale) * (D + scale)
            dyad_fill(rec, v, a, b, dist[dyad[k, 3]], dist[dyad[k, 4]], qmin, qmax)
        elif kind[k] == SLIDE:
            if slid is None:  # a plan without sliders: this code is pruned, not compiled (_batch.design_setup)
                continue
            v = slid[k, 0]
            e = slid[k, 3]
            d = dist[slid[k, 2]]
            rec.vertex = v
            rec.a = slid[k, 1]
            rec.b = slid[k, 1]
            rec.da2 = d * d
            rec.hi2 = d * d
            rec.lo2 = -d * d
            rec.lim2 = (MAX_MOVE * d) ** 2
            rec.gap = 1
            rec.sp = slide[e, 0]
            rec.sa = slide[e, 1]
            rec.sb = slide[e, 2]
            rec.role = 0 if slide[e, 0] == v else (1 if slide[e, 1] == v else 2)
            rec.lx = sd[e, 0]
            rec.ly = sd[e, 1]
            rec.nx = sd[e, 2]
            rec.ny = sd[e, 3]
            rec.off = sd[e, 4]
            rec.sl = sd[e, 5]
        elif kind[k] == ATTACH:
            t = attach[k]
            rec.vertex = att_vpq[t, 0]
            rec.a = att_vpq[t, 1]
            rec.b = att_vpq[t, 2]
            rec.u = uv[t, 0]
            rec.v = uv[t, 1]
        else:
            rec.slot = gen[k]
    return tab


@njit(cache=True)
def _general_solve(ctx, k, signs, P0, V0, Vp, P1, V1, A1, h, hp, tol, maxit, want_acc, checks):
    g = ctx.table[k].slot
    return solve_general(P0, V0, Vp, P1, V1, A1, ctx.gen_verts[ctx.gen_vptr[g]:ctx.gen_vptr[g + 1]],
                         ctx.gen_rows[ctx.gen_rptr[g]:ctx.gen_rptr[g + 1]], ctx.dist_a, ctx.dist_b, ctx.att_vpq,
                         ctx.dist, ctx.uv, ctx.slide, ctx.sd, h, hp, tol, maxit, signs[k], want_acc, checks, ctx.loc,
                         ctx.M, ctx.rhs)


@njit(cache=True)
def _blocks_step(ctx, signs, P0, V0, Vp, P1, V1, A1, h, hp, tol, maxit, want_acc, checks):
    iters = 0
    table = ctx.table
    for k in range(table.shape[0]):
        if table[k].kind != GENERAL:  # DYAD and ATTACH: the fast step, on this block's row
            code, _, it = fast_step(table[k:k + 1], signs[k:k + 1], P0, V0, Vp, P1, V1, A1, h, hp, tol, maxit,
                                    want_acc, checks)
        else:
            code, it = _general_solve(ctx, k, signs, P0, V0, Vp, P1, V1, A1, h, hp, tol, maxit, want_acc, checks)
        iters += it
        if code != OK:
            return code, k, iters
    return OK, -1, iters


@njit(cache=True)
def _check_dense(ctx, signs, P0, V0, P1, V1, h, checks):
    """The per-block branch, gap and move checks on a full-system solution. Returns (code, block);
    code FOLD marks a dyad on the mirror root at a fold (not a branch change: both roots meet there)."""
    table = ctx.table
    for k in range(table.shape[0]):
        rec = table[k]
        if rec.kind == DYAD:
            v, a, b = rec.vertex, rec.a, rec.b
            hi2, lo2, lim2 = rec.hi2, rec.lo2, rec.lim2
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
        elif rec.kind == SLIDE:
            sg = slide_sign(rec, P1)
            if sg == 0.0 or (sg > 0.0) != (signs[k] > 0.0):
                return SIGN, k
        elif rec.kind != ATTACH:  # ATTACH has no branch
            g = rec.slot
            sg = general_sign(P1, ctx.gen_verts[ctx.gen_vptr[g]:ctx.gen_vptr[g + 1]],
                              ctx.gen_rows[ctx.gen_rptr[g]:ctx.gen_rptr[g + 1]], ctx.dist_a, ctx.dist_b, ctx.att_vpq,
                              ctx.uv, ctx.slide, ctx.sd, ctx.loc, ctx.M, ctx.rhs)
            if sg == 0.0 or (sg > 0.0) != (signs[k] > 0.0):
                return SIGN, k
    return OK, -1


@njit(cache=True)
def generic_step(ctx, signs, P0, V0, Vp, P1, V1, A1, h, hp, tol, maxit, want_acc, checks):
    """One step of the sweep for the block method on any plan, or the dense method."""
    if ctx.method == BLOCK:
        return _blocks_step(ctx, signs, P0, V0, Vp, P1, V1, A1, h, hp, tol, maxit, want_acc, checks)
    known = ctx.known
    kpos = ctx.kpos
    kvel = ctx.kvel
    kacc = ctx.kacc
    tip = known[0]
    for ax in range(2):
        kpos[0, ax] = P1[tip, ax]
        kvel[0, ax] = V1[tip, ax]
        kacc[0, ax] = A1[tip, ax]
    code, iters = solve_dense(P0, V0, Vp, P1, V1, A1, ctx.dist_a, ctx.dist_b, ctx.dist, ctx.att_vpq, ctx.uv, ctx.slide,
                              ctx.sd, known, kpos, kvel, kacc, h, hp, tol, maxit, want_acc, ctx.M, ctx.rhs)
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
        # block by block, which keeps each dyad's branch (see ``_fast.fast_step``)
        code, blk, it = _blocks_step(ctx, signs, P0, V0, Vp, P1, V1, A1, h, hp, tol, maxit, want_acc, checks)
        iters += it
    return code, blk, iters


@njit(cache=True)
def generic_context(method, table, gen_vptr, gen_verts, gen_rptr, gen_rows, dist_a, dist_b, att_vpq, dist, uv,
                    known, fixed_pos, slide, sd):
    """The :class:`GenericContext` of one design (scratch included); fixed_pos (n_fixed, 2) are the
    targets of ``known[1:]``."""
    nv = 0
    for e in range(dist_a.shape[0]):
        nv = max(nv, dist_a[e] + 1, dist_b[e] + 1)
    for i in range(known.shape[0]):
        nv = max(nv, known[i] + 1)
    for t in range(att_vpq.shape[0]):
        for c in range(3):
            nv = max(nv, att_vpq[t, c] + 1)
    for t in range(slide.shape[0]):
        for c in range(3):
            nv = max(nv, slide[t, c] + 1)
    nk = known.shape[0]
    kpos = np.zeros((nk, 2))
    for i in range(1, nk):
        kpos[i, 0] = fixed_pos[i - 1, 0]
        kpos[i, 1] = fixed_pos[i - 1, 1]
    n = 2 * nv
    return GenericContext(method, table, gen_vptr, gen_verts, gen_rptr, gen_rows, dist_a, dist_b, att_vpq, dist, uv,
                          slide, sd, known, kpos, np.zeros((nk, 2)), np.zeros((nk, 2)), np.full(nv, -1, dtype=np.int64),
                          np.empty((n, n)), np.empty(n))


@njit(cache=True)
def block_signs(P, table, gen_vptr, gen_verts, gen_rptr, gen_rows, dist_a, dist_b, att_vpq, uv, slide, sd):
    """Branch sign (+1.0 / −1.0, 0.0 if singular or without a branch) of every block at positions P."""
    nb = table.shape[0]
    out = np.zeros(nb)
    n = 2 * P.shape[0]
    loc = np.full(P.shape[0], -1, dtype=np.int64)
    M = np.empty((n, n))
    rhs = np.empty(n)
    for k in range(nb):
        rec = table[k]
        if rec.kind == DYAD:
            out[k] = np.sign(dyad_sign(P, rec.vertex, rec.a, rec.b))
        elif rec.kind == SLIDE:
            out[k] = np.sign(slide_sign(rec, P))
        elif rec.kind != ATTACH:
            g = rec.slot
            out[k] = general_sign(P, gen_verts[gen_vptr[g]:gen_vptr[g + 1]], gen_rows[gen_rptr[g]:gen_rptr[g + 1]],
                                  dist_a, dist_b, att_vpq, uv, slide, sd, loc, M, rhs)
    return out
