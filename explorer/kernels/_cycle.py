"""Continuation over the crank cycle with branch tracking and adaptive refinement, and its batch kernel.

Each crank step θ_k → θ_{k+1} is tried whole. If any block reports trouble (a sign change, no
convergence, an assembly failure, a possible gap between samples, or a move too large for the local
geometry) the step is retried in halves, recursively, down to Δθ / 2**REFINE_LEVELS. What still fails
at that size is real: the cycle ends there with the block and angle. After the last sample one more
step returns to θ = 2π; a cycle that does not close on its start configuration is a branch failure.
"""

import math

import numpy as np
from numba import njit, prange

from ._blocks import (INFEASIBLE, NOCONV, OK, SIGN, SUSPECT, MAX_MOVE, dyad_gap_suspect, dyad_sign,
                      general_sign, solve_dyad, solve_general)
from ._dense import solve_dense

BLOCK = 0
DENSE = 1

# Per-variant status codes (public: they are stored in results files).
STATUS_OK = 0
STATUS_ASSEMBLY = 1
STATUS_BRANCH = 2
STATUS_NOCONV = 3
STATUS_INVALID = 4

REFINE_LEVELS = 16


@njit(cache=True, inline="always")
def _dyad_parents(k, vert_ptr, verts, link_ptr, blinks, link_a, link_b):
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
            v, a, b, la, lb = _dyad_parents(k, vert_ptr, verts, link_ptr, blinks, link_a, link_b)
            out[k] = np.sign(dyad_sign(P, v, a, b))
        else:
            out[k] = general_sign(P, verts[vert_ptr[k]:vert_ptr[k + 1]], blinks[link_ptr[k]:link_ptr[k + 1]],
                                  link_a, link_b, loc, M, rhs)
    return out


@njit(cache=True, inline="always")
def _advance_blocks(kind, vert_ptr, verts, link_ptr, blinks, link_a, link_b, L, h, hp, P0, V0, Vp, P1, V1, A1,
                    want_acc, signs, tol, maxit, checks, loc, M, rhs):
    """Block method: Newton block by block in plan order. Returns (code, block, iterations)."""
    iters = 0
    for k in range(kind.shape[0]):
        if kind[k] == 0:
            v, a, b, la, lb = _dyad_parents(k, vert_ptr, verts, link_ptr, blinks, link_a, link_b)
            code, it = solve_dyad(P0, V0, Vp, P1, V1, A1, v, a, b, L[la], L[lb], h, hp, tol, maxit, signs[k],
                                  want_acc, checks)
        else:
            code, it = solve_general(P0, V0, Vp, P1, V1, A1, verts[vert_ptr[k]:vert_ptr[k + 1]],
                                     blinks[link_ptr[k]:link_ptr[k + 1]], link_a, link_b, L, h, hp, tol, maxit,
                                     signs[k], want_acc, checks, loc, M, rhs)
        iters += it
        if code != OK:
            return code, k, iters
    return OK, -1, iters


@njit(cache=True)
def _check_dense(kind, vert_ptr, verts, link_ptr, blinks, link_a, link_b, L, h, P0, V0, P1, V1, signs, checks,
                 loc, M, rhs):
    """Dense method: the per-block branch, gap and move checks on a full-system solution. Returns (code, block)."""
    for k in range(kind.shape[0]):
        if kind[k] == 0:
            v, a, b, la, lb = _dyad_parents(k, vert_ptr, verts, link_ptr, blinks, link_a, link_b)
            sg = dyad_sign(P1, v, a, b)
            if sg == 0.0 or (sg > 0.0) != (signs[k] > 0.0):
                return SIGN, k
            if checks:
                if dyad_gap_suspect(P0, V0, P1, V1, a, b, L[la], L[lb], h):
                    return SUSPECT, k
                mx = P1[v, 0] - P0[v, 0] - h * V0[v, 0]
                my = P1[v, 1] - P0[v, 1] - h * V0[v, 1]
                lim = MAX_MOVE * min(L[la], L[lb])
                if mx * mx + my * my > lim * lim:
                    return SUSPECT, k
        else:
            sg = general_sign(P1, verts[vert_ptr[k]:vert_ptr[k + 1]], blinks[link_ptr[k]:link_ptr[k + 1]],
                              link_a, link_b, loc, M, rhs)
            if sg == 0.0 or (sg > 0.0) != (signs[k] > 0.0):
                return SIGN, k
    return OK, -1


@njit(cache=True, inline="always")
def _prepare(P0, V0, P1, V1, A1, known, kpos, kvel, kacc, radius, cx, cy, c, s):
    """Start a step: copy the state, and put the crank tip at angle (cos c, sin s) with its rates."""
    nv = P0.shape[0]
    for v in range(nv):
        P1[v, 0] = P0[v, 0]
        P1[v, 1] = P0[v, 1]
        V1[v, 0] = V0[v, 0]
        V1[v, 1] = V0[v, 1]
    tip = known[0]
    kpos[0, 0] = cx + radius * c
    kpos[0, 1] = cy + radius * s
    kvel[0, 0] = -radius * s
    kvel[0, 1] = radius * c
    kacc[0, 0] = -radius * c
    kacc[0, 1] = -radius * s
    P1[tip, 0] = kpos[0, 0]
    P1[tip, 1] = kpos[0, 1]
    V1[tip, 0] = kvel[0, 0]
    V1[tip, 1] = kvel[0, 1]
    A1[tip, 0] = kacc[0, 0]
    A1[tip, 1] = kacc[0, 1]


