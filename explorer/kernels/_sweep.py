"""Continuation over the driver's parameter with branch tracking and adaptive refinement.

One driver serves every solver. Its source is written once, below, against a global ``step``;
:func:`_specialise` binds that name to the fast all-dyad step or to the generic block / dense step
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

import numpy as np
from numba import njit

from ._blocks import INFEASIBLE, SIGN, SUSPECT
from ._drive import drive
import types

from ._dyads import dyad_step
from ._generic import generic_step

# Per-variant status codes (public: they are stored in results files).
STATUS_OK = 0
STATUS_ASSEMBLY = 1
STATUS_BRANCH = 2
STATUS_NOCONV = 3
STATUS_INVALID = 4

REFINE_LEVELS = 16

# The step functions the templates below call; _specialise binds both in each jitted copy.
step = first_step = None
# Steps accepted at the smallest size (with the gap and move checks off) allowed between two samples.
# Passing a fold tangentially takes a few thousand (the Hermite margin spans ~1e-3 of the parameter);
# past an eighth of the interval the design sits on a toggle over a stretch, and the sweep ends
# ("no-convergence") rather than crawl on at Δ / 2**REFINE_LEVELS.
MAX_FORCED = 2 ** (REFINE_LEVELS - 3)


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


def _advance(ctx, signs, t0, t1, tab1, tip, kind, prm, cx, cy, scale, P0, V0, Vp, A0, P1, V1, A1, moving, hp,
             dmin, tol, maxit, want_acc, d):
    """Carry the state from parameter t0 to t1 (either direction), halving where trouble is reported.

    ``tab1`` holds the driver values at t1 (6,). Returns (ok, failing parameter, block, code,
    iterations, last step taken).
    """
    span = t1 - t0
    hs = span
    t = t0
    iters = 0
    forced = 0
    while True:
        last = abs(hs) >= abs(t1 - t) - 0.5 * dmin
        h = t1 - t if last else hs
        if last:
            _place(P1, V1, A1, tip, cx, cy, scale, tab1)
        else:
            drive(kind, prm, t + h, d)
            _place(P1, V1, A1, tip, cx, cy, scale, d)
        strict = abs(h) > 1.5 * dmin
        code, blk, it = step(ctx, signs, P0, V0, Vp, P1, V1, A1, h, hp, tol, maxit, want_acc, strict)
        iters += it
        if code == 0:
            if not strict:
                forced += 1
                if forced > MAX_FORCED:  # sitting on a toggle for a stretch: no trustworthy continuation
                    return False, t + h, blk, SUSPECT, iters, hp
            _accept(moving, P0, V0, Vp, A0, P1, V1, A1, want_acc)
            hp = h
            t += h
            if last:
                return True, t, -1, 0, iters, hp
            hs = 2.0 * hs if abs(2.0 * hs) <= abs(span) else span
        elif strict:
            hs = 0.5 * h
        else:
            return False, t + h, blk, code, iters, hp


def sweep(ctx, tip, kind, prm, tab, t_end, closed, cx, cy, scale, P_init, signs, moving, shortest, tol, maxit,
          out_idx, want_vel, want_acc, out_pos, out_vel, out_acc):
    """Solve one design at every sample of its driver, writing the requested rows.

    tab (S, 6): driver values at the S samples t_k = k·t_end/S (closed: a crank, t_end = 2π) or
    k·t_end/(S−1) (open: a path from 0 to t_end). P_init (n_vertices, 2): start of the first
    Newton solve (fixed vertices already in place). signs (n_blocks,): the branch each block keeps.
    out_pos[k, j] = position of vertex out_idx[j] at sample k, likewise out_vel (d/dparameter) and
    out_acc when asked; NaN where not reached. Returns (status, failure parameter or NaN, end of the
    unreachable range or NaN, failing block or −1, total Newton iterations).
    """
    S = tab.shape[0]
    nv = P_init.shape[0]
    P0 = P_init.copy()
    P1 = P_init.copy()
    V0 = np.zeros((nv, 2))
    V1 = np.zeros((nv, 2))
    Vp = np.zeros((nv, 2))
    A0 = np.zeros((nv, 2))
    A1 = np.zeros((nv, 2))
    d = np.empty(6)
    status = STATUS_OK
    fail_t = np.nan
    fail_end = np.nan
    fail_block = -1
    dt = t_end / S if closed else t_end / (S - 1)
    dmin = dt / 2.0 ** REFINE_LEVELS

    _place(P1, V1, A1, tip, cx, cy, scale, tab[0])
    code, blk, iters = first_step(ctx, signs, P0, V0, Vp, P1, V1, A1, 0.0, 0.0, tol, maxit, want_acc, False)
    reached = 0  # samples 0 .. reached-1 are solved going forward
    back = S  # samples back .. S-1 are solved going backward (crank cycles that fail)
    if code != 0:
        status = status_of(code)
        fail_t = 0.0
        fail_block = blk
    else:
        _accept(moving, P0, V0, Vp, A0, P1, V1, A1, want_acc)
        Vp[:, :] = V0
        _store(0, out_idx, P0, V0, A0, want_vel, want_acc, out_pos, out_vel, out_acc)
        reached = 1
        P_first = P0.copy()
        V_first = V0.copy()
        A_first = A0.copy()
        hp = 0.0
        n_steps = S if closed else S - 1
        for k in range(n_steps):
            # the last step of a crank cycle returns to θ = 2π, whose driver values are sample 0's
            ok, tf, blk, code, it, hp = _advance(ctx, signs, k * dt, (k + 1) * dt, tab[(k + 1) % S], tip, kind, prm,
                                                 cx, cy, scale, P0, V0, Vp, A0, P1, V1, A1, moving, hp, dmin, tol,
                                                 maxit, want_acc, d)
            iters += it
            if not ok:
                status = status_of(code)
                fail_t = tf
                fail_block = blk
                break
            if k + 1 < S:
                _store(k + 1, out_idx, P0, V0, A0, want_vel, want_acc, out_pos, out_vel, out_acc)
                reached = k + 2
        if status == STATUS_OK and closed:
            gap = 0.0
            for v in range(nv):
                gap = max(gap, abs(P0[v, 0] - P_first[v, 0]) + abs(P0[v, 1] - P_first[v, 1]))
            if gap > max(1e-4, 10.0 * tol) * shortest:
                status = STATUS_BRANCH
                fail_t = t_end
        elif status != STATUS_OK and closed:
            # the other end of the reachable range: sweep clockwise from θ = 0
            P0[:, :] = P_first
            V0[:, :] = V_first
            Vp[:, :] = V_first
            A0[:, :] = A_first
            hp = 0.0
            # the forward failure lies in (t[reached-1], t[reached]]: sweep back into that interval
            fail_end = fail_t
            for j in range(S - 1, reached - 2, -1):
                ok, tf, blk, code, it, hp = _advance(ctx, signs, (j + 1) * dt, j * dt, tab[j], tip, kind, prm, cx, cy,
                                                     scale, P0, V0, Vp, A0, P1, V1, A1, moving, hp, dmin, tol, maxit,
                                                     want_acc, d)
                iters += it
                if not ok:
                    fail_end = tf
                    break
                if j >= reached:
                    _store(j, out_idx, P0, V0, A0, want_vel, want_acc, out_pos, out_vel, out_acc)
                    back = j
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
    """Jit a copy of :func:`sweep` (and its :func:`_advance`) whose global ``step`` is ``step_fn``.

    The step is inlined into the stepping loop, where it runs millions of times; the one solve at
    the first sample calls a plain (not inlined) copy, ``first_step``, which keeps compile time down.
    """
    env = dict(globals(), step=step_fn, first_step=njit(cache=True)(step_fn.py_func))
    for fn, opts in ((_advance, {"inline": "always"}), (sweep, {})):
        copy = types.FunctionType(fn.__code__, env, fn.__name__, fn.__defaults__, fn.__closure__)
        copy.__qualname__ = f"{fn.__name__}_{name}"
        copy.__doc__ = fn.__doc__
        env[fn.__name__] = njit(cache=True, **opts)(copy)
    return env["sweep"]


#: :func:`sweep` with the fast all-dyad step; its context comes from ``_dyads.dyad_context``.
dyad_sweep = _specialise(dyad_step, "dyad")
#: :func:`sweep` with the generic block / dense step; its context comes from ``_generic.generic_context``.
generic_sweep = _specialise(generic_step, "generic")
