"""The closed-form block kinds, DYAD and ATTACH, and the fast step that places them.

* DYAD: one vertex placed by two distances to known vertices (the Jansen leg is five of them), by
  Newton on the 2x2 system with branch tracking, a gap check and the tangent.
* SLIDE: one vertex placed by a distance to a known vertex c and a slide equation affine in it (a
  pin–slider dyad), exactly: the line–circle intersection (:func:`slide_root`), the branch the sign
  of cross(vertex − c, J), J the slide equation's gradient in the vertex; a gap check on the squared
  distance from c to the vertex's line, and the rates from the 2x2 Jacobian.
* ATTACH: a rigid body's joint placed from its body's known base pair p, q, exactly: at
  p + u (q − p) + v R(q − p) (R: a quarter turn counter-clockwise), (u, v) being the joint's
  coordinates in the frame of the base pair scaled by its length (``_design``). A rigid transform:
  no Newton, no branch (a body never mirrors), no way to fail; its rates follow by the same map.

:func:`place_dyad` is the dyad's arithmetic (prediction, Newton, checks, tangent) on scalars, its one
home: :func:`fast_step` and the kernels generated per topology (``_codegen``) both call it, so they
do the same floating-point operations. :func:`fast_step` is scalar code over the per-variant block
table (``_inputs.BLOCK_DTYPE``: each block's kind, vertex, parents and squared lengths by name), both
kinds in its one loop. (A function per kind taking the state arrays, inlined by Numba, measured 2x
slower on the Jansen leg: Numba counts references to the six state arrays at every inlined call,
atomically; place_dyad takes scalars and is inlined by LLVM.) The generic step (``_step``) calls
fast_step on one block's row at a time.
"""

import math

from numba import njit

from ..plan import ATTACH, DYAD
from ._blocks import GAP_MARGIN, INFEASIBLE, MAX_MOVE, NOCONV, OK, ROUNDING, SIGN, SUSPECT, gap_suspect, slide_eval


# Below this |sin| of the angle at the placed vertex a dyad is at a fold (its parents' distance at
# the end of its range): both roots meet there, and keeping the branch means taking the mirror root.
FOLD_SIN = 1e-2
# Newton's second correction of a dyad is taken from its first step's Jacobian (``place_dyad``) when that
# Jacobian is within this relative distance of the new one (ρ); the correction's own error is then
# below ρ / (1 − ρ) ≈ 1e-4 of its length, which is at most tol.
SHORTCUT_RHO = 1e-4
SHORTCUT_RHO2 = SHORTCUT_RHO * SHORTCUT_RHO


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


@njit(cache=True, forceinline=True)
def frame_point(u, w, ax, ay, bx, by):
    """The point (u, w) of the frame of a → b: a + u (b − a) + w R(b − a), R a quarter turn
    counter-clockwise. A body joint from its base pair (and, applied to tangents or second
    derivatives, its rates); a dyad's vertex from its parents (``_batch.place_closed``)."""
    gx = bx - ax
    gy = by - ay
    return ax + u * gx - w * gy, ay + u * gy + w * gx