@njit(cache=True)
def _advance(method, kind, vert_ptr, verts, link_ptr, blinks, link_a, link_b, known, kpos, kvel, kacc,
             L, radius, cx, cy, c, s, h, hp, P0, V0, Vp, P1, V1, A1, want_acc, signs, tol, maxit, checks,
             loc, M, rhs):
    """Solve the configuration at crank angle (cos c, sin s) from the state P0/V0 a step h earlier.

    Returns (code, block, iterations) with the first block that reported trouble (−1 if none).
    """
    _prepare(P0, V0, P1, V1, A1, known, kpos, kvel, kacc, radius, cx, cy, c, s)
    if method == BLOCK:
        return _advance_blocks(kind, vert_ptr, verts, link_ptr, blinks, link_a, link_b, L, h, hp, P0, V0, Vp,
                               P1, V1, A1, want_acc, signs, tol, maxit, checks, loc, M, rhs)
    code, iters = solve_dense(P0, V0, Vp, P1, V1, A1, link_a, link_b, L, known, kpos, kvel, kacc, h, hp,
                              tol, maxit, want_acc, M, rhs)
    if code != OK:
        # tell a design that cannot assemble here from one where Newton merely failed
        _prepare(P0, V0, P1, V1, A1, known, kpos, kvel, kacc, radius, cx, cy, c, s)
        c2, b2, _ = _advance_blocks(kind, vert_ptr, verts, link_ptr, blinks, link_a, link_b, L, h, hp, P0, V0,
                                    Vp, P1, V1, A1, False, signs, tol, maxit, False, loc, M, rhs)
        if c2 == INFEASIBLE:
            return INFEASIBLE, b2, iters
        return NOCONV, -1, iters
    code, blk = _check_dense(kind, vert_ptr, verts, link_ptr, blinks, link_a, link_b, L, h, P0, V0, P1, V1,
                             signs, checks, loc, M, rhs)
    return code, blk, iters


