"""The batch kernels: one design, or N variants in parallel, through the sweep driver.

For every row they are handed, the ``*_batch_jit`` kernels check the variant's lengths, build its
block table (and, for the generic step, its context) and run :func:`~._sweep.sweep`, serially and
without the GIL: :func:`~._rows.parallel_rows` runs them in parallel over blocks of rows. (The
per-variant part is written into each loop rather than called: a separately compiled function
layer re-optimises the whole sweep once more, about 2 s on a cold cache.)
"""


import math

import numpy as np
from numba import njit

from ..plan import ATTACH, DYAD, GENERAL, SLIDE
from ._drive import CRANK
from ._blocks import OK
from ._fast import frame_point, slide_root
from ._step import block_table, generic_context
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


@njit(cache=True)
def design_start(P_init, fixed, fixed_pos):
    """A design's start: the nominal start P_init with its own fixed vertices ``fixed_pos`` in place."""
    P = P_init.copy()
    for f in range(fixed.shape[0]):
        P[fixed[f], 0] = fixed_pos[f, 0]
        P[fixed[f], 1] = fixed_pos[f, 1]
    return P


@njit(cache=True)
def place_closed(tab, tip, cx, cy, scale, d, signs, P, start, sliders=True):
    """Place the driven vertex at (cx, cy) + scale * d[:2], then every block of the block table
    ``tab`` in order by the closed form: a dyad's vertex at the intersection of the circles about its
    parents on the side ``signs[j]`` (the branch: the sign of cross(b − a, p − a)), a body joint by
    its body's rigid transform of its base pair, a SLIDE block's vertex where its circle meets its line
    on the side ``signs[j]`` (``_fast.slide_root``). Writes P (n_vertices, 2) in place; returns the first
    block it could not place (a dyad whose circles do not meet), or −1.

    start: placing a design's start for Newton (the kernels' first sample): then it also stops,
    leaving that vertex and the later ones where they were, at a coupled (GENERAL) block or a dyad
    with no branch to keep (sign 0), which Newton places from there.

    sliders: None for a table without SLIDE blocks (the generated kernels'): Numba then prunes the
    SLIDE branch when it compiles this (an argument typed None is a compile-time constant), and the
    slider code is not compiled; a SLIDE row would then be reported as not placed."""
    P[tip, 0] = cx + scale * d[0]
    P[tip, 1] = cy + scale * d[1]
    for j in range(tab.shape[0]):
        rec = tab[j]
        if start and (rec.kind == GENERAL or (rec.kind != ATTACH and signs[j] == 0.0)):
            return j
        if rec.kind == SLIDE:
            if sliders is None:
                return j
            code, x, y = slide_root(rec, signs[j], P, P[rec.vertex, 0], P[rec.vertex, 1])
            if code != OK:
                return j
            P[rec.vertex, 0] = x
            P[rec.vertex, 1] = y
            continue
        a = rec.a
        b = rec.b
        gx = P[b, 0] - P[a, 0]
        gy = P[b, 1] - P[a, 1]
        if rec.kind == DYAD:
            d2 = gx * gx + gy * gy
            if d2 == 0.0:
                return j
            x = 0.5 * (rec.da2 - rec.db2 + d2) / d2  # along a→b, as a fraction of |a−b|
            y2 = rec.da2 / d2 - x * x  # squared offset across, same units
            if y2 < 0.0:
                return j
            y = math.sqrt(y2) if signs[j] > 0.0 else -math.sqrt(y2)
        else:  # ATTACH: the body's rigid transform from its base pair (a, b)
            x = rec.u
            y = rec.v
        P[rec.vertex, 0], P[rec.vertex, 1] = frame_point(x, y, P[a, 0], P[a, 1], P[b, 0], P[b, 1])
    return -1


