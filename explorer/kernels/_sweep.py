"""Continuation over the driver's parameter with branch tracking and adaptive refinement.

One driver serves every solver. Its source is written once, below, against a global ``step``;
:func:`_specialise` binds that name to the fast DYAD / ATTACH step or to the generic block / dense step
and jits each copy under its own name, so each compiles (and caches) only the step it calls, and
calls it directly. (Passing the step as an argument instead disables caching; dispatching through
``@overload`` measured 2x slower.)

Each step between samples is tried whole. If the step function reports trouble (a branch sign
change, no convergence, an assembly failure, a possible gap between samples, or a move too large
for the local geometry) the step is retried in halves, down to Δ / 2**REFINE_LEVELS. What still
fails at that size is real: the sweep ends there, with the block and the parameter value.

A crank is periodic: after the last sample one more step returns to θ = 2π, and a cycle that does
not close on its start configuration is a branch failure. When a crank cycle fails going forward,
a second sweep runs backward from θ = 0 (clockwise) to find where the reachable range ends on the
other side; samples in between stay NaN (seed 004 leaves unreachable angles empty). A path driver
(time from 0 to T) simply ends at its first failure.
"""

import types

import numpy as np
from numba import njit

from ._blocks import INFEASIBLE, SIGN, SUSPECT
from ._drive import drive
from ._fast import fast_step
from ._step import generic_step

# Per-variant status codes (public: they are stored in results files).
STATUS_OK = 0
STATUS_ASSEMBLY = 1
STATUS_BRANCH = 2
STATUS_NOCONV = 3
STATUS_INVALID = 4

REFINE_LEVELS = 16

# The step function the templates below call; _specialise binds it in each jitted copy.
step = None
# Steps accepted at the smallest size (with the gap and move checks off) allowed between two samples.
# Passing a fold tangentially takes a few thousand (the Hermite margin spans ~1e-3 of the parameter);
# past an eighth of the interval the design sits on a toggle over a stretch, and the sweep ends
# ("no-convergence") rather than crawl on at Δ / 2**REFINE_LEVELS.
MAX_FORCED = 2 ** (REFINE_LEVELS - 3)
# ... or, where more, the steps that span this fraction of the whole driver range: a fold passed
# tangentially stays within the Hermite margin over a stretch of the parameter that does not shrink
# with the sample spacing (seed 004's arm: 3.8 ms of its 10 s, an eighth of the spacing at 360 samples).
MAX_FORCED_SPAN = 1e-3


@njit(cache=True)
def status_of(code):
    """Map a step's trouble code to the per-variant status it ends a sweep with."""
    if code == INFEASIBLE:
        return STATUS_ASSEMBLY
    if code == SIGN:
        return STATUS_BRANCH
    return STATUS_NOCONV  # NOCONV, or a SUSPECT step that never resolved


@njit(cache=True, inline="always")
def _place(P1, V1, A1, tip, cx, cy, scale, d):
    P1[tip, 0] = cx + scale * d[0]
    P1[tip, 1] = cy + scale * d[1]
    V1[tip, 0] = scale * d[2]
    V1[tip, 1] = scale * d[3]
    A1[tip, 0] = scale * d[4]
    A1[tip, 1] = scale * d[5]


@njit(cache=True, inline="always")
def _accept(moving, P0, V0, Vp, A0, P1, V1, A1, want_acc):
    """Make the trial state current and keep the previous tangent in Vp (copies, not array swaps:
    rebinding arrays costs atomic reference counting in the hot loop)."""
    for i in range(moving.shape[0]):
        v = moving[i]
        for ax in range(2):
            Vp[v, ax] = V0[v, ax]
            V0[v, ax] = V1[v, ax]
            P0[v, ax] = P1[v, ax]
            if want_acc:
                A0[v, ax] = A1[v, ax]


