"""SLIDE: one vertex placed by a distance to a known vertex c and a slide equation whose other
vertices are known (a pin–slider dyad: a connecting rod to a piston, or a slotted link about its
pivot through a known slider). The slide equation is affine in the vertex, so the vertex lies on a
known line.

* **closed form**: the line–circle intersection (:func:`slide_root`), exact;
* **branch sign**: cross(vertex − c, J), J the slide equation's gradient in the vertex;
* **gap check**: the squared distance from c to the vertex's line must stay within its length²;
* **step**: the closed form on the branch, the gap and move checks, then the rates from the 2x2
  Jacobian of its distance row and slide row (:func:`slide_step`, :func:`slide_rates`);
* **reactions**: the multipliers of its distance and slide rows from that 2x2 system transposed.
"""

import math

import numpy as np
from numba import njit

from ._common import (INFEASIBLE, NOCONV, OK, SIGN, SUSPECT, gap_suspect, other_end, vector_gaps,
                      vector_moves)
from .dyad import VECTOR_FOLD
from .eq_slide import slide_eval

NAME = "SLIDE"
NUMBER = 3
TEXT = "one joint from a distance to a known joint and a slider's line (closed form)"
#: its columns of ``Topology.blk``: the vertex, the known vertex c at a fixed distance, that distance
#: equation, its slide equation
COLUMNS = ("vertex", "c", "eq_d", "eq_s")
READS = ("c",)
#: per-design fields: the vertex, c (as a = b), da2 = hi2 = d², lo2 = −d² (the limits of the squared
#: distance from c to the vertex's line), lim2, gap, then its slide equation: slider vertex sp, line
#: vertices sa, sb (−1: ground), which of them the block places (role 0, 1, 2), and the line's numbers
#: (``Designs.slide``: lx, ly, nx, ny, off, sl)
FIELDS = (("vertex", "i8"), ("a", "i8"), ("b", "i8"), ("da2", "f8"), ("hi2", "f8"), ("lo2", "f8"), ("lim2", "f8"),
          ("gap", "i8"), ("sp", "i8"), ("sa", "i8"), ("sb", "i8"), ("role", "i8"), ("lx", "f8"), ("ly", "f8"),
          ("nx", "f8"), ("ny", "f8"), ("off", "f8"), ("sl", "f8"))
START = "sign"


def classify(vertices, rows, tables) -> bool:
    """One vertex, a distance row and a slide row."""
    return (len(vertices) == 1 and len(rows) == 2 and sorted(r[0] for r in rows) == ["distance", "slide"])


def lower(plan, block, crank: bool, shared: dict) -> tuple:
    v = block.vertices[0]
    return (v, other_end(plan, block.links[0], v), block.links[0], block.slides[0])


def assemble(k, P, ctx):
    """The line–circle intersection on the side of the guess P[v]; False if the circle misses the line."""
    rec = ctx.table[k]
    v = int(rec["vertex"])
    code, x, y = slide_root(rec, float(np.sign(slide_sign(rec, P))), P, P[v, 0], P[v, 1])
    if code != 0:
        return False
    P[v] = x, y
    return True


def branch(k, P, ctx) -> float:
    return float(np.sign(slide_sign(ctx.table[k], P)))


# -- numerics ------------------------------------------------------------------------------------
@njit(cache=True)
def _slide_at(rec, P, x, y):
    """``slide_eval`` of a SLIDE record's slide equation at positions (or rates) P with the block's
    vertex at (x, y) instead: (r, ∂r/∂p, ∂r/∂a, ∂r/∂b) as seven numbers."""
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
    then its rates. Returns a step code."""
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


@njit(cache=True)
def _load(w, k, X, Y, VX, VY, P, V):
    """Sample k of vertex w's rows of X, Y, VX, VY into P[w], V[w] (w < 0: none)."""
    if w >= 0:
        P[w, 0] = X[w, k]
        P[w, 1] = Y[w, k]
        V[w, 0] = VX[w, k]
        V[w, 1] = VY[w, k]


@njit(cache=True)
def slide_vector(rec, sign, X, Y, VX, VY, Q, M, P, V, h, closed):
    """A SLIDE block over every sample (the vectorised first pass, ``explorer.kernels._vector``): its
    vertex by the closed form on the branch ``sign`` and its tangent, from its known vertices' rows of
    X, Y, VX, VY ((n_vertices, S)), into its own row; P, V (n_vertices, 2): one sample's scratch; Q, M
    (S,): scratch. Per sample (the line's geometry is not one formula per kind of slide, so this loop is
    scalar). Returns True (flagged: leave the design to Newton) where the circle misses the line, the
    angle between the distance row and the slide row is within ``dyad.VECTOR_FOLD`` of a fold, or
    between samples the line may leave the circle's reach or the vertex moves too far
    (``_common.vector_moves``, ``vector_gaps``)."""
    v = rec.vertex
    c = rec.a
    S = X.shape[1]
    for k in range(S):
        _load(c, k, X, Y, VX, VY, P, V)
        _load(rec.sa, k, X, Y, VX, VY, P, V)
        _load(rec.sb, k, X, Y, VX, VY, P, V)
        if rec.role != 0:
            _load(rec.sp, k, X, Y, VX, VY, P, V)
        code, x, y = slide_root(rec, sign, P, 0.0, 0.0)
        if code != OK:
            return True
        P[v, 0] = x
        P[v, 1] = y
        _, jpx, jpy, jax, jay, jbx, jby = _slide_at(rec, P, x, y)
        jx, jy = _role(rec.role, jpx, jpy, jax, jay, jbx, jby)
        ex = x - P[c, 0]
        ey = y - P[c, 1]
        if not abs(ex * jy - ey * jx) >= VECTOR_FOLD * math.sqrt((ex * ex + ey * ey) * (jx * jx + jy * jy)):
            return True
        if not slide_rates(rec, P, V, V, False):
            return True
        X[v, k] = x
        Y[v, k] = y
        VX[v, k] = V[v, 0]
        VY[v, k] = V[v, 1]
        Q[k], M[k] = _slide_gap(rec, P, V)
    return (vector_moves(X[v], Y[v], VX[v], VY[v], h, closed, rec.lim2)
            or vector_gaps(Q, M, h, closed, rec.hi2, rec.lo2))


