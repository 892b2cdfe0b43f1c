"""DYAD: one vertex placed by two distance equations to known vertices (two links, or a link and a
body's base pair; the Jansen leg is five of them).

Its parts, each written once here:

* **closed form** (the start of every design, the exact "closed" method): the circles about its
  parents a, b meet on the side ``sign`` of a → b;
* **branch sign**: cross(b − a, p − a) (:func:`dyad_sign`), the orientation of the vertex against
  its parents; at a fold (sin of the angle at the vertex below :data:`FOLD_SIN`) the mirror root is
  the branch's own;
* **gap check**: the parents' squared distance must stay within [(da − db)², (da + db)²] between two
  samples (``_common.gap_suspect``), skipped where a link joins the parents or they are the crank tip
  and a ground pivot whose range stays inside (the ``join`` column);
* **Newton step** (:func:`place_dyad`: the predictor, Newton with a step limit, the checks and the
  tangent, on scalars: one home for the sweep's array form and the generated per-topology code);
* **rates**: the tangent from the 2x2 Jacobian at the solved position, the second derivative from
  the same inverse;
* **reactions**: the multipliers of its two distance rows from the same 2x2 system transposed.

The sweep's array and scalar forms, the closed form, the dense method's checks and the forces read
the snippets below (``ARRAY``, ``SCALAR``), rendered by ``explorer.kernels._render``.
"""

import math

import numpy as np
from numba import njit

from ._common import (GAP_MARGIN, INFEASIBLE, MAX_MOVE, NOCONV, OK, ROUNDING, SIGN, SUSPECT, gap_suspect, other_end,
                      vector_gaps, vector_moves)

NAME = "DYAD"
NUMBER = 0
TEXT = "one joint from two distances to known joints (closed form)"
#: its columns of the lowered plan's block table (``Topology.blk``): the vertex, its parents, the two
#: distance equations to them, and the equation joining the parents (−2: they are the crank tip and
#: a fixed vertex, −1: neither)
COLUMNS = ("vertex", "a", "b", "eq_a", "eq_b", "join")
#: fields of the per-design block table (``_inputs.BLOCK_DTYPE``) it fills: squared lengths to the
#: parents, the squared limits of their distance (hi2 = (da+db)², lo2 = (da−db)²), the squared largest
#: move per step, whether the between-sample gap check is needed
FIELDS = (("vertex", "i8"), ("a", "i8"), ("b", "i8"), ("da2", "f8"), ("db2", "f8"), ("hi2", "f8"), ("lo2", "f8"),
          ("lim2", "f8"), ("gap", "i8"))
#: the vertices (columns) its generated code reads
READS = ("a", "b")
#: how a design's start places it: by the closed form on the nominal's branch (a sign is needed)
START = "sign"

# Below this |sin| of the angle at the placed vertex a dyad is at a fold (its parents' distance at
# the end of its range): both roots meet there, and keeping the branch means taking the mirror root.
FOLD_SIN = 1e-2
# Newton's second correction of a dyad is taken from its first step's Jacobian (``place_dyad``) when that
# Jacobian is within this relative distance of the new one (ρ); the correction's own error is then
# below ρ / (1 − ρ) ≈ 1e-4 of its length, which is at most tol.
SHORTCUT_RHO = 1e-4
SHORTCUT_RHO2 = SHORTCUT_RHO * SHORTCUT_RHO


# -- the plan ------------------------------------------------------------------------------------
def classify(vertices, rows, tables) -> bool:
    """One vertex, two distance rows."""
    return len(vertices) == 1 and len(rows) == 2 and all(r[0] == "distance" for r in rows)


def lower(plan, block, crank: bool, shared: dict) -> tuple:
    """Its ``COLUMNS`` for ``Topology.blk`` (``shared``: scratch shared by the plan's blocks)."""
    v = block.vertices[0]
    la, lb = block.links
    pa, pb = other_end(plan, la, v), other_end(plan, lb, v)
    join = -1
    if "pairs" not in shared:  # once per plan: the distance equation joining each pair of vertices
        shared["pairs"] = {frozenset((int(a), int(b))): e for e, (a, b) in enumerate(zip(plan.link_a, plan.link_b))}
        shared["fixed"] = set(plan.fixed.tolist())
    pairs = shared["pairs"]
    if frozenset((pa, pb)) in pairs:
        join = pairs[frozenset((pa, pb))]
    elif crank and plan.tip in (pa, pb) and ({pa, pb} - {plan.tip}) <= shared["fixed"]:
        join = -2
    return (v, pa, pb, la, lb, join)