@njit(cache=True, forceinline=True)
def place_dyad(checks, gap, h, c2, ax, ay, bx, by, vax, vay, vbx, vby, ax0, ay0, bx0, by0, vax0, vay0, vbx0, vby0,
               x0, y0, vx0, vy0, wx0, wy0, da2, db2, hi2, lo2, lim2, sign, tol2, maxit):
    """Place one dyad's vertex at a new driver position: the dyad arithmetic, in scalars, that
    :func:`fast_step` and the code generated per topology (``_codegen``) both call, so both do the
    same floating-point operations. (A function of scalars, typed once by Numba and inlined by LLVM at
    each call site, ``forceinline``: Numba's own inlining would type its body again at every site,
    seconds of compile time for a generated kernel; an ordinary call costs 10 % of the run time.)

    checks: the step is not at the smallest size (run the gap and move checks); gap: the parents'
    distance may leave the assembly range over the cycle (run the gap check); h, c2: the step and the
    predictor's curvature coefficient (``_sweep``). (ax, ay), (bx, by), (vax, vay), (vbx, vby): the
    parents' new positions and tangents; (ax0, ...), (vax0, ...): their previous ones; (x0, y0),
    (vx0, vy0), (wx0, wy0): the vertex's previous position, tangent and the tangent before that; da2,
    db2: squared distances to the parents; hi2, lo2, lim2: the block table's assembly limits and largest
    move (``_inputs.BLOCK_DTYPE``); sign: the branch kept (0: none); tol2: Newton's stopping distance,
    squared; maxit: its iteration limit.

    Predicts the vertex from its previous position and tangents, runs Newton with a step limit until
    a correction no longer than tol has been applied, checks assembly, the branch, a gap between
    samples and the move, and solves for the tangent. Returns (code, iterations, x, y, vx, vy, ex, ey,
    fx, fy, inv): the step code (``_blocks``' OK, INFEASIBLE, SIGN, NOCONV, SUSPECT), then, when OK,
    the position and tangent, the vertex's offsets from its parents and 1/det (for accelerations).
    """
    nan = math.nan
    gx = bx - ax
    gy = by - ay
    q1 = gx * gx + gy * gy
    if q1 > hi2 or q1 < lo2:
        return INFEASIBLE, 0, nan, nan, nan, nan, nan, nan, nan, nan, nan
    if checks and gap:
        # may the parents' distance leave the assembly range between the two samples?
        ux = bx0 - ax0
        uy = by0 - ay0
        q0 = ux * ux + uy * uy
        m0 = 2.0 * (ux * (vbx0 - vax0) + uy * (vby0 - vay0))
        m1 = 2.0 * (gx * (vbx - vax) + gy * (vby - vay))
        if gap_suspect(q0, m0, q1, m1, h, hi2, lo2):
            return SUSPECT, 0, nan, nan, nan, nan, nan, nan, nan, nan, nan
    mx = h * vx0 + c2 * (vx0 - wx0)
    my = h * vy0 + c2 * (vy0 - wy0)
    if checks and mx * mx + my * my > lim2:
        return SUSPECT, 0, nan, nan, nan, nan, nan, nan, nan, nan, nan
    px = x0 + mx
    py = y0 + my
    pxp = px
    pyp = py
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
            return NOCONV, it, nan, nan, nan, nan, nan, nan, nan, nan, nan
        inv = 0.5 / det
        dx = (ey * rb - ra * fy) * inv
        dy = (fx * ra - ex * rb) * inv
        n2 = dx * dx + dy * dy
        full = n2 <= 4.0 * lim2
        if not full:
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
        if (full and it < maxit
                and 2.0 * n2 * (ex * ex + ey * ey + fx * fx + fy * fy) <= SHORTCUT_RHO2 * det * det):
            # The equations are quadratic with Hessian 2I, so after a full Newton step d the residuals
            # are exactly (|d|², |d|²): the next correction needs no new residual, and with this
            # step's Jacobian J (the new one is J + (1, 1)ᵀ dᵀ) no new division. Its error is at most
            # ρ/(1 − ρ) of its length, ρ = ‖J⁻¹‖‖(1, 1)ᵀ dᵀ‖ (Frobenius norms), so it is taken only
            # where ρ ≤ SHORTCUT_RHO; then it is as good as a Newton step, and one within tol stops
            # Newton with the position within about tol · SHORTCUT_RHO + (its length)² / |p − a|
            # of the root. Otherwise Newton goes on from there as usual.
            cx = (ey - fy) * n2 * inv
            cy = (fx - ex) * n2 * inv
            px += cx
            py += cy
            it += 1
            if cx * cx + cy * cy <= tol2:
                break
    ex = px - ax
    ey = py - ay
    fx = px - bx
    fy = py - by
    det = ex * fy - ey * fx
    # det = cross(p − a, p − b) = cross(b − a, p − a): the orientation, i.e. the branch sign
    if sign != 0.0 and (det > 0.0) != (sign > 0.0):
        if abs(det) > FOLD_SIN * math.sqrt((ex * ex + ey * ey) * (fx * fx + fy * fy)):
            return SIGN, it, nan, nan, nan, nan, nan, nan, nan, nan, nan
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
        return SIGN, it, nan, nan, nan, nan, nan, nan, nan, nan, nan
    if checks:
        mx = px - pxp
        my = py - pyp
        if mx * mx + my * my > lim2:
            return SUSPECT, it, nan, nan, nan, nan, nan, nan, nan, nan, nan
    inv = 1.0 / det
    r1 = ex * vax + ey * vay
    r2 = fx * vbx + fy * vby
    vx = (r1 * fy - ey * r2) * inv
    vy = (ex * r2 - fx * r1) * inv
    return OK, it, px, py, vx, vy, ex, ey, fx, fy, inv