@njit(cache=True, inline="always")
def _store(k, out_idx, P0, V0, A0, want_vel, want_acc, out_pos, out_vel, out_acc):
    for j in range(out_idx.shape[0]):
        v = out_idx[j]
        for ax in range(2):
            out_pos[k, j, ax] = P0[v, ax]
            if want_vel:
                out_vel[k, j, ax] = V0[v, ax]
            if want_acc:
                out_acc[k, j, ax] = A0[v, ax]


@njit(cache=True)
def _copy(dst, src):
    """dst[:, :] = src for (n, 2) arrays, as a loop (a slice assignment compiles a shape-mismatch error
    message, seconds of compile time for nothing)."""
    for v in range(src.shape[0]):
        dst[v, 0] = src[v, 0]
        dst[v, 1] = src[v, 1]


def sweep(ctx, topo, drv, opts, P_init, signs, cx, cy, scale, shortest, tol, out_pos, out_vel, out_acc):
    """Solve one design at every sample of its driver, writing the requested rows.

    ctx: the step's context (a block table, or a ``GenericContext``); topo, drv, opts: the
    ``_inputs`` Topology, Drive and Options. The driver's S samples are t_k = k·t_end/S (closed: a
    crank, t_end = 2π) or k·t_end/(S−1) (open: a path from 0 to t_end). P_init (n_vertices, 2):
    start of the first Newton solve (the design assembled on the nominal's branch where the closed form
    can, ``_batch.design_setup``). signs (n_blocks,): the
    branch each block keeps. (cx, cy), scale: the design's crank centre and radius. shortest: its
    shortest dyad length; tol: Newton's stopping distance (model units).
    out_pos[k, j] = position of vertex topo.out_idx[j] at sample k, likewise out_vel (d/dparameter)
    and out_acc when asked; NaN where not reached. Returns (status, failure parameter or NaN, end of the
    unreachable range or NaN, failing block or −1, total Newton iterations).

    One loop makes every move, so the step is inlined (and compiled) once: phase 0 solves sample 0
    (a zero step from P_init, checks off), phase 1 steps forward, and phase 2, after a crank cycle
    fails, steps backward from θ = 0 to the other end of the reachable range.
    """
    tip = topo.tip
    moving = topo.moving
    out_idx = topo.out_idx
    kind = drv.kind
    prm = drv.prm
    tab = drv.table
    t_end = drv.t_end
    closed = drv.closed
    maxit = opts.maxit
    want_vel = opts.want_vel
    want_acc = opts.want_acc
    S = tab.shape[0]
    nv = P_init.shape[0]
    P0 = P_init.copy()
    P1 = P_init.copy()
    V0 = np.zeros((nv, 2))
    V1 = np.zeros((nv, 2))
    Vp = np.zeros((nv, 2))
    A0 = np.zeros((nv, 2))
    A1 = np.zeros((nv, 2))
    P_first = np.empty((nv, 2))
    V_first = np.empty((nv, 2))
    A_first = np.empty((nv, 2))
    d = np.empty(6)
    status = STATUS_OK
    fail_t = np.nan
    fail_end = np.nan
    fail_block = -1
    iters = 0
    dt = t_end / S if closed else t_end / (S - 1)
    dmin = dt / 2.0 ** REFINE_LEVELS
    n_steps = S if closed else S - 1
    reached = 0  # samples 0 .. reached-1 are solved going forward
    back = S  # samples back .. S-1 are solved going backward (crank cycles that fail)
    hp = 0.0  # the last step taken (the predictor's curvature term needs it)
    phase = 0
    k = 0
    while True:  # one move per pass, from parameter t0 to t1 (either direction)
        if phase == 0:
            t0 = 0.0
            t1 = 0.0
            row = 0
        elif phase == 1:
            if k >= n_steps:
                break
            # the last step of a crank cycle returns to θ = 2π, whose driver values are sample 0's
            t0 = k * dt
            t1 = (k + 1) * dt
            row = (k + 1) % S
        else:
            # the forward failure lies in (t[reached-1], t[reached]]: sweep back into that interval
            if k < reached - 1:
                break
            t0 = (k + 1) * dt
            t1 = k * dt
            row = k
        # the move: tried whole, halved where the step reports trouble, doubled again after success
        span = t1 - t0
        hs = span
        t = t0
        forced = 0
        max_forced = max(MAX_FORCED, int(MAX_FORCED_SPAN * t_end / dmin))
        while True:
            last = abs(hs) >= abs(t1 - t) - 0.5 * dmin
            h = t1 - t if last else hs
            if not last:
                drive(kind, prm, t + h, d)
            _place(P1, V1, A1, tip, cx, cy, scale, tab[row] if last else d)
            strict = abs(h) > 1.5 * dmin
            code, blk, it = step(ctx, signs, P0, V0, Vp, P1, V1, A1, h, hp, tol, maxit, want_acc, strict)
            iters += it
            if code == 0:
                if not strict:
                    forced += 1
                    if forced > max_forced:  # sitting on a toggle for a stretch: no trustworthy continuation
                        code = SUSPECT
                        break
                _accept(moving, P0, V0, Vp, A0, P1, V1, A1, want_acc)
                hp = h
                t += h
                if last:
                    break
                hs = 2.0 * hs if abs(2.0 * hs) <= abs(span) else span
            elif strict:
                hs = 0.5 * h
            else:
                break
        ok = code == 0
        tf = t + h  # where a failed move failed (t is the last parameter reached)
        sample = -1  # the sample this move reached, if it is to be stored
        if not ok and phase < 2:
            status = status_of(code)
            fail_t = tf  # 0 when sample 0 itself fails
            fail_block = blk
            if phase == 0 or not closed:
                break
            # the other end of the reachable range: sweep clockwise from θ = 0
            _copy(P0, P_first)
            _copy(V0, V_first)
            _copy(Vp, V_first)
            _copy(A0, A_first)
            hp = 0.0
            fail_end = fail_t
            phase = 2
            k = S - 1
            continue
        if phase == 0:
            _copy(Vp, V0)
            _copy(P_first, P0)
            _copy(V_first, V0)
            _copy(A_first, A0)
            sample = 0
            reached = 1
            phase = 1
        elif phase == 1:
            if k + 1 < S:
                sample = k + 1
                reached = k + 2
            k += 1
        else:
            if not ok:
                fail_end = tf
                break
            if k >= reached:
                sample = k
                back = k
            k -= 1
        if sample >= 0:
            _store(sample, out_idx, P0, V0, A0, want_vel, want_acc, out_pos, out_vel, out_acc)
    if status == STATUS_OK and closed:
        gap = 0.0
        for v in range(nv):
            gap = max(gap, abs(P0[v, 0] - P_first[v, 0]) + abs(P0[v, 1] - P_first[v, 1]))
        if gap > max(1e-4 * shortest, 10.0 * tol):
            status = STATUS_BRANCH
            fail_t = t_end
    for k in range(reached, back):
        for j in range(out_idx.shape[0]):
            for ax in range(2):
                out_pos[k, j, ax] = np.nan
                if want_vel:
                    out_vel[k, j, ax] = np.nan
                if want_acc:
                    out_acc[k, j, ax] = np.nan
    return status, fail_t, fail_end, fail_block, iters


def _specialise(step_fn, name: str):
    """Jit a copy of :func:`sweep` whose global ``step`` is ``step_fn``, inlined at the sweep's one call
    site, where it runs millions of times. (Inlining through an intermediate inlined function, as an
    earlier version did, made Numba copy the step's IR twice: seconds of compile time.)"""
    env = dict(globals(), step=step_fn)
    copy = types.FunctionType(sweep.__code__, env, sweep.__name__, sweep.__defaults__, sweep.__closure__)
    copy.__qualname__ = f"sweep_{name}"
    copy.__doc__ = sweep.__doc__
    return njit(cache=True)(copy)


#: :func:`sweep` with the fast DYAD / ATTACH step; its context is the design's block table (``_step.block_table``).
fast_sweep = _specialise(fast_step, "fast")
#: :func:`sweep` with the generic block / dense step; its context comes from ``_step.generic_context``.
generic_sweep = _specialise(generic_step, "generic")
