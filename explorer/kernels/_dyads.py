"""The fast path: block Newton for plans made only of dyads (the Jansen leg, four-bars, most legs).

Same method, checks and results as the generic driver in ``_cycle`` (which it is tested against),
specialised for speed: per variant, each dyad's vertex, parents and squared lengths sit in flat
tables; the step loop is scalar code with no state copies (fixed vertices are written once, the
crank tip and each placed vertex once per step); nothing of the dense or general-block machinery is
compiled in, so this kernel also compiles in a fraction of the time.
"""

import math

import numpy as np
from numba import njit, prange

from ._blocks import GAP_MARGIN, INFEASIBLE, MAX_MOVE, NOCONV, OK, SIGN, SUSPECT, _hermite_extremes
from ._cycle import REFINE_LEVELS, STATUS_BRANCH, STATUS_INVALID, STATUS_OK, _status_of


@njit(cache=True, inline="always")
def _place_tip(P1, V1, A1, tip, radius, cx, cy, c, s):
    P1[tip, 0] = cx + radius * c
    P1[tip, 1] = cy + radius * s
    V1[tip, 0] = -radius * s
    V1[tip, 1] = radius * c
    A1[tip, 0] = -radius * c
    A1[tip, 1] = -radius * s


@njit(cache=True, inline="always")
def _accept(moving, P0, V0, Vp, A0, P1, V1, A1, want_acc):
    """Make the trial state (P1, V1, A1) current, keeping the previous tangent in Vp (copies, not swaps:
    rebinding arrays costs atomic reference counting in the hot loop)."""
    for i in range(moving.shape[0]):
        v = moving[i]
        for ax in range(2):
            Vp[v, ax] = V0[v, ax]
            V0[v, ax] = V1[v, ax]
            P0[v, ax] = P1[v, ax]
            if want_acc:
                A0[v, ax] = A1[v, ax]


@njit(cache=True)
def _gap_exact(q0, m0, q1, m1, h, hi_lim, lo_lim):
    lo, hi = _hermite_extremes(q0, m0, q1, m1, h)
    return hi >= hi_lim * (1.0 - GAP_MARGIN) or lo <= lo_lim * (1.0 + GAP_MARGIN)


@njit(cache=True, inline="always")
def _dyad_step(dv, dpa, dpb, da2, db2, hi2, lo2, lim2, signs, P0, V0, Vp, P1, V1, A1, h, hp, tol, maxit,
               want_acc, checks):
    """Place every dyad in order at the new crank angle (tip already in P1). Returns (code, dyad, iterations)."""
    iters = 0
    c2 = 0.5 * h * h / hp if hp > 0.0 else 0.0
    for k in range(dv.shape[0]):
        v = dv[k]
        a = dpa[k]
        b = dpb[k]
        ax = P1[a, 0]
        ay = P1[a, 1]
        bx = P1[b, 0]
        by = P1[b, 1]
        gx = bx - ax
        gy = by - ay
        q1 = gx * gx + gy * gy
        if q1 > hi2[k] or q1 < lo2[k]:
            return INFEASIBLE, k, iters
        if checks:
            # may the parents' distance leave the assembly range between the two samples?
            ux = P0[b, 0] - P0[a, 0]
            uy = P0[b, 1] - P0[a, 1]
            q0 = ux * ux + uy * uy
            m0 = 2.0 * (ux * (V0[b, 0] - V0[a, 0]) + uy * (V0[b, 1] - V0[a, 1]))
            m1 = 2.0 * (gx * (V1[b, 0] - V1[a, 0]) + gy * (V1[b, 1] - V1[a, 1]))
            ext = (4.0 / 27.0) * h * (abs(m0) + abs(m1))
            if max(q0, q1) + ext >= hi2[k] * (1.0 - GAP_MARGIN) or min(q0, q1) - ext <= lo2[k] * (1.0 + GAP_MARGIN):
                if _gap_exact(q0, m0, q1, m1, h, hi2[k], lo2[k]):
                    return SUSPECT, k, iters
        mx = h * V0[v, 0] + c2 * (V0[v, 0] - Vp[v, 0])
        my = h * V0[v, 1] + c2 * (V0[v, 1] - Vp[v, 1])
        if checks and mx * mx + my * my > lim2[k]:
            return SUSPECT, k, iters
        px = P0[v, 0] + mx
        py = P0[v, 1] + my
        pxp = px
        pyp = py
        ta = tol * da2[k]
        tb = tol * db2[k]
        it = 0
        while True:
            ex = px - ax
            ey = py - ay
            fx = px - bx
            fy = py - by
            ra = ex * ex + ey * ey - da2[k]
            rb = fx * fx + fy * fy - db2[k]
            det = ex * fy - ey * fx
            if abs(ra) <= ta and abs(rb) <= tb:
                break
            if it >= maxit or det == 0.0:
                return NOCONV, k, iters + it
            inv = 0.5 / det
            dx = (ey * rb - ra * fy) * inv
            dy = (fx * ra - ex * rb) * inv
            n2 = dx * dx + dy * dy
            if n2 > 4.0 * lim2[k]:
                sc = 2.0 * math.sqrt(lim2[k] / n2)
                dx *= sc
                dy *= sc
            px += dx
            py += dy
            it += 1
        iters += it
        # det = cross(p − a, p − b) = cross(b − a, p − a): the orientation, i.e. the branch sign
        if det == 0.0 or (signs[k] != 0.0 and (det > 0.0) != (signs[k] > 0.0)):
            return SIGN, k, iters
        if checks:
            mx = px - pxp
            my = py - pyp
            if mx * mx + my * my > lim2[k]:
                return SUSPECT, k, iters
        P1[v, 0] = px
        P1[v, 1] = py
        inv = 1.0 / det
        r1 = ex * V1[a, 0] + ey * V1[a, 1]
        r2 = fx * V1[b, 0] + fy * V1[b, 1]
        vx = (r1 * fy - ey * r2) * inv
        vy = (ex * r2 - fx * r1) * inv
        V1[v, 0] = vx
        V1[v, 1] = vy
        if want_acc:
            wax = vx - V1[a, 0]
            way = vy - V1[a, 1]
            wbx = vx - V1[b, 0]
            wby = vy - V1[b, 1]
            s1 = ex * A1[a, 0] + ey * A1[a, 1] - (wax * wax + way * way)
            s2 = fx * A1[b, 0] + fy * A1[b, 1] - (wbx * wbx + wby * wby)
            A1[v, 0] = (s1 * fy - ey * s2) * inv
            A1[v, 1] = (ex * s2 - fx * s1) * inv
    return OK, -1, iters


