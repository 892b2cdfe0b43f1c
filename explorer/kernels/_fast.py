"""The closed-form block kinds, DYAD and ATTACH, and the fast step that places them.

* DYAD: one vertex placed by two distances to known vertices (the Jansen leg is five of them), by
  Newton on the 2x2 system with branch tracking, a gap check and the tangent.
* ATTACH: a rigid body's joint placed from its body's known base pair p, q, exactly: at
  p + u (q − p) + v R(q − p) (R: a quarter turn counter-clockwise), (u, v) being the joint's
  coordinates in the frame of the base pair scaled by its length (``_design``). A rigid transform:
  no Newton, no branch (a body never mirrors), no way to fail; its rates follow by the same map.

:func:`fast_step` is scalar code over the per-variant block table (``_inputs.BLOCK_DTYPE``: each
block's kind, vertex, parents and squared lengths by name), both kinds written in its one loop. (A
function per kind, inlined, measured 2x slower on the Jansen leg: Numba counts references to the six
state arrays at every inlined call, atomically.) The generic step (``_step``) calls it on one
block's row at a time.
"""

import math

import numpy as np
from numba import njit

from ..plan import DYAD
from ._blocks import GAP_MARGIN, INFEASIBLE, MAX_MOVE, NOCONV, OK, ROUNDING, SIGN, SUSPECT, gap_suspect


# Below this |sin| of the angle at the placed vertex a dyad is at a fold (its parents' distance at
# the end of its range): both roots meet there, and keeping the branch means taking the mirror root.
FOLD_SIN = 1e-2


@njit(cache=True, inline="always")
def dyad_fill(rec, v, a, b, d1, d2, qmin, qmax):
    """Fill block-table row ``rec`` (``_inputs.BLOCK_DTYPE``) for a dyad placing vertex v at distances
    d1 from parent a and d2 from parent b. [qmin, qmax] bounds the parents' squared distance over the
    whole cycle where that is known (qmin < 0: unknown); inside the assembly range with margin, the
    between-sample gap check is not needed."""
    rec.vertex = v
    rec.a = a
    rec.b = b
    rec.da2 = d1 * d1
    rec.db2 = d2 * d2
    rec.hi2 = (d1 + d2) * (d1 + d2)
    rec.lo2 = (d1 - d2) * (d1 - d2)
    rec.lim2 = (MAX_MOVE * min(d1, d2)) ** 2
    lo = rec.lo2 * (1.0 + GAP_MARGIN)
    hi = rec.hi2 * (1.0 - GAP_MARGIN)
    rec.gap = 0 if (qmin >= 0.0 and lo < qmin and qmax < hi) else 1


@njit(cache=True, inline="always")
def fast_step(ctx, signs, P0, V0, Vp, P1, V1, A1, h, hp, tol, maxit, want_acc, checks):
    """Place every block of the block table ``ctx`` (DYAD and ATTACH rows) in order at the new driver
    position (already in P1). Returns (code, failing block or −1, iterations).

    A dyad: predict its vertex from P0/V0/Vp, Newton with a step limit until a correction no longer
    than ``tol`` (model units) has been applied, check assembly, the branch ``signs[k]``, a gap
    between samples and the move; then the tangent (and second derivative). A body joint: the rigid
    transform of its base pair, with its rates.
    """
    iters = 0
    c2 = 0.5 * h * h / hp if hp != 0.0 else 0.0
    for k in range(ctx.shape[0]):
        rec = ctx[k]
        v = rec.vertex
        a = rec.a
        b = rec.b
        if rec.kind != DYAD:  # ATTACH (the fast step is given no GENERAL row)
            u = rec.u
            w = rec.v
            gx = P1[b, 0] - P1[a, 0]
            gy = P1[b, 1] - P1[a, 1]
            P1[v, 0] = P1[a, 0] + u * gx - w * gy
            P1[v, 1] = P1[a, 1] + u * gy + w * gx
            gx = V1[b, 0] - V1[a, 0]
            gy = V1[b, 1] - V1[a, 1]
            V1[v, 0] = V1[a, 0] + u * gx - w * gy
            V1[v, 1] = V1[a, 1] + u * gy + w * gx
            if want_acc:
                gx = A1[b, 0] - A1[a, 0]
                gy = A1[b, 1] - A1[a, 1]
                A1[v, 0] = A1[a, 0] + u * gx - w * gy
                A1[v, 1] = A1[a, 1] + u * gy + w * gx
            continue
        da2 = rec.da2
        db2 = rec.db2
        hi2 = rec.hi2
        lo2 = rec.lo2
        lim2 = rec.lim2
        ax = P1[a, 0]
        ay = P1[a, 1]
        bx = P1[b, 0]
        by = P1[b, 1]
        gx = bx - ax
        gy = by - ay
        q1 = gx * gx + gy * gy
        if q1 > hi2 or q1 < lo2:
            return INFEASIBLE, k, iters
        if checks and rec.gap != 0:
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