@njit(cache=True)
def _slide_at(rec, P, x, y):
    """``_blocks.slide_eval`` of a SLIDE record's slide equation at positions (or rates) P with the
    block's vertex at (x, y) instead: (r, ∂r/∂p, ∂r/∂a, ∂r/∂b) as seven numbers."""
    ground = rec.sa < 0
    px = P[rec.sp, 0]
    py = P[rec.sp, 1]
    ax = ay = bx = by = 0.0
    if not ground:
        ax = P[rec.sa, 0]
        ay = P[rec.sa, 1]
        bx = P[rec.sb, 0]
        by = P[rec.sb, 1]
    if rec.role == 0:
        px = x
        py = y
    elif rec.role == 1:
        ax = x
        ay = y
    else:
        bx = x
        by = y
    return slide_eval(ground, px, py, ax, ay, bx, by, rec.lx, rec.ly, rec.nx, rec.ny, rec.off, rec.sl)


@njit(cache=True)
def _role(role, jpx, jpy, jax, jay, jbx, jby):
    """The partial derivative of a slide equation in the vertex of ``role`` (0 p, 1 a, 2 b)."""
    if role == 0:
        return jpx, jpy
    if role == 1:
        return jax, jay
    return jbx, jby


@njit(cache=True)
def _others(rec, R, jpx, jpy, jax, jay, jbx, jby):
    """Σ ∂r/∂w · R[w] over the slide equation's vertices w other than the block's own (R: rates)."""
    out = 0.0
    if rec.role != 0:
        out += jpx * R[rec.sp, 0] + jpy * R[rec.sp, 1]
    if rec.sa >= 0:
        if rec.role != 1:
            out += jax * R[rec.sa, 0] + jay * R[rec.sa, 1]
        if rec.role != 2:
            out += jbx * R[rec.sb, 0] + jby * R[rec.sb, 1]
    return out


@njit(cache=True)
def slide_root(rec, sign, P, gx, gy):
    """A SLIDE block's vertex by the closed form: the slide equation with the other vertices known is
    J·(x − c) + r_c = 0 (r_c: its residual with the vertex at c, the known vertex at distance d), a line;
    the vertex is where the circle of radius d about c meets it, on the side ``sign`` (the sign of
    cross(x − c, J)), or, with sign 0, the one nearer (gx, gy). Returns (code, x, y): OK, INFEASIBLE
    (the circle misses the line) or NOCONV (the line is undefined: J = 0)."""
    c = rec.a
    cx = P[c, 0]
    cy = P[c, 1]
    rc, jpx, jpy, jax, jay, jbx, jby = _slide_at(rec, P, cx, cy)
    jx, jy = _role(rec.role, jpx, jpy, jax, jay, jbx, jby)
    j2 = jx * jx + jy * jy
    if not j2 > 0.0:
        return NOCONV, math.nan, math.nan
    t2 = rec.da2 - rc * rc / j2
    if t2 < 0.0:
        return INFEASIBLE, math.nan, math.nan
    fx = cx - rc * jx / j2
    fy = cy - rc * jy / j2
    t = math.sqrt(t2 / j2)
    # the roots f ± t (−jy, jx); cross(x − c, J) = −(±) t |J|²
    s = -1.0 if sign > 0.0 else 1.0
    if sign == 0.0:
        d1 = (fx - t * jy - gx) ** 2 + (fy + t * jx - gy) ** 2
        d2 = (fx + t * jy - gx) ** 2 + (fy - t * jx - gy) ** 2
        s = 1.0 if d1 <= d2 else -1.0
    return OK, fx - s * t * jy, fy + s * t * jx


