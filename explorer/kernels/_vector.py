"""The vectorised closed-form first pass: each design's blocks over every sample at once, Newton where needed.

For plans whose every block kind has a closed form (dyads, body joints, sliders: each kind's ``vector``
snippet in ``explorer/kinds``, rendered into ``_kinds_array.vector_blocks``), a design is solved
block by block, each block over all S samples at once on the branch the design starts on (the
nominal's, the same root the Newton sweep starts from and must keep), with its tangents for the
velocities; x and y live in separate (n_vertices, S) arrays, and a dyad's loop over the samples has no
branch, so LLVM vectorises it (8 samples per instruction on AVX-512). Its checks are passes over the
same step arrays: the assembly margin and the closeness to a fold at every sample (|sin| of the angle
at the vertex ≥ ``dyad.VECTOR_FOLD``), the gap bound between samples (the squared parent distance's
cubic Hermite bound, as in the sweep) and the move limit (the vertex's deviation from its linear
prediction ≤ the sweep's largest move). A design that passes every check is done: the closed form is
the exact root on its branch (within rounding, well inside the tolerance promise, which Newton meets
only to within tol), every sample is on one branch and no fold or gap hides between samples. A
flagged design (and an invalid one) goes through the Newton sweep, which stays the reference and
owns every failure report (status, angle, block).

Newton need not redo what the pass solved: for a flagged design of dyads, body joints and geared cranks
(:func:`restart_points`), the samples from the start up to the first that fails a check, and (a crank)
those from the last failing one to the end and the step back to θ = 2π, are exact roots that passed
every check; they are stored, and the sweep resumes forward and backward where they end
(``Designs.restart_at``, ``restart_pos``; ``_sweep_template.sweep``), so a design that cannot
assemble over part of the cycle costs the steps around its failures instead of its whole reachable range.

Outputs are the sweep's: positions (and tangents) of ``topo.out_idx``, status OK, 0 iterations; a
flagged row has status :data:`FLAGGED` and its failing block in ``fail_block`` until Newton replaces it.
Coupled blocks (GENERAL) have no vector form: their plans keep Newton (``applies``).
"""

import numpy as np
from numba import njit

from ..kinds import KINDS
from ._kinds_array import vector_blocks, vector_good
from ._sweep_template import STATUS_OK, valid_lengths

#: Status of a row the first pass leaves to Newton (never stored: Newton overwrites it).
FLAGGED = -1


def applies(kinds, signs) -> bool:
    """Whether the first pass can solve a plan whose blocks (those solved) have ``kinds`` (int array)
    and the nominal's branch ``signs``: every kind has a vector form, and every block that keeps a
    branch has one (sign ±1; a block with sign 0 starts on a fold, and Newton places it)."""
    for k, s in zip(kinds, signs):
        mod = KINDS[int(k)]
        if not mod.ARRAY.get("vector", "").strip():
            return False
        if mod.START == "sign" and s == 0.0:
            return False
    return True


@njit(cache=True, nogil=True)
def restart_points(tab, signs, X, Y, VX, VY, Q, M, P, V, h, closed, j, good_at, good_to):
    """Where Newton may resume for a design the first pass flagged at block j (X, Y, VX, VY (n_vertices,
    S): its rows, solved up to block j; the rest as for ``vector_blocks``; good_at, good_to (S,) bool:
    scratch): (kf, kb), samples 0 … kf and kb … S−1 (and the step from S−1 back to 0) passed every
    check of every block, 0 where there is no such run (or a block's kind does not tell its checks
    sample by sample: sliders). The blocks after j are solved here too."""
    k = j
    while k >= 0:  # the blocks after the flagged one: their rows at the samples that pass are exact
        k = vector_blocks(tab, signs, X, Y, VX, VY, Q, M, P, V, h, closed, k + 1)
    S = X.shape[1]
    good_at[:] = True
    good_to[:] = True
    if not vector_good(tab, X, Y, VX, VY, h, closed, good_at, good_to):  # each kind's ``good`` snippet
        return 0, 0
    if not good_at[0]:
        return 0, 0
    kf = 0
    while kf + 1 < S and good_to[kf] and good_at[kf + 1]:
        kf += 1
    kb = 0
    if closed and good_to[S - 1] and good_at[S - 1] and S - 1 > kf + 1:
        kb = S - 1
        while kb - 1 > kf + 1 and good_at[kb - 1] and good_to[kb - 1]:
            kb -= 1
    return kf, kb