# -- the nominal's first assembly (Python, once per topology) --------------------------------------
def assemble(k, P, ctx):
    """Place the vertex at the circles' intersection on the side of a → b where its guess P[v] lies;
    False if they do not meet. (ctx: the plan, the nominal design ``des``, ...: ``_simulate.assemble``.)"""
    plan = ctx.plan
    block = plan.blocks[k]
    v = block.vertices[0]
    (a, la), (b, lb) = [(other_end(plan, e, v), e) for e in block.links]
    L = ctx.des.dist[0]
    A, B = P[a], P[b]
    g = B - A
    d = math.hypot(g[0], g[1])
    da, db = L[la], L[lb]
    if d == 0.0 or d > da + db or d < abs(da - db):
        return False
    x = (da * da - db * db + d * d) / (2.0 * d)
    y = math.sqrt(max(da * da - x * x, 0.0))
    u = g / d
    perp = np.array([-u[1], u[0]])
    guess = P[v]
    side = g[0] * (guess[1] - A[1]) - g[1] * (guess[0] - A[0])
    P[v] = A + x * u + (y if side >= 0.0 else -y) * perp
    return True


def branch(k, P, ctx) -> float:
    """Its branch sign at positions P (+1, −1, 0 on its parents' line)."""
    plan = ctx.plan
    block = plan.blocks[k]
    v = block.vertices[0]
    a, b = (other_end(plan, e, v) for e in block.links)
    g, w = P[b] - P[a], P[v] - P[a]
    return float(np.sign(g[0] * w[1] - g[1] * w[0]))


# -- numerics ------------------------------------------------------------------------------------
@njit(cache=True, inline="always")
def dyad_fill(rec, v, a, b, d1, d2, qmin, qmax):
    """Fill block-table row ``rec`` for a dyad placing vertex v at distances d1 from parent a and d2
    from parent b. [qmin, qmax] bounds the parents' squared distance over the whole cycle where that is
    known (qmin < 0: unknown); inside the assembly range with margin, the gap check is not needed."""
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


@njit(cache=True)
def dyad_sign(P, v, a, b):
    """Orientation cross(b − a, p − a) of dyad vertex v against its parents a, b (its branch sign)."""
    return (P[b, 0] - P[a, 0]) * (P[v, 1] - P[a, 1]) - (P[b, 1] - P[a, 1]) * (P[v, 0] - P[a, 0])