@njit(cache=True)
def slide_partial(slide, s, v, jpx, jpy, jax, jay, jbx, jby):
    """Slide equation s's partial derivative in vertex v (one of its p, a, b)."""
    if slide[s, 0] == v:
        return jpx, jpy
    if slide[s, 1] == v:
        return jax, jay
    return jbx, jby


ARRAY = {
    "imports": ("from explorer.kinds.slide import slide_partial, slide_root, slide_sign, slide_step, slide_vector\n"
                "from explorer.kinds.eq_slide import slide_row"),
    "fill": """\
v = row[0]
e = row[3]
d = dist[row[2]]
rec.vertex = v
rec.a = row[1]
rec.b = row[1]
rec.da2 = d * d
rec.hi2 = d * d
rec.lo2 = -d * d
rec.lim2 = (MAX_MOVE * d) ** 2
rec.gap = 1
rec.sp = slide[e, 0]
rec.sa = slide[e, 1]
rec.sb = slide[e, 2]
rec.role = 0 if slide[e, 0] == v else (1 if slide[e, 1] == v else 2)
rec.lx = sd[e, 0]
rec.ly = sd[e, 1]
rec.nx = sd[e, 2]
rec.ny = sd[e, 3]
rec.off = sd[e, 4]
rec.sl = sd[e, 5]
""",
    "place": """\
if start and signs[j] == 0.0:
    return j
code, x, y = slide_root(rec, signs[j], P, P[rec.vertex, 0], P[rec.vertex, 1])
if code != OK:
    return j
P[rec.vertex, 0] = x
P[rec.vertex, 1] = y
""",
    "step": """\
code = slide_step(rec, signs[k], P0, V0, Vp, P1, V1, A1, h, c2, want_acc, checks)
if code != OK:
    return code, k, iters
""",
    "check": """\
sg = slide_sign(rec, P1)
if sg == 0.0 or (sg > 0.0) != (signs[k] > 0.0):
    return SIGN, k
""",
    "sign": "out[k] = np.sign(slide_sign(rec, P))\n",
    # the vectorised first pass (per sample: the line's geometry depends on the slide's kind)
    "vector": """\
if slide_vector(rec, signs[k], X, Y, VX, VY, Q, M, P, V, h, closed):
    return k
""",
    "singular": """\
v = rec.vertex
c = rec.a
s = blk[k, 3]
_, jpx, jpy, jax, jay, jbx, jby = slide_row(P, s, topo.slide, sd)
jx, jy = slide_partial(topo.slide, s, v, jpx, jpy, jax, jay, jbx, jby)
ex = P[v, 0] - P[c, 0]
ey = P[v, 1] - P[c, 1]
det = ex * jy - ey * jx
if not (abs(det) > tol * (abs(ex * jy) + abs(ey * jx))):
    return k
""",
    # the forces effect: λ_d 2(v − c) + λ_s J = R_v, its distance row's and slide row's multipliers
    "reactions": """\
v = rec.vertex
c = rec.a
e = blk[k, 2]
s = blk[k, 3]
sl = topo.slide
_, jpx, jpy, jax, jay, jbx, jby = slide_row(P, s, sl, sd)
jx, jy = slide_partial(sl, s, v, jpx, jpy, jax, jay, jbx, jby)
ex = P[v, 0] - P[c, 0]
ey = P[v, 1] - P[c, 1]
det = ex * jy - ey * jx
if det == 0.0:
    return k
inv = 1.0 / det
for r in range(R.shape[0]):
    if act[r]:
        rx = R[r, v, 0]
        ry = R[r, v, 1]
        l1 = (rx * jy - ry * jx) * inv
        l2 = (ex * ry - ey * rx) * inv
        lam_d[r, e] = 0.5 * l1
        lam_s[r, s] = l2
        R[r, v, 0] = 0.0
        R[r, v, 1] = 0.0
        R[r, c, 0] += ex * l1
        R[r, c, 1] += ey * l1
        for vv, gx, gy in ((sl[s, 0], jpx, jpy), (sl[s, 1], jax, jay), (sl[s, 2], jbx, jby)):
            if vv >= 0 and vv != v:
                R[r, vv, 0] -= gx * l2
                R[r, vv, 1] -= gy * l2
""",
}

#: no generated (scalar) form yet: plans with sliders run the table-driven kernels
SCALAR = None