@njit(cache=True, nogil=True)
def _store(outs, i, X, Y, VX, VY, out_idx, want_vel, lo, hi):
    """Samples lo … hi−1 of the rows ``out_idx`` of X, Y (and VX, VY) into row i of the outputs."""
    for o in range(out_idx.shape[0]):
        w = out_idx[o]
        for k in range(lo, hi):
            outs.pos[i, k, o, 0] = X[w, k]
            outs.pos[i, k, o, 1] = Y[w, k]
        if want_vel:
            for k in range(lo, hi):
                outs.vel[i, k, o, 0] = VX[w, k]
                outs.vel[i, k, o, 1] = VY[w, k]


@njit(cache=True, nogil=True)
def vector_batch_jit(topo, drv, want_vel, signs, designs, outs):
    """The first pass for every design (row) of ``designs`` (``_inputs.Designs``, set up by
    ``_batch.setup``), serially, writing ``outs`` (``_inputs.Outputs``) in place; the shared
    arguments first and the per-row ones last, for ``_rows.parallel_rows``. want_vel: write the
    tangents (d/dparameter) of ``topo.out_idx``; signs (nb,): each block's branch. A flagged design's
    ``designs.restart_at`` and ``restart_pos`` (n_vertices rows) say where Newton resumes
    (:func:`restart_points`), and the samples before (after) are stored."""
    nv = designs.start.shape[1]
    T = drv.table
    S = T.shape[0]
    h = drv.t_end / S if drv.closed else drv.t_end / (S - 1)
    X = np.empty((nv, S))
    Y = np.empty((nv, S))
    VX = np.empty((nv, S))
    VY = np.empty((nv, S))
    Q = np.empty(S)
    M = np.empty(S)
    P = np.zeros((nv, 2))
    V = np.zeros((nv, 2))
    good_at = np.empty(S, dtype=np.bool_)
    good_to = np.empty(S, dtype=np.bool_)
    tip = topo.tip
    fixed = topo.fixed
    out_idx = topo.out_idx
    for i in range(designs.scale.shape[0]):
        outs.iters[i] = 0
        outs.fail_t[i] = np.nan
        outs.fail_end[i] = np.nan
        designs.restart_at[i, 0] = 0
        designs.restart_at[i, 1] = 0
        scale = designs.scale[i]
        if not valid_lengths(designs.dist[i], scale):
            outs.status[i] = FLAGGED  # Newton's batch reports it "invalid"
            outs.fail_block[i] = -1
            continue
        for f in range(fixed.shape[0]):
            w = fixed[f]
            fx = designs.fixed[i, f, 0]
            fy = designs.fixed[i, f, 1]
            for k in range(S):
                X[w, k] = fx
                Y[w, k] = fy
                VX[w, k] = 0.0
                VY[w, k] = 0.0
        cx = designs.center[i, 0]
        cy = designs.center[i, 1]
        for k in range(S):
            X[tip, k] = cx + scale * T[k, 0]
            Y[tip, k] = cy + scale * T[k, 1]
            VX[tip, k] = scale * T[k, 2]
            VY[tip, k] = scale * T[k, 3]
        tab = designs.table[i]
        j = vector_blocks(tab, signs, X, Y, VX, VY, Q, M, P, V, h, drv.closed, 0)
        if j >= 0:
            outs.status[i] = FLAGGED
            outs.fail_block[i] = j
            kf, kb = restart_points(tab, signs, X, Y, VX, VY, Q, M, P, V, h, drv.closed, j, good_at, good_to)
            for r, s in ((0, kf), (1, kb)):
                designs.restart_at[i, r] = s
                if s > 0:
                    for v in range(nv):
                        designs.restart_pos[i, r, v, 0] = X[v, s]
                        designs.restart_pos[i, r, v, 1] = Y[v, s]
            if kf > 0:
                _store(outs, i, X, Y, VX, VY, out_idx, want_vel, 0, kf + 1)
            if kb > 0:
                _store(outs, i, X, Y, VX, VY, out_idx, want_vel, kb, S)
            continue
        outs.status[i] = STATUS_OK
        outs.fail_block[i] = -1
        _store(outs, i, X, Y, VX, VY, out_idx, want_vel, 0, S)