@njit(cache=True, forceinline=True)
def place_dyad(checks, gap, h, c2, ax, ay, bx, by, vax, vay, vbx, vby, ax0, ay0, bx0, by0, vax0, vay0, vbx0, vby0,
               x0, y0, vx0, vy0, wx0, wy0, da2, db2, hi2, lo2, lim2, sign, tol2, maxit):
    """Place one dyad's vertex at a new driver position: the dyad arithmetic, in scalars, that the
    sweep's array form and the code generated per topology both call, so both do the same
    floating-point operations. (A function of scalars, typed once by Numba and inlined by LLVM at
    each call site, ``forceinline``: Numba's own inlining would type its body again at every site,
    seconds of compile time for a generated kernel; an ordinary call costs 10 % of the run time.)

    checks: the step is not at the smallest size (run the gap and move checks); gap: the parents'
    distance may leave the assembly range over the cycle (run the gap check); h, c2: the step and the
    predictor's curvature coefficient (the sweep's). (ax, ay), (bx, by), (vax, vay), (vbx, vby): the
    parents' new positions and tangents; (ax0, ...), (vax0, ...): their previous ones; (x0, y0),
    (vx0, vy0), (wx0, wy0): the vertex's previous position, tangent and the tangent before that; da2,
    db2: squared distances to the parents; hi2, lo2, lim2: the block table's assembly limits and largest
    move; sign: the branch kept (0: none); tol2: Newton's stopping distance, squared; maxit: its
    iteration limit.

    Predicts the vertex from its previous position and tangents, runs Newton with a step limit until
    a correction no longer than tol has been applied, checks assembly, the branch, a gap between
    samples and the move, and solves for the tangent. Returns (code, iterations, x, y, vx, vy, ex, ey,
    fx, fy, inv): the step code (OK, INFEASIBLE, SIGN, NOCONV, SUSPECT), then, when OK, the position
    and tangent, the vertex's offsets from its parents and 1/det (for accelerations).
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


#: The vectorised first pass (``explorer.kernels._vector``) leaves a design to Newton where a dyad's
#: |sin| of the angle at its vertex falls below this at any sample: near a fold the branch is ambiguous
#: (the motion may pass onto the mirror root) and the closed form loses digits (its error grows like
#: rounding / sin). Twice the fold Newton itself tolerates (:data:`FOLD_SIN`).
VECTOR_FOLD = 2.0 * FOLD_SIN


@njit(cache=True, error_model="numpy")
def dyad_vector(v, a, b, da2, db2, hi2, lo2, lim2, gap, sign, X, Y, VX, VY, Q, M, h, closed):
    """A dyad over every sample at once: its vertex v by the closed form on the side ``sign`` of a → b
    and its tangent from the 2x2 Jacobian, from its parents' rows of X, Y, VX, VY ((n_vertices, S):
    positions and tangents, x and y apart), written into row v; then its checks as passes over the
    step arrays. Returns True (flagged: leave the design to Newton) if at any sample the circles do not
    meet or the angle at the vertex is within :data:`VECTOR_FOLD` of a fold, or between two samples
    (a step h apart; ``closed``: the last and the first too) the vertex moves further than √lim2 from
    its linear prediction (the move limit, ``_common.vector_moves``) or, when ``gap``, the parents'
    squared distance may leave [lo2, hi2] (the gap bound, ``_common.vector_gaps``; Q, M (S,): scratch).
    The loops have no branches (a negative square root gives NaN, which fails the fold test) so that
    LLVM vectorises them."""
    xa = X[a]
    ya = Y[a]
    xb = X[b]
    yb = Y[b]
    ua = VX[a]
    wa = VY[a]
    ub = VX[b]
    wb = VY[b]
    xv = X[v]
    yv = Y[v]
    uv = VX[v]
    wv = VY[v]
    S = xa.shape[0]
    s = 1.0 if sign > 0.0 else -1.0
    rs = VECTOR_FOLD * math.sqrt(da2 * db2)
    bad = 0
    for k in range(S):
        gx = xb[k] - xa[k]
        gy = yb[k] - ya[k]
        d2 = gx * gx + gy * gy
        # one square root and one division for the position and the tangent: with c = (da2 − db2 + d2)/2
        # and K = da2 d2 − c² (4 K = the squared doubled area of the triangle), w = √K, z = 1/(d2 w):
        # the offsets along and across a → b are x = c/d2 = c z w and y = ±w/d2 = ±K z, and the
        # Jacobian's determinant cross(p − a, p − b) = y d2, so 1/det = ±z d2
        c = 0.5 * (da2 - db2 + d2)
        K = da2 * d2 - c * c
        w = np.sqrt(K)
        z = 1.0 / (d2 * w)
        x = c * z * w
        y = s * K * z
        ex = x * gx - y * gy  # p − a
        ey = x * gy + y * gx
        fx = ex - gx  # p − b
        fy = ey - gy
        det = y * d2  # cross(p − a, p − b); NaN where the circles do not meet
        idet = s * z * d2
        r1 = ex * ua[k] + ey * wa[k]
        r2 = fx * ub[k] + fy * wb[k]
        xv[k] = xa[k] + ex
        yv[k] = ya[k] + ey
        uv[k] = (r1 * fy - ey * r2) * idet
        wv[k] = (ex * r2 - fx * r1) * idet
        bad += not (abs(det) >= rs)  # NaN (no assembly) fails too
    if bad or vector_moves(xv, yv, uv, wv, h, closed, lim2):
        return True
    if not gap:
        return False
    for k in range(S):
        gx = xb[k] - xa[k]
        gy = yb[k] - ya[k]
        Q[k] = gx * gx + gy * gy
        M[k] = 2.0 * (gx * (ub[k] - ua[k]) + gy * (wb[k] - wa[k]))
    return vector_gaps(Q, M, h, closed, hi2, lo2)


@njit(cache=True, error_model="numpy")
def dyad_good(v, a, b, da2, db2, hi2, lo2, lim2, gap, X, Y, VX, VY, h, closed, good_at, good_to):
    """Where a dyad placed by :func:`dyad_vector` (same arguments) passes that pass's checks, sample by
    sample, for a design it flagged (where Newton may resume, ``_vector``): good_at[k] (S,) is cleared
    where sample k fails the assembly and fold test, good_to[k] where the step from sample k to k + 1
    (k = S − 1: to sample 0, ``closed``) fails the move limit or, when ``gap``, the gap bound; the
    same tests as dyad_vector's. Branch-free passes (vectorised), but for the gap bound's exact test."""
    S = X.shape[1]
    rs = VECTOR_FOLD * math.sqrt(da2 * db2)
    xa = X[a]
    ya = Y[a]
    xb = X[b]
    yb = Y[b]
    xv = X[v]
    yv = Y[v]
    uv = VX[v]
    wv = VY[v]
    for k in range(S):
        # the fold test on the placed vertex, det = cross(p − a, p − b) (the pass's, to rounding: a sample at
        # the margin may go either way, and either is safe); NaN (no assembly) fails
        ex = xv[k] - xa[k]
        ey = yv[k] - ya[k]
        good_at[k] &= abs(ex * (yv[k] - yb[k]) - ey * (xv[k] - xb[k])) >= rs
    for k in range(S - 1):
        mx = xv[k + 1] - xv[k] - h * uv[k]
        my = yv[k + 1] - yv[k] - h * wv[k]
        good_to[k] &= mx * mx + my * my <= lim2
    if closed:
        mx = xv[0] - xv[S - 1] - h * uv[S - 1]
        my = yv[0] - yv[S - 1] - h * wv[S - 1]
        good_to[S - 1] &= mx * mx + my * my <= lim2
    if gap:
        for k in range(S if closed else S - 1):
            n = k + 1 if k + 1 < S else 0
            gx = xb[k] - xa[k]
            gy = yb[k] - ya[k]
            ux = xb[n] - xa[n]
            uy = yb[n] - ya[n]
            m0 = 2.0 * (gx * (VX[b, k] - VX[a, k]) + gy * (VY[b, k] - VY[a, k]))
            m1 = 2.0 * (ux * (VX[b, n] - VX[a, n]) + uy * (VY[b, n] - VY[a, n]))
            if gap_suspect(gx * gx + gy * gy, m0, ux * ux + uy * uy, m1, h, hi2, lo2):
                good_to[k] = False


@njit(cache=True, forceinline=True)
def dyad_acc(ex, ey, fx, fy, inv, vx, vy, vax, vay, vbx, vby, aax, aay, abx, aby):
    """The vertex's second derivative from its parents' (aa, ab) and the rates: the 2x2 system of the
    twice-differentiated distance rows, with the inverse ``inv`` of place_dyad's final Jacobian."""
    wax = vx - vax
    way = vy - vay
    wbx = vx - vbx
    wby = vy - vby
    s1 = ex * aax + ey * aay - (wax * wax + way * way)
    s2 = fx * abx + fy * aby - (wbx * wbx + wby * wby)
    return (s1 * fy - ey * s2) * inv, (ex * s2 - fx * s1) * inv


