"""The batch kernels: N variants through the sweep driver, and each variant's setup.

:func:`setup` runs once per chunk of variants, before any sweep: for each variant, its block table
(each block's numbers, filled by its kind) and its start (the design assembled at the first sample on
the nominal's branch by the closed form). It is one compiled function for every topology (the
lowered plan and the block table are arrays), so the kernels generated per topology do not compile
it again, and a cache built once serves every plan.

For every row they are handed, the ``*_batch_jit`` kernels check the variant's lengths and run
:func:`~._sweep.sweep`, serially and without the GIL: :func:`~._rows.parallel_rows` runs them in
parallel over blocks of rows.
"""

import numpy as np
from numba import njit

from ._drive import CRANK
from ._kinds_array import block_table, place_closed
from ._rows import parallel_rows
from ._step import generic_context
from ._sweep import STATUS_INVALID, fast_sweep, generic_sweep

# Lengths outside this range are "invalid": their squares (the residuals are in squared lengths)
# would underflow to 0 or overflow to inf (NaN compares false, so NaN is invalid as well).
MIN_LENGTH = 1e-150
MAX_LENGTH = 1e150


@njit(cache=True)
def valid_lengths(L, scale):
    """True if every link length and the driver scale (crank radius) lie in [MIN_LENGTH, MAX_LENGTH]:
    finite, positive, and with squares that neither underflow nor overflow in double precision."""
    ok = MIN_LENGTH <= scale <= MAX_LENGTH
    for e in range(L.shape[0]):
        ok = ok and MIN_LENGTH <= L[e] <= MAX_LENGTH
    return ok


@njit(cache=True)
def _nan_fill(out):
    """out[...] = NaN, as a flat loop (a slice assignment compiles for about a second more)."""
    flat = out.reshape(-1)
    for i in range(flat.shape[0]):
        flat[i] = np.nan


@njit(cache=True)
def _invalid(out_pos, out_vel, out_acc, want_vel, want_acc):
    """NaN outputs and the sweep's 5-tuple for a design with a non-finite or non-positive length.
    (out_vel and out_acc have no rows when not wanted, so filling them costs nothing.)"""
    _nan_fill(out_pos)
    _nan_fill(out_vel)
    _nan_fill(out_acc)
    return STATUS_INVALID, 0.0, np.nan, -1, 0


@njit(cache=True, nogil=True)
def setup_jit(topo, d0, P_init, signs, crank, designs):
    """Each valid design's (row's) block table and start into ``designs.table`` and ``designs.start``.

    The start is the design assembled at the first sample (driver values d0, (6,)) on the nominal's
    branch of every block (``signs``), by the closed form (``_kinds_array.place_closed``): Newton's
    first solve then starts at the root it must keep, wherever the design's dimensions put it. (Started
    from the nominal's configuration, a design far from it could converge to the mirror root and be
    reported as a branch failure although it assembles on the nominal's branch.) Vertices the closed
    form cannot place (beyond a coupled block, or where the design cannot assemble) keep the nominal's
    positions P_init, and Newton starts there; fixed vertices are the design's own."""
    fixed = topo.fixed
    for i in range(designs.scale.shape[0]):
        L = designs.dist[i]
        scale = designs.scale[i]
        if not valid_lengths(L, scale):
            continue
        P = designs.start[i]
        for v in range(P.shape[0]):
            P[v, 0] = P_init[v, 0]
            P[v, 1] = P_init[v, 1]
        for f in range(fixed.shape[0]):
            P[fixed[f], 0] = designs.fixed[i, f, 0]
            P[fixed[f], 1] = designs.fixed[i, f, 1]
        cx = designs.center[i, 0]
        cy = designs.center[i, 1]
        tab = designs.table[i]
        block_table(tab, topo.kind, topo.blk, topo.tip, L, designs.uv[i], designs.slide[i], topo.att_vpq, topo.slide,
                    P, cx, cy, scale, crank)
        place_closed(tab, topo.tip, cx, cy, scale, d0, signs, P, True)


def setup(plan, blocks, topo, drv, P_init, signs, des):
    """``des`` (``_inputs.Designs``) with its block tables, starts and closing-check scales filled
    (see :func:`setup_jit`). The closing check's scale (``Designs.shortest``) is the shortest distance
    equation among the rows of the blocks solved (their links and body base pairs), or, for blocks
    without one, the design's shortest distance equation."""
    rows = sorted({e for b in blocks for e in plan.blocks[b].links})
    L = des.dist
    with np.errstate(invalid="ignore"):
        shortest = (L[:, rows] if rows else L).min(axis=1, initial=np.inf) if L.shape[1] else np.full(L.shape[0], np.inf)
    des = des._replace(shortest=np.ascontiguousarray(shortest))
    parallel_rows(setup_jit, (topo, drv.table[0], P_init, signs, drv.kind == CRANK), (des,))
    return des


@njit(cache=True, nogil=True)
def fast_batch_jit(topo, drv, opts, signs, designs, outs):
    """Every design (row) of ``designs`` through :func:`_sweep.sweep` with the fast step (plans without
    coupled blocks), serially, writing ``outs`` in place.

    topo, drv, opts, designs, outs: the ``_inputs`` named tuples (``designs`` set up by :func:`setup`);
    signs (n_blocks,): the nominal's branch of each block. The per-row arguments come last
    (``designs``, ``outs``), for :func:`~._rows.parallel_rows`.
    """
    for i in range(designs.scale.shape[0]):
        L = designs.dist[i]
        scale = designs.scale[i]
        if not valid_lengths(L, scale):
            res = _invalid(outs.pos[i], outs.vel[i], outs.acc[i], opts.want_vel, opts.want_acc)
        else:
            res = fast_sweep(designs.table[i], topo, drv, opts, designs.start[i], signs, designs.center[i, 0],
                             designs.center[i, 1], scale, designs.shortest[i], designs.tol[i], outs.pos[i],
                             outs.vel[i], outs.acc[i])
        outs.status[i], outs.fail_t[i], outs.fail_end[i], outs.fail_block[i], outs.iters[i] = res


@njit(cache=True, nogil=True)
def generic_batch_jit(topo, drv, opts, signs, designs, outs):
    """Every design through :func:`_sweep.sweep` with the generic step (``opts.method``: block or
    dense), serially; arguments as for :func:`fast_batch_jit`."""
    known = np.empty(topo.fixed.shape[0] + 1, dtype=np.int64)
    known[0] = topo.tip
    for f in range(topo.fixed.shape[0]):
        known[f + 1] = topo.fixed[f]
    for i in range(designs.scale.shape[0]):
        L = designs.dist[i]
        scale = designs.scale[i]
        if not valid_lengths(L, scale):
            res = _invalid(outs.pos[i], outs.vel[i], outs.acc[i], opts.want_vel, opts.want_acc)
        else:
            ctx = generic_context(opts.method, designs.table[i], topo.gen_vptr, topo.gen_verts, topo.gen_rptr,
                                  topo.gen_rows, topo.dist_a, topo.dist_b, topo.att_vpq, L, designs.uv[i], known,
                                  designs.fixed[i], topo.slide, designs.slide[i])
            res = generic_sweep(ctx, topo, drv, opts, designs.start[i], signs, designs.center[i, 0],
                                designs.center[i, 1], scale, designs.shortest[i], designs.tol[i], outs.pos[i],
                                outs.vel[i], outs.acc[i])
        outs.status[i], outs.fail_t[i], outs.fail_end[i], outs.fail_block[i], outs.iters[i] = res
