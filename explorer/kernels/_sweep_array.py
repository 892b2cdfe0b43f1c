"""The sweep's array form: rendered from ``_sweep_template`` by ``_sweep.array_module_source``; do not edit.

Edit the template (``_sweep_template.sweep``) or the array dialect (``_sweep.ARRAY``), then rewrite
this file: ``python -c "from explorer.kernels import _sweep; _sweep.write_array_module()"``
(tests/test_sweep_template.py fails while it differs from a fresh rendering). ``_sweep._specialise``
jits copies of :func:`sweep` with the global ``step`` bound to a step function.
"""

import numpy as np

from explorer.kinds._common import SUSPECT
from ._drive import drive
from ._sweep_template import MAX_FORCED, MAX_FORCED_SPAN, REFINE_LEVELS, STATUS_BRANCH, STATUS_OK, status_of

# The step function the sweep calls; _sweep._specialise binds it in each jitted copy.
step = None


def sweep(ctx, topo, drv, opts, P_init, restart_at, restart_pos, signs, cx, cy, scale, shortest, tol, out_pos, out_vel,
          out_acc):
    """Solve one design at every sample of its driver, writing the requested rows.

    ctx: the step's context (a block table, or a ``GenericContext``); topo, drv, opts: the
    ``_inputs`` Topology, Drive and Options. The driver's S samples are t_k = k·t_end/S (closed: a
    crank, t_end = 2π) or k·t_end/(S−1) (open: a path from 0 to t_end). P_init (n_vertices, 2):
    start of the first Newton solve (the design assembled on the nominal's branch where the closed form
    can, ``_batch.setup``). restart_at (2,) int64, restart_pos (2 or 0, n_vertices, 2): where the
    vectorised first pass (``_vector``) left off, forward and backward (0: nowhere), and its
    configurations there (see below). signs (n_blocks,): the
    branch each block keeps. (cx, cy), scale: the design's crank centre and radius. shortest: its
    shortest dyad length; tol: Newton's stopping distance (model units).
    out_pos[k, j] = position of vertex topo.out_idx[j] at sample k, likewise out_vel (d/dparameter)
    and out_acc when asked; NaN where not reached. Returns (status, failure parameter or NaN, end of the
    unreachable range or NaN, failing block or −1, total Newton iterations).

    One loop makes every move, so the step is inlined (and compiled) once: phase 0 solves sample 0
    (a zero step from P_init, checks off), phase 1 steps forward, and phase 2, after a crank cycle
    fails, steps backward from θ = 0 to the other end of the reachable range.

    Resuming (method "auto"): where the first pass solved samples 0 … restart_at[0] exactly (closed-form
    roots that passed its every check, already in the outputs), the forward sweep resumes at sample
    restart_at[0] from restart_pos[0] (a zero move there, as at sample 0), and where it solved samples
    restart_at[1] … S−1 and the step back to θ = 2π, the backward sweep resumes at restart_at[1]
    from restart_pos[1]. Every failure is still found, located and reported by this sweep; should a
    resumed configuration not solve, the sweep goes the whole way from sample 0 instead.
    """
    tip = topo.tip
    moving = topo.moving
    out_idx = topo.out_idx
    maxit = opts.maxit
    want_vel = opts.want_vel
    want_acc = opts.want_acc
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
    kf = restart_at[0]
    kb = restart_at[1]
    kind = drv.kind
    prm = drv.prm
    T = drv.table
    t_end = drv.t_end
    closed = drv.closed
    S = T.shape[0]
    dt = t_end / S if closed else t_end / (S - 1)
    dmin = dt / 2.0 ** REFINE_LEVELS
    n_steps = S if closed else S - 1
    status = STATUS_OK
    fail_t = np.nan
    fail_end = np.nan
    fail_block = -1
    iters = 0
    reached = 0  # samples 0 .. reached-1 are solved going forward
    back = S  # samples back .. S-1 are solved going backward (crank cycles that fail)
    hp = 0.0  # the last step taken (the predictor's curvature term needs it)
    phase = 0
    k = 0
    kr = 0  # the sample a resume (phase 3) solves, and the phase it goes on in
    then = 1
    while True:  # one move per pass, from parameter t0 to t1 (either direction)
        if phase == 0:
            t0 = 0.0
            t1 = 0.0
            row = 0
        elif phase == 3:
            t0 = kr * dt
            t1 = t0
            row = kr
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
            if last:
                P1[tip, 0] = cx + scale * T[row, 0]
                P1[tip, 1] = cy + scale * T[row, 1]
                V1[tip, 0] = scale * T[row, 2]
                V1[tip, 1] = scale * T[row, 3]
                A1[tip, 0] = scale * T[row, 4]
                A1[tip, 1] = scale * T[row, 5]
            else:
                drive(kind, prm, t + h, d)
                P1[tip, 0] = cx + scale * d[0]
                P1[tip, 1] = cy + scale * d[1]
                V1[tip, 0] = scale * d[2]
                V1[tip, 1] = scale * d[3]
                A1[tip, 0] = scale * d[4]
                A1[tip, 1] = scale * d[5]
            checks = abs(h) > 1.5 * dmin
            code, blk, it = step(ctx, signs, P0, V0, Vp, P1, V1, A1, h, hp, tol, maxit, want_acc, checks)
            iters += it
            if code == 0:
                if not checks:
                    forced += 1
                    if forced > max_forced:  # sitting on a toggle for a stretch: no trustworthy continuation
                        code = SUSPECT
                        break
                for m in range(moving.shape[0]):
                    v = moving[m]
                    for ax in range(2):
                        Vp[v, ax] = V0[v, ax]
                        V0[v, ax] = V1[v, ax]
                        P0[v, ax] = P1[v, ax]
                        if want_acc:
                            A0[v, ax] = A1[v, ax]
                hp = h
                t += h
                if last:
                    break
                hs = 2.0 * hs if abs(2.0 * hs) <= abs(span) else span
            elif checks:
                hs = 0.5 * h
            else:
                break
        ok = code == 0
        tf = t + h  # where a failed move failed (t is the last parameter reached)
        sample = -1  # the sample this move reached, if it is to be stored
        if phase == 3:
            phase = then
            if not ok:  # the resumed configuration did not solve: the whole way from sample 0 instead
                for v in range(nv):
                    for ax in range(2):
                        P0[v, ax] = P_first[v, ax]
                        V0[v, ax] = V_first[v, ax]
                        Vp[v, ax] = V_first[v, ax]
                        A0[v, ax] = A_first[v, ax]
                hp = 0.0
                k = 0 if then == 1 else S - 1
                continue
            sample = kr
            if then == 1:
                k = kr
                reached = kr + 1
            else:
                k = kr - 1
                back = kr
            for j in range(out_idx.shape[0]):
                v = out_idx[j]
                for ax in range(2):
                    out_pos[sample, j, ax] = P0[v, ax]
                    if want_vel:
                        out_vel[sample, j, ax] = V0[v, ax]
                    if want_acc:
                        out_acc[sample, j, ax] = A0[v, ax]
            continue
        if not ok and phase < 2:
            status = status_of(code)
            fail_t = tf  # 0 when sample 0 itself fails
            fail_block = blk
            if phase == 0 or not closed:
                break
            # the other end of the reachable range: sweep clockwise from θ = 0
            for v in range(nv):
                for ax in range(2):
                    P0[v, ax] = P_first[v, ax]
                    V0[v, ax] = V_first[v, ax]
                    Vp[v, ax] = V_first[v, ax]
                    A0[v, ax] = A_first[v, ax]
            hp = 0.0
            fail_end = fail_t
            phase = 2
            k = S - 1
            if kb > reached:  # resume the backward sweep where the first pass left off
                for m in range(moving.shape[0]):
                    v = moving[m]
                    for ax in range(2):
                        P0[v, ax] = restart_pos[1, v, ax]
                        V0[v, ax] = 0.0
                        Vp[v, ax] = 0.0
                        A0[v, ax] = 0.0
                kr = kb
                then = 2
                phase = 3
            continue
        if phase == 0:
            for v in range(nv):
                for ax in range(2):
                    Vp[v, ax] = V0[v, ax]
                    P_first[v, ax] = P0[v, ax]
                    V_first[v, ax] = V0[v, ax]
                    A_first[v, ax] = A0[v, ax]
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
            for j in range(out_idx.shape[0]):
                v = out_idx[j]
                for ax in range(2):
                    out_pos[sample, j, ax] = P0[v, ax]
                    if want_vel:
                        out_vel[sample, j, ax] = V0[v, ax]
                    if want_acc:
                        out_acc[sample, j, ax] = A0[v, ax]
        if sample == 0 and kf > 0:  # resume the forward sweep where the first pass left off
            for m in range(moving.shape[0]):
                v = moving[m]
                for ax in range(2):
                    P0[v, ax] = restart_pos[0, v, ax]
                    V0[v, ax] = 0.0
                    Vp[v, ax] = 0.0
                    A0[v, ax] = 0.0
            hp = 0.0
            kr = kf
            then = 1
            phase = 3
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