#: What the table-driven kernels (``explorer.kernels._render``) write for a DYAD block, by function:
#: ``fill`` (the per-design block table; row = Topology.blk[k]), ``place`` (the closed form, ``return
#: j`` where it cannot), ``step`` (the sweep's step; ``return code, k, iters`` on trouble), ``check``
#: (the dense method's per-block check), ``sign`` (its branch sign into out[k]).
ARRAY = {
    "imports": "from explorer.kinds.dyad import FOLD_SIN, dyad_acc, dyad_fill, dyad_good, dyad_sign, dyad_vector, place_dyad",
    "fill": """\
v = row[0]
a = row[1]
b = row[2]
qmin = -1.0
qmax = -1.0
if row[5] >= 0:
    qmin = dist[row[5]] * dist[row[5]]
    qmax = qmin
elif row[5] == -2 and crank:
    other = b if a == tip else a
    D = np.hypot(P[other, 0] - cx, P[other, 1] - cy)
    qmin = (D - scale) * (D - scale)
    qmax = (D + scale) * (D + scale)
dyad_fill(rec, v, a, b, dist[row[3]], dist[row[4]], qmin, qmax)
""",
    "place": """\
if start and signs[j] == 0.0:
    return j
a = rec.a
b = rec.b
gx = P[b, 0] - P[a, 0]
gy = P[b, 1] - P[a, 1]
d2 = gx * gx + gy * gy
if d2 == 0.0:
    return j
x = 0.5 * (rec.da2 - rec.db2 + d2) / d2  # along a→b, as a fraction of |a−b|
y2 = rec.da2 / d2 - x * x  # squared offset across, same units
if y2 < 0.0:
    return j
y = math.sqrt(y2) if signs[j] > 0.0 else -math.sqrt(y2)
P[rec.vertex, 0], P[rec.vertex, 1] = frame_point(x, y, P[a, 0], P[a, 1], P[b, 0], P[b, 1])
""",
    "step": """\
v = rec.vertex
a = rec.a
b = rec.b
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
    A1[v, 0], A1[v, 1] = dyad_acc(ex, ey, fx, fy, inv, vx, vy, V1[a, 0], V1[a, 1], V1[b, 0], V1[b, 1],
                                  A1[a, 0], A1[a, 1], A1[b, 0], A1[b, 1])
""",
    "check": """\
v, a, b = rec.vertex, rec.a, rec.b
hi2, lo2, lim2 = rec.hi2, rec.lo2, rec.lim2
sg = dyad_sign(P1, v, a, b)
if sg == 0.0 or (sg > 0.0) != (signs[k] > 0.0):
    ea = (P1[v, 0] - P1[a, 0]) ** 2 + (P1[v, 1] - P1[a, 1]) ** 2
    eb = (P1[v, 0] - P1[b, 0]) ** 2 + (P1[v, 1] - P1[b, 1]) ** 2
    return (FOLD if abs(sg) <= FOLD_SIN * np.sqrt(ea * eb) else SIGN), k
if checks:
    ux = P0[b, 0] - P0[a, 0]
    uy = P0[b, 1] - P0[a, 1]
    gx = P1[b, 0] - P1[a, 0]
    gy = P1[b, 1] - P1[a, 1]
    m0 = 2.0 * (ux * (V0[b, 0] - V0[a, 0]) + uy * (V0[b, 1] - V0[a, 1]))
    m1 = 2.0 * (gx * (V1[b, 0] - V1[a, 0]) + gy * (V1[b, 1] - V1[a, 1]))
    if gap_suspect(ux * ux + uy * uy, m0, gx * gx + gy * gy, m1, h, hi2, lo2):
        return SUSPECT, k
    mx = P1[v, 0] - P0[v, 0] - h * V0[v, 0]
    my = P1[v, 1] - P0[v, 1] - h * V0[v, 1]
    if mx * mx + my * my > lim2:
        return SUSPECT, k
""",
    "sign": "out[k] = np.sign(dyad_sign(P, rec.vertex, rec.a, rec.b))\n",
    # the vectorised first pass: every sample at once, then its checks (``return k``: flagged)
    "vector": """\
if dyad_vector(rec.vertex, rec.a, rec.b, rec.da2, rec.db2, rec.hi2, rec.lo2, rec.lim2, rec.gap != 0, signs[k],
               X, Y, VX, VY, Q, M, h, closed):
    return k
""",
    # where that pass's checks pass, sample by sample (``_vector.restart_points``: where Newton may resume a
    # design the pass flagged); a kind without it keeps the whole sweep for Newton, "pass": it flags nothing
    "good": """\
dyad_good(rec.vertex, rec.a, rec.b, rec.da2, rec.db2, rec.hi2, rec.lo2, rec.lim2, rec.gap != 0, X, Y, VX, VY, h, closed,
          good_at, good_to)
""",
    # the forces effect: a Jacobian too near singular for its reactions (|det| relative to its terms)
    "singular": """\
v = rec.vertex
a = rec.a
b = rec.b
c1x = P[v, 0] - P[a, 0]
c1y = P[v, 1] - P[a, 1]
c2x = P[v, 0] - P[b, 0]
c2y = P[v, 1] - P[b, 1]
det = c1x * c2y - c1y * c2x
if not (abs(det) > tol * (abs(c1x * c2y) + abs(c1y * c2x))):
    return k
""",
    # the forces effect: the multipliers of its two distance rows for every right-hand side r with act[r]
    # (R (nr, nv, 2) the loads; the 2x2 Jacobian transposed, its inverse taken once), passed to its parents
    "reactions": """\
v = rec.vertex
a = rec.a
b = rec.b
c1x = P[v, 0] - P[a, 0]
c1y = P[v, 1] - P[a, 1]
c2x = P[v, 0] - P[b, 0]
c2y = P[v, 1] - P[b, 1]
det = c1x * c2y - c1y * c2x
if det == 0.0:
    return k
inv = 1.0 / det
ea = blk[k, 3]
eb = blk[k, 4]
for r in range(R.shape[0]):
    if act[r]:
        rx = R[r, v, 0]
        ry = R[r, v, 1]
        l1 = (rx * c2y - ry * c2x) * inv
        l2 = (c1x * ry - c1y * rx) * inv
        lam_d[r, ea] = 0.5 * l1  # the distance row's gradient is 2(v − a): its multiplier is half
        lam_d[r, eb] = 0.5 * l2
        R[r, v, 0] = 0.0
        R[r, v, 1] = 0.0
        R[r, a, 0] += c1x * l1
        R[r, a, 1] += c1y * l1
        R[r, b, 0] += c2x * l2
        R[r, b, 1] += c2y * l2
""",
}