@njit(cache=True)
def slide_sign(rec, P):
    """A SLIDE block's branch at positions P: cross(x − c, J) (J the slide equation's gradient in x)."""
    v = rec.vertex
    c = rec.a
    _, jpx, jpy, jax, jay, jbx, jby = _slide_at(rec, P, P[v, 0], P[v, 1])
    jx, jy = _role(rec.role, jpx, jpy, jax, jay, jbx, jby)
    return (P[v, 0] - P[c, 0]) * jy - (P[v, 1] - P[c, 1]) * jx


@njit(cache=True)
def _slide_gap(rec, P, V):
    """(q, dq/dparameter): the squared distance from the known vertex c to the SLIDE block's line, and its
    rate, from the known vertices' positions P and rates V (the vertex must stay within √da2 of c: q ≤ da2)."""
    c = rec.a
    cx = P[c, 0]
    cy = P[c, 1]
    rc, jpx, jpy, jax, jay, jbx, jby = _slide_at(rec, P, cx, cy)
    jx, jy = _role(rec.role, jpx, jpy, jax, jay, jbx, jby)
    j2 = jx * jx + jy * jy
    # r_c's rate: every vertex's partial times its rate, the block's vertex taking c's
    drc = _others(rec, V, jpx, jpy, jax, jay, jbx, jby) + jx * V[c, 0] + jy * V[c, 1]
    jj = 0.0  # J·J': J is linear in the other vertices (zero rate for a ground line)
    if rec.sa >= 0:
        _, kpx, kpy, kax, kay, kbx, kby = _slide_at(rec, V, V[c, 0], V[c, 1])
        kx, ky = _role(rec.role, kpx, kpy, kax, kay, kbx, kby)
        jj = jx * kx + jy * ky
    return rc * rc / j2, 2.0 * (rc * drc * j2 - rc * rc * jj) / (j2 * j2)


@njit(cache=True)
def slide_rates(rec, P, V, A, want_acc):
    """The SLIDE block's vertex's tangent into V (and second derivative into A), from the 2x2 system of
    its distance row (x − c)·(V_x − V_c) = 0 and slide row J·V_x = −Σ others; False if singular."""
    v = rec.vertex
    c = rec.a
    _, jpx, jpy, jax, jay, jbx, jby = _slide_at(rec, P, P[v, 0], P[v, 1])
    jx, jy = _role(rec.role, jpx, jpy, jax, jay, jbx, jby)
    ex = P[v, 0] - P[c, 0]
    ey = P[v, 1] - P[c, 1]
    det = ex * jy - ey * jx
    if det == 0.0:
        return False
    r1 = ex * V[c, 0] + ey * V[c, 1]
    r2 = -_others(rec, V, jpx, jpy, jax, jay, jbx, jby)
    V[v, 0] = (r1 * jy - ey * r2) / det
    V[v, 1] = (ex * r2 - jx * r1) / det
    if want_acc:
        wx = V[v, 0] - V[c, 0]
        wy = V[v, 1] - V[c, 1]
        s1 = ex * A[c, 0] + ey * A[c, 1] - (wx * wx + wy * wy)
        s2 = -_others(rec, A, jpx, jpy, jax, jay, jbx, jby)
        if rec.sa >= 0:  # the slot's curvature term 2 cross(v_b − v_a, v_p − v_a)/L
            p = rec.sp
            a = rec.sa
            b = rec.sb
            s2 -= 2.0 * ((V[b, 0] - V[a, 0]) * (V[p, 1] - V[a, 1])
                         - (V[b, 1] - V[a, 1]) * (V[p, 0] - V[a, 0])) / rec.sl
        A[v, 0] = (s1 * jy - ey * s2) / det
        A[v, 1] = (ex * s2 - jx * s1) / det
    return True