def sweep_resumable(ctx, topo, drv, opts, P_init, restart_at, restart_pos, signs, cx, cy, scale, shortest, tol,
                    out_pos, out_vel, out_acc, P0, V0, Vp, A0, P1, V1, A1, P_first, V_first, A_first, d, si, sf):
    """The sweep (:func:`sweep`, the same arguments first) that leaves the loop of whole steps to its caller
    (``_sweep.RESUMABLE``); the state in the arrays after ``out_acc`` (each (n_vertices, 2)), d (6,), si
    (SLOTS[0],) int64, sf (SLOTS[1],) float64. Returns (1, ...) where the caller takes the whole steps, else (0,
    status, fail_t, fail_end, fail_block, iters).
    """
    tip = topo.tip
    moving = topo.moving
    out_idx = topo.out_idx
    maxit = opts.maxit
    want_vel = opts.want_vel
    want_acc = opts.want_acc
    nv = P_init.shape[0]
    resumed = si[0] != 0
    if not resumed:
        for v in range(nv):
            for ax in range(2):
                P0[v, ax] = P_init[v, ax]
                P1[v, ax] = P_init[v, ax]
                V0[v, ax] = 0.0
                V1[v, ax] = 0.0
                Vp[v, ax] = 0.0
                A0[v, ax] = 0.0
                A1[v, ax] = 0.0
    kf = restart_at[0]
    kb = restart_at[1]
    kind = drv.kind
    prm = drv.prm
    T = drv.table
    t_end = drv.t_end
    closed = drv.closed
    S = T.shape[0]
    dt = t_end / S if closed else t_end / (S - 1)
    dmin = dt / 2.0 ** REFINE_LEVELS
    n_steps = S if closed else S - 1
    status = STATUS_OK
    fail_t = np.nan
    fail_end = np.nan
    fail_block = -1
    iters = 0
    reached = 0  # samples 0 .. reached-1 are solved going forward
    back = S  # samples back .. S-1 are solved going backward (crank cycles that fail)
    hp = 0.0  # the last step taken (the predictor's curvature term needs it)
    phase = 0
    k = 0
    kr = 0  # the sample a resume (phase 3) solves, and the phase it goes on in
    then = 1
    if resumed:
        status = si[1]
        fail_block = si[2]
        iters = si[3]
        reached = si[4]
        back = si[5]
        phase = si[6]
        k = si[7]
        kr = si[8]
        then = si[9]
        hp = sf[0]
        fail_t = sf[1]
        fail_end = sf[2]
    while True:  # one move per pass, from parameter t0 to t1 (either direction)
        if phase == 0:
            t0 = 0.0
            t1 = 0.0
            row = 0
        elif phase == 3:
            t0 = kr * dt
            t1 = t0
            row = kr
        elif phase == 1:
            if resumed:  # the caller has just taken the whole steps
                resumed = False
            else:
                si[0] = 1
                si[1] = status
                si[2] = fail_block
                si[3] = iters
                si[4] = reached
                si[5] = back
                si[6] = phase
                si[7] = k
                si[8] = kr
                si[9] = then
                si[10] = n_steps
                si[11] = S
                sf[0] = hp
                sf[1] = fail_t
                sf[2] = fail_end
                sf[3] = dt
                sf[4] = dmin
                return 1, status, fail_t, fail_end, fail_block, iters
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
            if last:
                P1[tip, 0] = cx + scale * T[row, 0]
                P1[tip, 1] = cy + scale * T[row, 1]
                V1[tip, 0] = scale * T[row, 2]
                V1[tip, 1] = scale * T[row, 3]
                A1[tip, 0] = scale * T[row, 4]
                A1[tip, 1] = scale * T[row, 5]
            else:
                drive(kind, prm, t + h, d)
                P1[tip, 0] = cx + scale * d[0]
                P1[tip, 1] = cy + scale * d[1]
                V1[tip, 0] = scale * d[2]
                V1[tip, 1] = scale * d[3]
                A1[tip, 0] = scale * d[4]
                A1[tip, 1] = scale * d[5]
            checks = abs(h) > 1.5 * dmin
            code, blk, it = step(ctx, signs, P0, V0, Vp, P1, V1, A1, h, hp, tol, maxit, want_acc, checks)
            iters += it
            if code == 0:
                if not checks:
                    forced += 1
                    if forced > max_forced:  # sitting on a toggle for a stretch: no trustworthy continuation
                        code = SUSPECT
                        break
                for m in range(moving.shape[0]):
                    v = moving[m]
                    for ax in range(2):
                        Vp[v, ax] = V0[v, ax]
                        V0[v, ax] = V1[v, ax]
                        P0[v, ax] = P1[v, ax]
                        if want_acc:
                            A0[v, ax] = A1[v, ax]
                hp = h
                t += h
                if last:
                    break
                hs = 2.0 * hs if abs(2.0 * hs) <= abs(span) else span
            elif checks:
                hs = 0.5 * h
            else:
                break
        ok = code == 0
        tf = t + h  # where a failed move failed (t is the last parameter reached)
        sample = -1  # the sample this move reached, if it is to be stored
        if phase == 3:
            phase = then
            if not ok:  # the resumed configuration did not solve: the whole way from sample 0 instead
                for v in range(nv):
                    for ax in range(2):
                        P0[v, ax] = P_first[v, ax]
                        V0[v, ax] = V_first[v, ax]
                        Vp[v, ax] = V_first[v, ax]
                        A0[v, ax] = A_first[v, ax]
                hp = 0.0
                k = 0 if then == 1 else S - 1
                continue
            sample = kr
            if then == 1:
                k = kr
                reached = kr + 1
            else:
                k = kr - 1
                back = kr
            for j in range(out_idx.shape[0]):
                v = out_idx[j]
                for ax in range(2):
                    out_pos[sample, j, ax] = P0[v, ax]
                    if want_vel:
                        out_vel[sample, j, ax] = V0[v, ax]
                    if want_acc:
                        out_acc[sample, j, ax] = A0[v, ax]
            continue
        if not ok and phase < 2:
            status = status_of(code)
            fail_t = tf  # 0 when sample 0 itself fails
            fail_block = blk
            if phase == 0 or not closed:
                break
            # the other end of the reachable range: sweep clockwise from θ = 0
            for v in range(nv):
                for ax in range(2):
                    P0[v, ax] = P_first[v, ax]
                    V0[v, ax] = V_first[v, ax]
                    Vp[v, ax] = V_first[v, ax]
                    A0[v, ax] = A_first[v, ax]
            hp = 0.0
            fail_end = fail_t
            phase = 2
            k = S - 1
            if kb > reached:  # resume the backward sweep where the first pass left off
                for m in range(moving.shape[0]):
                    v = moving[m]
                    for ax in range(2):
                        P0[v, ax] = restart_pos[1, v, ax]
                        V0[v, ax] = 0.0
                        Vp[v, ax] = 0.0
                        A0[v, ax] = 0.0
                kr = kb
                then = 2
                phase = 3
            continue
        if phase == 0:
            for v in range(nv):
                for ax in range(2):
                    Vp[v, ax] = V0[v, ax]
                    P_first[v, ax] = P0[v, ax]
                    V_first[v, ax] = V0[v, ax]
                    A_first[v, ax] = A0[v, ax]
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
            for j in range(out_idx.shape[0]):
                v = out_idx[j]
                for ax in range(2):
                    out_pos[sample, j, ax] = P0[v, ax]
                    if want_vel:
                        out_vel[sample, j, ax] = V0[v, ax]
                    if want_acc:
                        out_acc[sample, j, ax] = A0[v, ax]
        if sample == 0 and kf > 0:  # resume the forward sweep where the first pass left off
            for m in range(moving.shape[0]):
                v = moving[m]
                for ax in range(2):
                    P0[v, ax] = restart_pos[0, v, ax]
                    V0[v, ax] = 0.0
                    Vp[v, ax] = 0.0
                    A0[v, ax] = 0.0
            hp = 0.0
            kr = kf
            then = 1
            phase = 3
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
    return 0, status, fail_t, fail_end, fail_block, iters