#: What the code generated per topology (``explorer.kernels._codegen``) writes for DYAD block {k}
#: placing {v} from {a} and {b}: ``init`` (its numbers loaded into scalars once per design), ``step``
#: (position and tangent; ``break`` leaves the step's one-pass loop with code and blk set; ``chk``: the
#: step's checks flag as a plain bool), ``acc`` (its second derivative, after ``step``). Names:
#: X{v}/Y{v} position, VX/VY tangent, WX/WY previous tangent, x/y and vx/vy the trial ones, zx/zy the
#: trial second derivative.
SCALAR = {
    "init": """\
da2_{k} = tab[{k}].da2
db2_{k} = tab[{k}].db2
hi2_{k} = tab[{k}].hi2
lo2_{k} = tab[{k}].lo2
lim2_{k} = tab[{k}].lim2
gap_{k} = tab[{k}].gap != 0
sg_{k} = signs[{k}]
""",
    "step": """\
# block {k}: dyad placing {v} from {a} and {b}
code, it, x{v}, y{v}, vx{v}, vy{v}, _ex, _ey, _fx, _fy, _inv = place_dyad(
    chk, gap_{k}, h, c2, x{a}, y{a}, x{b}, y{b}, vx{a}, vy{a}, vx{b}, vy{b}, X{a}, Y{a}, X{b}, Y{b},
    VX{a}, VY{a}, VX{b}, VY{b}, X{v}, Y{v}, VX{v}, VY{v}, WX{v}, WY{v},
    da2_{k}, db2_{k}, hi2_{k}, lo2_{k}, lim2_{k}, sg_{k}, tol2, maxit)
iters += it
if code != 0:
    blk = {k}
    break
""",
    "acc": """\
zx{v}, zy{v} = dyad_acc(_ex, _ey, _fx, _fy, _inv, vx{v}, vy{v}, vx{a}, vy{a}, vx{b}, vy{b}, zx{a}, zy{a}, zx{b}, zy{b})
""",
    "imports": "from explorer.kinds.dyad import dyad_acc, place_dyad",
    # the forces effect's code generated per topology (``explorer.kernels._forces_scalar``): at each sample
    # (positions X{v}, Y{v}), in plan order, the 2x2 Jacobian's columns and inverse, and its singularity
    # check (``return`` the block and the sample); then, in reverse plan order for each right-hand side
    # {r}, the multipliers of its two distance rows from the loads R{r}_{v}x, R{r}_{v}y passed to its
    # parents (the table-driven ``reactions`` and ``singular`` snippets' arithmetic, in scalars)
    "forces_init": "",
    "forces_geometry": """\
# block {k}: dyad {v} from {a} and {b}
c1x_{k} = X{v} - X{a}
c1y_{k} = Y{v} - Y{a}
c2x_{k} = X{v} - X{b}
c2y_{k} = Y{v} - Y{b}
det_{k} = c1x_{k} * c2y_{k} - c1y_{k} * c2x_{k}
if not (abs(det_{k}) > tol * (abs(c1x_{k} * c2y_{k}) + abs(c1y_{k} * c2x_{k}))):
    return {k}, u
inv_{k} = 1.0 / det_{k}
""",
    "reactions": """\
l1 = (R{r}_{v}x * c2y_{k} - R{r}_{v}y * c2x_{k}) * inv_{k}
l2 = (c1x_{k} * R{r}_{v}y - c1y_{k} * R{r}_{v}x) * inv_{k}
lam{r}_{eq_a} = 0.5 * l1  # the distance row's gradient is 2(v − a): its multiplier is half
lam{r}_{eq_b} = 0.5 * l2
R{r}_{a}x += c1x_{k} * l1
R{r}_{a}y += c1y_{k} * l1
R{r}_{b}x += c2x_{k} * l2
R{r}_{b}y += c2y_{k} * l2
""",
}