@njit(cache=True)
def run_cycle(method, kind, vert_ptr, verts, link_ptr, blinks, link_a, link_b, known, fixed_pos, L, radius,
              cx, cy, P_init, signs, cth, sth, tol, maxit, out_idx, want_vel, want_acc, out_pos, out_vel,
              out_acc):
    """Solve one design over a full crank cycle of S = len(cth) samples (θ_k = 2πk/S).

    P_init (n_vertices, 2) is the starting point of the θ = 0 Newton solve; ``signs`` (n_blocks,) the
    branch each block must keep. Writes out_pos[k, j] = position of vertex out_idx[j] at θ_k, and
    likewise out_vel / out_acc when asked (NaN from the failure on). Returns
    (status, failure angle in radians or NaN, failing block or −1, total Newton iterations).
    """
    S = cth.shape[0]
    nv = P_init.shape[0]
    nk = known.shape[0]
    nout = out_idx.shape[0]
    n = 2 * nv
    loc = np.full(nv, -1, dtype=np.int64)
    M = np.empty((n, n))
    rhs = np.empty(n)
    kpos = np.zeros((nk, 2))
    kvel = np.zeros((nk, 2))
    kacc = np.zeros((nk, 2))
    for i in range(1, nk):
        kpos[i, 0] = fixed_pos[i - 1, 0]
        kpos[i, 1] = fixed_pos[i - 1, 1]
    P0 = P_init.copy()
    V0 = np.zeros((nv, 2))
    Vp = np.zeros((nv, 2))
    A0 = np.zeros((nv, 2))
    P1 = np.zeros((nv, 2))
    V1 = np.zeros((nv, 2))
    A1 = np.zeros((nv, 2))
    shortest = np.inf
    for e in range(L.shape[0]):
        shortest = min(shortest, L[e])

    status = STATUS_OK
    fail_theta = np.nan
    fail_block = -1
    iters = 0
    filled = 0
    ok = math.isfinite(radius) and radius > 0.0
    for e in range(L.shape[0]):
        ok = ok and math.isfinite(L[e]) and L[e] > 0.0
    if not ok:
        status = STATUS_INVALID
        fail_theta = 0.0
    else:
        code, blk, it = _advance(method, kind, vert_ptr, verts, link_ptr, blinks, link_a, link_b, known, kpos,
                                 kvel, kacc, L, radius, cx, cy, cth[0], sth[0], 0.0, 0.0, P0, V0, Vp, P1, V1,
                                 A1, want_acc, signs, tol, maxit, False, loc, M, rhs)
        iters += it
        if code != OK:
            status = _status_of(code)
            fail_theta = 0.0
            fail_block = blk
        else:
            P0, P1 = P1, P0
            V0, V1 = V1, V0
            A0, A1 = A1, A0
            Vp[:, :] = V0
    if status == STATUS_OK:
        P_first = P0.copy()
        dth = 2.0 * np.pi / S
        hmin = dth / 2.0 ** REFINE_LEVELS
        hp = 0.0
        for k in range(S + 1):
            if k < S:
                for j in range(nout):
                    v = out_idx[j]
                    out_pos[k, j, 0] = P0[v, 0]
                    out_pos[k, j, 1] = P0[v, 1]
                    if want_vel:
                        out_vel[k, j, 0] = V0[v, 0]
                        out_vel[k, j, 1] = V0[v, 1]
                    if want_acc:
                        out_acc[k, j, 0] = A0[v, 0]
                        out_acc[k, j, 1] = A0[v, 1]
                filled = k + 1
            if k == S:
                break
            # advance θ_k → θ_{k+1}, halving the step where trouble is reported
            theta = k * dth
            target = (k + 1) * dth
            hs = dth
            while True:
                last = theta + hs >= target - 0.5 * hmin
                h = target - theta if last else hs
                if last and k + 1 < S:
                    c = cth[k + 1]
                    s = sth[k + 1]
                else:
                    c = math.cos(theta + h)
                    s = math.sin(theta + h)
                strict = h > 1.5 * hmin
                if method == BLOCK:
                    _prepare(P0, V0, P1, V1, A1, known, kpos, kvel, kacc, radius, cx, cy, c, s)
                    code, blk, it = _advance_blocks(kind, vert_ptr, verts, link_ptr, blinks, link_a, link_b, L, h,
                                                    hp, P0, V0, Vp, P1, V1, A1, want_acc, signs, tol, maxit, strict,
                                                    loc, M, rhs)
                else:
                    code, blk, it = _advance(method, kind, vert_ptr, verts, link_ptr, blinks, link_a, link_b, known,
                                             kpos, kvel, kacc, L, radius, cx, cy, c, s, h, hp, P0, V0, Vp, P1, V1,
                                             A1, want_acc, signs, tol, maxit, strict, loc, M, rhs)
                iters += it
                if code == OK:
                    P0, P1 = P1, P0
                    Vp, V0, V1 = V0, V1, Vp
                    A0, A1 = A1, A0
                    hp = h
                    theta += h
                    if last:
                        break
                    hs = min(2.0 * hs, dth)
                elif strict:
                    hs = 0.5 * h
                else:
                    status = _status_of(code)
                    fail_theta = theta + h
                    fail_block = blk
                    break
            if status != STATUS_OK:
                break
        if status == STATUS_OK:
            # the cycle must close on the configuration it started from
            gap = 0.0
            for v in range(nv):
                gap = max(gap, abs(P0[v, 0] - P_first[v, 0]) + abs(P0[v, 1] - P_first[v, 1]))
            if gap > max(1e-4, 10.0 * tol) * shortest:
                status = STATUS_BRANCH
                fail_theta = 2.0 * np.pi
    for k in range(filled, S):
        for j in range(nout):
            for ax in range(2):
                out_pos[k, j, ax] = np.nan
                if want_vel:
                    out_vel[k, j, ax] = np.nan
                if want_acc:
                    out_acc[k, j, ax] = np.nan
    return status, fail_theta, fail_block, iters


@njit(cache=True)
def _status_of(code):
    if code == INFEASIBLE:
        return STATUS_ASSEMBLY
    if code == SIGN:
        return STATUS_BRANCH
    return STATUS_NOCONV  # NOCONV, or SUSPECT that never resolved


@njit(parallel=True, cache=True)
def cycle_batch_jit(method, kind, vert_ptr, verts, link_ptr, blinks, link_a, link_b, known, fixed_pos,
                    lengths, radius, cx, cy, P_init, signs, cth, sth, tol, maxit, out_idx, want_vel, want_acc,
                    out_pos, out_vel, out_acc, status, fail_theta, fail_block, iters):
    """Run :func:`run_cycle` for every row of ``lengths`` (N, n_links) / ``radius`` (N,) in parallel.

    Outputs are written in place: out_pos (N, S, n_out, 2); out_vel, out_acc the same shape when
    asked for (else (N, 0, n_out, 2), untouched); status, fail_theta, fail_block, iters (N,).
    """
    for i in prange(lengths.shape[0]):
        st, th, bl, it = run_cycle(method, kind, vert_ptr, verts, link_ptr, blinks, link_a, link_b, known,
                                   fixed_pos, lengths[i], radius[i], cx, cy, P_init, signs, cth, sth, tol, maxit,
                                   out_idx, want_vel, want_acc, out_pos[i], out_vel[i], out_acc[i])
        status[i] = st
        fail_theta[i] = th
        fail_block[i] = bl
        iters[i] = it
