"""The batch kernels: one design, or N variants in parallel, through the sweep driver.

For every row they are handed, the ``*_batch_jit`` kernels check the variant's lengths, build its
step context (the fast all-dyad one or the generic one) and run :func:`~._sweep.sweep`, serially and
without the GIL: :func:`~._rows.parallel_rows` runs them in parallel over blocks of rows. (The
per-variant part is written into each loop rather than called: a separately compiled function
layer re-optimises the whole sweep once more, about 2 s on a cold cache.)
"""


import numpy as np
from numba import njit

from ._drive import CRANK
from ._dyads import dyad_context
from ._generic import generic_context
from ._sweep import STATUS_INVALID, dyad_sweep, generic_sweep

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
def _invalid(out_pos, out_vel, out_acc, want_vel, want_acc):
    """NaN outputs and the sweep's 5-tuple for a design with a non-finite or non-positive length.
    (Flat loops: a slice assignment compiles for about a second more.)"""
    for out, wanted in ((out_pos, True), (out_vel, want_vel), (out_acc, want_acc)):
        if wanted:
            flat = out.reshape(-1)
            for i in range(flat.shape[0]):
                flat[i] = np.nan
    return STATUS_INVALID, 0.0, np.nan, -1, 0


@njit(cache=True, nogil=True)
def dyad_batch_jit(dv, dpa, dpb, dla, dlb, dlp, tip, kind, prm, tab, t_end, closed, cx, cy, P_init, signs, moving, tol,
                   maxit, out_idx, want_vel, want_acc, lengths, scale, out_pos, out_vel, out_acc, status, fail_t,
                   fail_end, fail_block, iters):
    """Every row of ``lengths`` (N, n_links) / ``scale`` (N,) through :func:`_sweep.sweep` with the dyad
    step, serially.

    Outputs in place: out_pos (N, S, n_out, 2); out_vel / out_acc the same when asked, else
    (N, 0, n_out, 2); status, fail_t, fail_end, fail_block, iters (N,). The per-row arguments come
    last (from ``lengths`` on), for :func:`~._rows.parallel_rows`.
    """
    for i in range(lengths.shape[0]):
        L = lengths[i]
        if not valid_lengths(L, scale[i]):
            res = _invalid(out_pos[i], out_vel[i], out_acc[i], want_vel, want_acc)
        else:
            ctx = dyad_context(dv, dpa, dpb, dla, dlb, L, dlp, tip, kind == CRANK, cx, cy, scale[i], P_init)
            shortest = np.inf
            for e in range(dla.shape[0]):
                shortest = min(shortest, L[dla[e]], L[dlb[e]])
            res = dyad_sweep(ctx, tip, kind, prm, tab, t_end, closed, cx, cy, scale[i], P_init, signs, moving,
                             shortest, tol * L.max(), maxit, out_idx, want_vel, want_acc, out_pos[i], out_vel[i], out_acc[i])
        status[i], fail_t[i], fail_end[i], fail_block[i], iters[i] = res


@njit(cache=True, nogil=True)
def generic_batch_jit(method, kind, vert_ptr, verts, link_ptr, blinks, link_a, link_b, known, fixed_pos, tip, dkind,
                      prm, tab, t_end, closed, cx, cy, P_init, signs, moving, tol, maxit, out_idx, want_vel, want_acc,
                      lengths, scale, out_pos, out_vel, out_acc, status, fail_t, fail_end, fail_block, iters):
    """Every row through :func:`_sweep.sweep` with the generic step, serially; the outputs and the
    order of arguments are those of :func:`dyad_batch_jit`."""
    for i in range(lengths.shape[0]):
        L = lengths[i]
        if not valid_lengths(L, scale[i]):
            res = _invalid(out_pos[i], out_vel[i], out_acc[i], want_vel, want_acc)
        else:
            ctx = generic_context(method, kind, vert_ptr, verts, link_ptr, blinks, link_a, link_b, known, fixed_pos,
                                  L)
            shortest = np.inf
            for e in range(L.shape[0]):
                shortest = min(shortest, L[e])
            res = generic_sweep(ctx, tip, dkind, prm, tab, t_end, closed, cx, cy, scale[i], P_init, signs, moving,
                                shortest, tol * L.max(), maxit, out_idx, want_vel, want_acc, out_pos[i], out_vel[i], out_acc[i])
        status[i], fail_t[i], fail_end[i], fail_block[i], iters[i] = res