@njit(cache=True)
def dyad_cycle(dv, dpa, dpb, dla, dlb, tip, fixed, fixed_pos, L, radius, cx, cy, P_init, signs, cth, sth, tol,
               maxit, out_idx, want_vel, want_acc, out_pos, out_vel, out_acc):
    """One design over a full crank cycle; arguments and results as ``_cycle.run_cycle``.

    dv, dpa, dpb, dla, dlb (n_dyads,): each dyad's placed vertex, parent vertices and the two links.
    """
    S = cth.shape[0]
    nv = P_init.shape[0]
    nd = dv.shape[0]
    nout = out_idx.shape[0]
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
    da2 = np.empty(nd)
    db2 = np.empty(nd)
    hi2 = np.empty(nd)
    lo2 = np.empty(nd)
    lim2 = np.empty(nd)
    shortest = np.inf
    for k in range(nd):
        d1 = L[dla[k]]
        d2 = L[dlb[k]]
        da2[k] = d1 * d1
        db2[k] = d2 * d2
        hi2[k] = (d1 + d2) * (d1 + d2)
        lo2[k] = (d1 - d2) * (d1 - d2)
        lim2[k] = (MAX_MOVE * min(d1, d2)) ** 2
        shortest = min(shortest, d1, d2)
    moving = np.empty(nd + 1, dtype=np.int64)  # the rows a step changes: the crank tip and every dyad
    moving[0] = tip
    moving[1:] = dv
    P0 = P_init.copy()
    P1 = P_init.copy()
    V0 = np.zeros((nv, 2))
    V1 = np.zeros((nv, 2))
    Vp = np.zeros((nv, 2))
    A0 = np.zeros((nv, 2))
    A1 = np.zeros((nv, 2))
    for i in range(fixed.shape[0]):
        for ax in range(2):
            P0[fixed[i], ax] = fixed_pos[i, ax]
            P1[fixed[i], ax] = fixed_pos[i, ax]
    if status == STATUS_OK:
        _place_tip(P1, V1, A1, tip, radius, cx, cy, cth[0], sth[0])
        code, blk, it = _dyad_step(dv, dpa, dpb, da2, db2, hi2, lo2, lim2, signs, P0, V0, Vp, P1, V1, A1, 0.0,
                                   0.0, tol, maxit, want_acc, False)
        iters += it
        if code != OK:
            status = _status_of(code)
            fail_theta = 0.0
            fail_block = blk
        else:
            _accept(moving, P0, V0, Vp, A0, P1, V1, A1, want_acc)
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
            else:
                break
            theta = k * dth
            target = (k + 1) * dth
            hs = dth
            while True:
                last = theta + hs >= target - 0.5 * hmin
                h = target - theta if last else hs
                if last and k + 1 < S:
                    _place_tip(P1, V1, A1, tip, radius, cx, cy, cth[k + 1], sth[k + 1])
                else:
                    _place_tip(P1, V1, A1, tip, radius, cx, cy, math.cos(theta + h), math.sin(theta + h))
                strict = h > 1.5 * hmin
                code, blk, it = _dyad_step(dv, dpa, dpb, da2, db2, hi2, lo2, lim2, signs, P0, V0, Vp, P1, V1, A1,
                                           h, hp, tol, maxit, want_acc, strict)
                iters += it
                if code == OK:
                    _accept(moving, P0, V0, Vp, A0, P1, V1, A1, want_acc)
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


@njit(parallel=True, cache=True)
def dyad_batch_jit(dv, dpa, dpb, dla, dlb, tip, fixed, fixed_pos, lengths, radius, cx, cy, P_init, signs, cth, sth,
                   tol, maxit, out_idx, want_vel, want_acc, out_pos, out_vel, out_acc, status, fail_theta,
                   fail_block, iters):
    """:func:`dyad_cycle` for every row of ``lengths`` (N, n_links) / ``radius`` (N,), in parallel; outputs as ``cycle_batch_jit``."""
    for i in prange(lengths.shape[0]):
        st, th, bl, it = dyad_cycle(dv, dpa, dpb, dla, dlb, tip, fixed, fixed_pos, lengths[i], radius[i], cx, cy,
                                    P_init, signs, cth, sth, tol, maxit, out_idx, want_vel, want_acc, out_pos[i],
                                    out_vel[i], out_acc[i])
        status[i] = st
        fail_theta[i] = th
        fail_block[i] = bl
        iters[i] = it