@njit(cache=True)
def slide_step(rec, sign, P0, V0, Vp, P1, V1, A1, h, c2, want_acc, checks):
    """Place a SLIDE block at the new driver position (its known vertices already placed in P1, V1):
    the closed form on the branch ``sign``, the gap check between the samples and the move check,
    then its rates. Returns a step code (``_blocks``)."""
    v = rec.vertex
    mx = h * V0[v, 0] + c2 * (V0[v, 0] - Vp[v, 0])
    my = h * V0[v, 1] + c2 * (V0[v, 1] - Vp[v, 1])
    if checks and mx * mx + my * my > rec.lim2:
        return SUSPECT
    code, x, y = slide_root(rec, sign, P1, P0[v, 0] + mx, P0[v, 1] + my)
    if code != OK:
        return code
    if checks:
        q0, m0 = _slide_gap(rec, P0, V0)
        q1, m1 = _slide_gap(rec, P1, V1)
        if gap_suspect(q0, m0, q1, m1, h, rec.hi2, rec.lo2):
            return SUSPECT
        dx = x - P0[v, 0] - mx
        dy = y - P0[v, 1] - my
        if dx * dx + dy * dy > rec.lim2:
            return SUSPECT
    P1[v, 0] = x
    P1[v, 1] = y
    if not slide_rates(rec, P1, V1, A1, want_acc):
        return SIGN
    return OK


@njit(cache=True, inline="always")
def fast_step(ctx, signs, P0, V0, Vp, P1, V1, A1, h, hp, tol, maxit, want_acc, checks):
    """Place every block of the block table ``ctx`` (DYAD and ATTACH rows) in order at the new driver
    position (already in P1). Returns (code, failing block or −1, iterations).

    A dyad: :func:`place_dyad` (prediction, Newton, the checks, the tangent), then its second
    derivative if asked. A body joint: the rigid transform of its base pair, with its rates.
    """
    iters = 0
    c2 = 0.5 * h * h / hp if hp != 0.0 else 0.0
    tol2 = tol * tol
    for k in range(ctx.shape[0]):
        rec = ctx[k]
        v = rec.vertex
        a = rec.a
        b = rec.b
        if rec.kind != DYAD and rec.kind != ATTACH:  # SLIDE (the fast step is given no GENERAL row)
            code = slide_step(rec, signs[k], P0, V0, Vp, P1, V1, A1, h, c2, want_acc, checks)
            if code != OK:
                return code, k, iters
            continue
        if rec.kind != DYAD:  # ATTACH
            u = rec.u
            w = rec.v
            P1[v, 0], P1[v, 1] = frame_point(u, w, P1[a, 0], P1[a, 1], P1[b, 0], P1[b, 1])
            V1[v, 0], V1[v, 1] = frame_point(u, w, V1[a, 0], V1[a, 1], V1[b, 0], V1[b, 1])
            if want_acc:
                A1[v, 0], A1[v, 1] = frame_point(u, w, A1[a, 0], A1[a, 1], A1[b, 0], A1[b, 1])
            continue
        code, it, px, py, vx, vy, ex, ey, fx, fy, inv = place_dyad(
            checks, rec.gap != 0, h, c2, P1[a, 0], P1[a, 1], P1[b, 0], P1[b, 1], V1[a, 0], V1[a, 1], V1[b, 0], V1[b, 1],
            P0[a, 0], P0[a, 1], P0[b, 0], P0[b, 1], V0[a, 0], V0[a, 1], V0[b, 0], V0[b, 1],
            P0[v, 0], P0[v, 1], V0[v, 0], V0[v, 1], Vp[v, 0], Vp[v, 1],
            rec.da2, rec.db2, rec.hi2, rec.lo2, rec.lim2, signs[k], tol2, maxit)
        iters += it
        if code != OK:
            return code, k, iters
        P1[v, 0] = px
        P1[v, 1] = py
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
