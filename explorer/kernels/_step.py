"""One step of the sweep: place every block at the driver's new position, in plan order.

The per-variant *block table* (a record array of ``_inputs.BLOCK_DTYPE``, ``_batch.setup``) holds each
block's kind and the numbers its kind reads; a step loops over it and places each block with its
kind's code (``_kinds_array``, rendered from the kinds). Two steps:

* ``_kinds_array.fast_step`` — plans without coupled blocks (Jansen, Hoeken, Klann, sliders, ...):
  scalar code, nothing of the dense or coupled-block machinery compiled in.
* :func:`generic_step` — any plan (GENERAL blocks too) with the block method
  (``_kinds_array.block_step``), or the dense full-system method followed by the same per-block
  checks. Its context is a :class:`GenericContext`.

Both return (code, failing block or −1, Newton iterations); codes are ``explorer.kinds._common``'s
OK, INFEASIBLE, SIGN, NOCONV, SUSPECT.
"""

from collections import namedtuple

import numpy as np
from numba import njit

from ..kinds._common import INFEASIBLE, NOCONV, OK, SUSPECT
from ._dense import solve_dense
from ._kinds_array import FOLD, block_step, check_dense, place_explicit

BLOCK = 0
DENSE = 1

GenericContext = namedtuple("GenericContext", [
    "method",     # BLOCK or DENSE
    "table",      # (nb,) BLOCK_DTYPE, the block table
    "gen_vptr", "gen_verts", "gen_rptr", "gen_rows",   # GENERAL blocks (``_inputs.Topology``)
    "dist_a", "dist_b", "att_vpq",                      # every equation's vertices
    "dist",       # (n_dist,) the distance equations' lengths
    "uv",         # (n_attach, 2) the attach equations' (u, v)
    "slide",      # (n_slide, 3) the slide equations' vertices (``_inputs.Topology.slide``)
    "sd",         # (n_slide, 6) their lines (``_inputs.Designs.slide``)
    "known",      # (n_known,) int64: the driven vertex, the fixed ones, the explicit blocks' (dense)
    "kpos", "kvel", "kacc",  # (n_known, 2) their targets (dense)
    "loc", "M", "rhs",       # scratch
    "ident",      # (n_vertices,) 0 … n−1: every vertex an unknown (the dense method's columns)
    "explicit",   # (n_explicit,) the blocks that place their vertex from the driver alone (``Topology``)
])


@njit(cache=True)
def generic_step(ctx, signs, P0, V0, Vp, P1, V1, A1, h, hp, tol, maxit, want_acc, checks):
    """One step of the sweep for the block method on any plan, or the dense method."""
    if ctx.method == BLOCK:
        return block_step(ctx, signs, P0, V0, Vp, P1, V1, A1, h, hp, tol, maxit, want_acc, checks)
    known = ctx.known
    kpos = ctx.kpos
    kvel = ctx.kvel
    kacc = ctx.kacc
    tip = known[0]
    for ax in range(2):
        kpos[0, ax] = P1[tip, ax]
        kvel[0, ax] = V1[tip, ax]
        kacc[0, ax] = A1[tip, ax]
    ne = ctx.explicit.shape[0]
    if ne > 0:  # vertices placed from the driver alone (a geared crank's tip): known rows too
        place_explicit(ctx.table, ctx.explicit, P1, V1, A1, want_acc)
        for q in range(ne):
            i = known.shape[0] - ne + q
            for ax in range(2):
                kpos[i, ax] = P1[known[i], ax]
                kvel[i, ax] = V1[known[i], ax]
                kacc[i, ax] = A1[known[i], ax]
    code, iters = solve_dense(P0, V0, Vp, P1, V1, A1, ctx.dist_a, ctx.dist_b, ctx.dist, ctx.att_vpq, ctx.uv, ctx.slide,
                              ctx.sd, known, kpos, kvel, kacc, h, hp, tol, maxit, want_acc, ctx.M, ctx.rhs, ctx.ident)
    for i in range(known.shape[0]):  # the known rows exactly as given
        for ax in range(2):
            P1[known[i], ax] = kpos[i, ax]
            V1[known[i], ax] = kvel[i, ax]
            A1[known[i], ax] = kacc[i, ax]
    if code != OK:
        # tell a design that cannot assemble here from one where Newton merely failed: next to a fold
        # the full-system Newton converges only linearly and may run out of iterations, where the
        # block step (which keeps each dyad's branch, as for FOLD below) still solves
        c2, b2, it2 = block_step(ctx, signs, P0, V0, Vp, P1, V1, A1, h, hp, tol, maxit, want_acc, checks)
        if c2 == INFEASIBLE or c2 == SUSPECT:
            return c2, b2, iters + it2
        if c2 == OK:
            return OK, -1, iters + it2
        return NOCONV, -1, iters
    code, blk = check_dense(ctx, signs, P0, V0, P1, V1, h, checks)
    if code == FOLD:
        # at a fold both roots meet and the full-system Newton may take either: this step is redone
        # block by block, which keeps each dyad's branch
        code, blk, it = block_step(ctx, signs, P0, V0, Vp, P1, V1, A1, h, hp, tol, maxit, want_acc, checks)
        iters += it
    return code, blk, iters


@njit(cache=True)
def generic_context(method, table, gen_vptr, gen_verts, gen_rptr, gen_rows, dist_a, dist_b, att_vpq, dist, uv,
                    known, fixed_pos, slide, sd, explicit):
    """The :class:`GenericContext` of one design (scratch included); fixed_pos (n_fixed, 2) are the
    targets of ``known[1:1 + n_fixed]`` (the explicit blocks' vertices follow, placed at each step)."""
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
    for i in range(1, 1 + fixed_pos.shape[0]):
        kpos[i, 0] = fixed_pos[i - 1, 0]
        kpos[i, 1] = fixed_pos[i - 1, 1]
    n = 2 * nv
    return GenericContext(method, table, gen_vptr, gen_verts, gen_rptr, gen_rows, dist_a, dist_b, att_vpq, dist, uv,
                          slide, sd, known, kpos, np.zeros((nk, 2)), np.zeros((nk, 2)), np.full(nv, -1, dtype=np.int64),
                          np.empty((n, n)), np.empty(n), np.arange(nv), explicit)