@njit(cache=True)
def design_setup(topo, designs, i, P_init, crank, d0, signs, sliders=True):
    """Design i's start, crank centre and block table: (P, cx, cy, table).

    The start is the design assembled at the first sample (driver values d0, (6,)) on the nominal's
    branch of every block (``signs``), by the closed form (:func:`place_closed`): Newton's first
    solve then starts at the root it must keep, wherever the design's dimensions put it. (Started from
    the nominal's configuration, a design far from it could converge to the mirror root and be
    reported as a branch failure although it assembles on the nominal's branch.) Vertices the closed
    form cannot place (beyond a coupled block, or where the design cannot assemble) keep the nominal's
    positions, and Newton starts there; fixed vertices are the design's own.

    sliders: None for a plan without SLIDE blocks: the slider code of :func:`place_closed` and
    ``_step.block_table`` is then left out of the compiled code (pruned by Numba as the argument's
    type is None: about 1 CPU-s less on a cold cache for the generated kernels, which take no sliders)."""
    P = design_start(P_init, topo.fixed, designs.fixed[i])
    cx = designs.center[i, 0]
    cy = designs.center[i, 1]
    if sliders is None:
        tab = block_table(topo.kind, topo.dyad, topo.join, topo.attach, topo.gen, topo.att_vpq, topo.tip,
                          designs.dist[i], designs.uv[i], P, cx, cy, designs.scale[i], crank, None, None, None)
        place_closed(tab, topo.tip, cx, cy, designs.scale[i], d0, signs, P, True, None)
    else:
        tab = block_table(topo.kind, topo.dyad, topo.join, topo.attach, topo.gen, topo.att_vpq, topo.tip,
                          designs.dist[i], designs.uv[i], P, cx, cy, designs.scale[i], crank, topo.slid, topo.slide,
                          designs.slide[i])
        place_closed(tab, topo.tip, cx, cy, designs.scale[i], d0, signs, P, True)
    return P, cx, cy, tab


@njit(cache=True)
def _shortest(tab, L):
    """The shortest dyad length of a block table (the scale of the sweep's closing check); the
    shortest distance equation if there is no dyad."""
    out = np.inf
    for k in range(tab.shape[0]):
        if tab[k].kind == DYAD:
            out = min(out, np.sqrt(tab[k].da2), np.sqrt(tab[k].db2))
    if out == np.inf:
        for e in range(L.shape[0]):
            out = min(out, L[e])
    return out


@njit(cache=True, nogil=True)
def fast_batch_jit(topo, drv, opts, P_init, signs, designs, outs):
    """Every design (row) of ``designs`` through :func:`_sweep.sweep` with the fast DYAD / ATTACH step,
    serially, writing ``outs`` in place.

    topo, drv, opts, designs, outs: the ``_inputs`` named tuples; P_init (n_vertices, 2): the
    nominal's configuration at the first sample (every design's first Newton solve starts there);
    signs (n_blocks,): the nominal's branch of each block. The per-row arguments come last
    (``designs``, ``outs``), for :func:`~._rows.parallel_rows`.
    """
    crank = drv.kind == CRANK
    for i in range(designs.scale.shape[0]):
        L = designs.dist[i]
        scale = designs.scale[i]
        if not valid_lengths(L, scale):
            res = _invalid(outs.pos[i], outs.vel[i], outs.acc[i], opts.want_vel, opts.want_acc)
        else:
            P, cx, cy, tab = design_setup(topo, designs, i, P_init, crank, drv.table[0], signs)
            res = fast_sweep(tab, topo, drv, opts, P, signs, cx, cy, scale, _shortest(tab, L), designs.tol[i],
                             outs.pos[i], outs.vel[i], outs.acc[i])
        outs.status[i], outs.fail_t[i], outs.fail_end[i], outs.fail_block[i], outs.iters[i] = res


@njit(cache=True, nogil=True)
def generic_batch_jit(topo, drv, opts, P_init, signs, designs, outs):
    """Every design through :func:`_sweep.sweep` with the generic step (``opts.method``: block or
    dense), serially; arguments as for :func:`fast_batch_jit`."""
    crank = drv.kind == CRANK
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
            P, cx, cy, tab = design_setup(topo, designs, i, P_init, crank, drv.table[0], signs)
            ctx = generic_context(opts.method, tab, topo.gen_vptr, topo.gen_verts, topo.gen_rptr, topo.gen_rows,
                                  topo.dist_a, topo.dist_b, topo.att_vpq, L, designs.uv[i], known, designs.fixed[i],
                                  topo.slide, designs.slide[i])
            shortest = np.inf
            for e in range(L.shape[0]):
                shortest = min(shortest, L[e])
            res = generic_sweep(ctx, topo, drv, opts, P, signs, cx, cy, scale, shortest, designs.tol[i],
                                outs.pos[i], outs.vel[i], outs.acc[i])
        outs.status[i], outs.fail_t[i], outs.fail_end[i], outs.fail_block[i], outs.iters[i] = res
