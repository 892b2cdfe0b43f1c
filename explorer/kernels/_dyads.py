"""The fast path: block Newton for plans made only of dyads (the Jansen leg, four-bars, most legs).

Same method, checks and results as the generic step in ``_generic`` (which it is tested against),
specialised for speed: per variant, each dyad's vertex, parents and squared lengths sit in flat
tables and the step is scalar code; nothing of the dense or general-block machinery is compiled in,
so this kernel also compiles in a fraction of the time.
"""

import math

import numpy as np
from numba import njit

from ._blocks import GAP_MARGIN, INFEASIBLE, MAX_MOVE, NOCONV, OK, ROUNDING, SIGN, SUSPECT, gap_suspect


# Below this |sin| of the angle at the placed vertex a dyad is at a fold (its parents' distance at
# the end of its range): both roots meet there, and keeping the branch means taking the mirror root.
FOLD_SIN = 1e-2


@njit(cache=True)
def dyad_context(dv, dpa, dpb, dla, dlb, L, dlp, tip, crank, cx, cy, scale, P_init):
    """Per-variant table of the dyad step, shape (n_dyads, 9): vertex, parent a, parent b (as floats),
    da², db², (da+db)², (da−db)², the largest move allowed per step squared, and 1.0 where the
    between-sample gap check is needed (0.0 where the parents' distance provably stays inside the
    assembly range: ``dlp`` ≥ 0 is a link joining the parents, so their distance is constant; −2 marks
    parents that are the crank tip (radius ``scale`` about (cx, cy)) and a fixed vertex, whose distance
    range is known in closed form; −1: neither).

    One array rather than a tuple: unpacking a tuple of arrays in the hot loop costs atomic
    reference counting on every step.
    """
    nd = dv.shape[0]
    ctx = np.empty((nd, 9))
    for k in range(nd):
        d1 = L[dla[k]]
        d2 = L[dlb[k]]
        ctx[k, 0] = dv[k]
        ctx[k, 1] = dpa[k]
        ctx[k, 2] = dpb[k]
        ctx[k, 3] = d1 * d1
        ctx[k, 4] = d2 * d2
        ctx[k, 5] = (d1 + d2) * (d1 + d2)
        ctx[k, 6] = (d1 - d2) * (d1 - d2)
        ctx[k, 7] = (MAX_MOVE * min(d1, d2)) ** 2
        lo = ctx[k, 6] * (1.0 + GAP_MARGIN)
        hi = ctx[k, 5] * (1.0 - GAP_MARGIN)
        qmin = -1.0
        qmax = -1.0
        if dlp[k] >= 0:
            qmin = L[dlp[k]] * L[dlp[k]]
            qmax = qmin
        elif dlp[k] == -2 and crank:
            other = dpb[k] if dpa[k] == tip else dpa[k]
            D = math.hypot(P_init[other, 0] - cx, P_init[other, 1] - cy)
            qmin = (D - scale) * (D - scale)
            qmax = (D + scale) * (D + scale)
        ctx[k, 8] = 0.0 if (qmin >= 0.0 and lo < qmin and qmax < hi) else 1.0
    return ctx


@njit(cache=True, inline="always")
def dyad_step(ctx, signs, P0, V0, Vp, P1, V1, A1, h, hp, tol, maxit, want_acc, checks):
    """Place every dyad in order at the new driver position (already in P1). Returns (code, dyad, iterations).

    A step of the sweep (see ``_sweep``): predict each vertex from P0/V0/Vp, Newton with a step
    limit until a correction no longer than ``tol`` (model units) has been applied, check assembly,
    branch sign, a gap between samples and the move; then the tangent.
    """
    iters = 0
    c2 = 0.5 * h * h / hp if hp != 0.0 else 0.0
    for k in range(ctx.shape[0]):
        v = int(ctx[k, 0])
        a = int(ctx[k, 1])
        b = int(ctx[k, 2])
        da2 = ctx[k, 3]
        db2 = ctx[k, 4]
        hi2 = ctx[k, 5]
        lo2 = ctx[k, 6]
        lim2 = ctx[k, 7]
        ax = P1[a, 0]
        ay = P1[a, 1]
        bx = P1[b, 0]
        by = P1[b, 1]
        gx = bx - ax
        gy = by - ay
        q1 = gx * gx + gy * gy
        if q1 > hi2 or q1 < lo2:
            return INFEASIBLE, k, iters
        if checks and ctx[k, 8] != 0.0:
            # may the parents' distance leave the assembly range between the two samples?
            ux = P0[b, 0] - P0[a, 0]
            uy = P0[b, 1] - P0[a, 1]
            q0 = ux * ux + uy * uy
            m0 = 2.0 * (ux * (V0[b, 0] - V0[a, 0]) + uy * (V0[b, 1] - V0[a, 1]))
            m1 = 2.0 * (gx * (V1[b, 0] - V1[a, 0]) + gy * (V1[b, 1] - V1[a, 1]))
            if gap_suspect(q0, m0, q1, m1, h, hi2, lo2):
                return SUSPECT, k, iters
        mx = h * V0[v, 0] + c2 * (V0[v, 0] - Vp[v, 0])
        my = h * V0[v, 1] + c2 * (V0[v, 1] - Vp[v, 1])
        if checks and mx * mx + my * my > lim2:
            return SUSPECT, k, iters
        px = P0[v, 0] + mx
        py = P0[v, 1] + my
        pxp = px
        pyp = py
        tol2 = tol * tol
        it = 0
        while True:
            ex = px - ax
            ey = py - ay
            fx = px - bx
            fy = py - by
            ra = ex * ex + ey * ey - da2
            rb = fx * fx + fy * fy - db2
            det = ex * fy - ey * fx
            if abs(ra) <= ROUNDING * da2 and abs(rb) <= ROUNDING * db2:
                break  # as exact as floating point allows (matters only next to a fold)
            if it >= maxit or det == 0.0:
                return NOCONV, k, iters + it
            inv = 0.5 / det
            dx = (ey * rb - ra * fy) * inv
            dy = (fx * ra - ex * rb) * inv
            n2 = dx * dx + dy * dy
            if n2 > 4.0 * lim2:
                sc = 2.0 * math.sqrt(lim2 / n2)
                dx *= sc
                dy *= sc
            px += dx
            py += dy
            it += 1
            # a correction this small leaves an error of order its square (Newton converges
            # quadratically): keep it and stop, the position is within tol of the root
            if n2 <= tol2:
                break
        iters += it
        ex = px - ax
        ey = py - ay
        fx = px - bx
        fy = py - by
        det = ex * fy - ey * fx
        # det = cross(p − a, p − b) = cross(b − a, p − a): the orientation, i.e. the branch sign
        if signs[k] != 0.0 and (det > 0.0) != (signs[k] > 0.0):
            if abs(det) > FOLD_SIN * math.sqrt((ex * ex + ey * ey) * (fx * fx + fy * fy)):
                return SIGN, k, iters
            # at a fold the two roots meet and Newton may take either: the mirror image across the
            # parents' line is the other exact root, the one on this dyad's branch
            g2 = gx * gx + gy * gy
            t = ((px - ax) * gx + (py - ay) * gy) / g2
            px = 2.0 * (ax + t * gx) - px
            py = 2.0 * (ay + t * gy) - py
            ex = px - ax
            ey = py - ay
            fx = px - bx
            fy = py - by
            det = ex * fy - ey * fx
        if det == 0.0:
            return SIGN, k, iters
        if checks:
            mx = px - pxp
            my = py - pyp
            if mx * mx + my * my > lim2:
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
