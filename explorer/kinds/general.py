"""GENERAL: several vertices coupled in a loop (an Assur triad, a body that is part of a loop, a slot
inside a loop), solved together: Newton on the block's rows with a step limit, the branch the sign of
the block's Jacobian determinant; rates and reactions from the same Jacobian (dense LU of the block's
size). Its rows are the equation types' (``eq_distance``, ``eq_attach``, ``eq_slide``), each written
once there: residual, gradient and rate terms in one convention.

It has no closed form: a design's start stops at its first coupled block (Newton starts from the
nominal's configuration there), and plans with one run the table-driven kernels.
"""

import numpy as np
from numba import njit

from . import eq_attach, eq_distance, eq_slide
from ._common import MAX_MOVE, NOCONV, OK, ROUNDING, SIGN, SUSPECT, lu_solve
from .eq_slide import slide_row

NAME = "GENERAL"
NUMBER = 2
TEXT = "joints coupled in a loop, solved together (Newton)"
#: its column of ``Topology.blk``: its index into the coupled blocks' CSR tables (``Topology.gen_*``)
COLUMNS = ("slot",)
READS = ()
FIELDS = (("slot", "i8"),)
#: a design's start stops here (no closed form)
START = "stop"
#: the nominal's first assembly failing here is a Newton failure, not a proof that it cannot assemble
FAILS_AS = "no-convergence"
#: its snippets read the generic context (``ctx``: the coupled blocks' tables and scratch)
CONTEXT = True

#: row type codes of a coupled block's rows (``Topology.gen_rows[:, 0]``), by equation type and row
ROW_CODES = {("distance", 0): eq_distance.ROW, ("attach", 0): eq_attach.ROW_X, ("attach", 1): eq_attach.ROW_Y,
             ("slide", 0): eq_slide.ROW}


def classify(vertices, rows, tables) -> bool:
    """Anything the other kinds do not take (tried last)."""
    return True


def lower(plan, block, crank: bool, shared: dict) -> tuple:
    """Its slot: its index into the coupled blocks' CSR tables, which it extends (``shared["gen"]``:
    vertex pointers, vertices, row pointers, rows (row type code, equation), read by
    ``explorer.kernels._inputs.topology``)."""
    vptr, verts, rptr, rows = shared.setdefault("gen", ([0], [], [0], []))
    slot = len(vptr) - 1
    verts.extend(block.vertices)
    rows.extend((ROW_CODES[(typ, ax)], e) for typ, e, ax in block.rows)
    vptr.append(len(verts))
    rptr.append(len(rows))
    return (slot,)


def assemble(k, P, ctx):
    """Damped Newton on the block from the guess; False if it does not converge."""
    blk = ctx.plan.blocks[k]
    g = ctx.topo.blk[k, 0]
    rows = ctx.topo.gen_rows[ctx.topo.gen_rptr[g]:ctx.topo.gen_rptr[g + 1]]
    Z = np.zeros_like(P)
    P1 = P.copy()
    code, _ = solve_general(P, Z, Z, P1, Z.copy(), Z.copy(), np.array(blk.vertices), rows, ctx.plan.link_a,
                            ctx.plan.link_b, ctx.plan.attach, ctx.des.dist[0], ctx.des.uv[0], ctx.topo.slide,
                            ctx.des.slide[0], 0.0, 0.0, ctx.tol, 200, 0.0, False, False, ctx.loc, ctx.M, ctx.rhs)
    if code != 0:
        return False
    P[:] = P1
    return True


def branch(k, P, ctx) -> float:
    g = ctx.topo.blk[k, 0]
    t = ctx.topo
    return general_sign(P, t.gen_verts[t.gen_vptr[g]:t.gen_vptr[g + 1]], t.gen_rows[t.gen_rptr[g]:t.gen_rptr[g + 1]],
                        t.dist_a, t.dist_b, t.att_vpq, ctx.des.uv[0], t.slide, ctx.des.slide[0], ctx.loc, ctx.M, ctx.rhs)


# -- numerics ------------------------------------------------------------------------------------
@njit(cache=True)
def _general_jacobian(P, verts, rows, dist_a, dist_b, att_vpq, uv, slide, sd, loc, M):
    """Jacobian of a general block's rows w.r.t. its own vertices (columns 2·loc + axis): each row's
    gradient from its equation type."""
    n = 2 * verts.shape[0]
    for i in range(n):
        for j in range(n):
            M[i, j] = 0.0
    for r in range(rows.shape[0]):
        typ = rows[r, 0]
        e = rows[r, 1]
        if typ == eq_distance.ROW:
            eq_distance.jacobian(P, e, dist_a, dist_b, loc, M, r)
        elif typ == eq_slide.ROW:
            eq_slide.jacobian(P, e, slide, sd, loc, M, r)
        else:
            eq_attach.jacobian(e, 0 if typ == eq_attach.ROW_X else 1, att_vpq, uv, loc, M, r)


@njit(cache=True)
def general_sign(P, verts, rows, dist_a, dist_b, att_vpq, uv, slide, sd, loc, M, rhs):
    """Sign of the determinant of a general block's Jacobian at P (its branch sign); 0.0 if singular."""
    for j in range(verts.shape[0]):
        loc[verts[j]] = j
    _general_jacobian(P, verts, rows, dist_a, dist_b, att_vpq, uv, slide, sd, loc, M)
    for j in range(verts.shape[0]):
        loc[verts[j]] = -1
    return lu_solve(M, rhs, 2 * verts.shape[0])


@njit(cache=True)
def solve_general(P0, V0, Vp, P1, V1, A1, verts, rows, dist_a, dist_b, att_vpq, L, uv, slide, sd, h, hp, tol, maxit,
                  sign_ref, want_acc, checks, loc, M, rhs):
    """Newton on one coupled block (e.g. an Assur triad, or a body inside a loop) with a step limit;
    then its tangent.

    ``verts`` are the block's vertices and ``rows`` its equations (``Topology.gen_rows``); ``loc``
    (n_vertices,) is scratch filled with −1, ``M`` and ``rhs`` are scratch of at least the block's
    size. Returns (code, iterations).
    """
    nb = verts.shape[0]
    n = 2 * nb
    shortest = np.inf
    for r in range(rows.shape[0]):
        if rows[r, 0] == eq_distance.ROW:
            shortest = min(shortest, L[rows[r, 1]])
        elif rows[r, 0] == eq_slide.ROW:
            if slide[rows[r, 1], 1] >= 0:
                shortest = min(shortest, sd[rows[r, 1], 5])
        else:
            t = rows[r, 1]
            p = att_vpq[t, 1]
            q = att_vpq[t, 2]
            for e in range(dist_a.shape[0]):  # the body's base distance
                if (dist_a[e] == p and dist_b[e] == q) or (dist_a[e] == q and dist_b[e] == p):
                    shortest = min(shortest, L[e])
    lim = MAX_MOVE * shortest
    ref = shortest if shortest < np.inf else 1e12 * tol  # a slide row's residual is a distance
    for j in range(nb):
        v = verts[j]
        loc[v] = j
        c = 0.5 * h * h / hp if hp != 0.0 else 0.0
        P1[v, 0] = P0[v, 0] + h * V0[v, 0] + c * (V0[v, 0] - Vp[v, 0])
        P1[v, 1] = P0[v, 1] + h * V0[v, 1] + c * (V0[v, 1] - Vp[v, 1])
    code = OK
    it = 0
    while True:
        worst = 0.0
        for r in range(rows.shape[0]):
            typ = rows[r, 0]
            if typ == eq_distance.ROW:
                res, d2 = eq_distance.residual(P1, rows[r, 1], dist_a, dist_b, L)
                rhs[r] = -res
                worst = max(worst, abs(res) / d2)
            elif typ == eq_slide.ROW:
                res = slide_row(P1, rows[r, 1], slide, sd)[0]
                rhs[r] = -res
                worst = max(worst, abs(res) / ref)
            else:
                res = eq_attach.residual(P1, rows[r, 1], 0 if typ == eq_attach.ROW_X else 1, att_vpq, uv)
                rhs[r] = -res
                worst = max(worst, abs(res) / shortest)
        if worst <= ROUNDING:
            break
        if it >= maxit:
            code = NOCONV
            break
        _general_jacobian(P1, verts, rows, dist_a, dist_b, att_vpq, uv, slide, sd, loc, M)
        if lu_solve(M, rhs, n) == 0.0:
            code = NOCONV
            break
        norm = 0.0
        for j in range(nb):
            norm = max(norm, rhs[2 * j] * rhs[2 * j] + rhs[2 * j + 1] * rhs[2 * j + 1])
        s = 1.0 if norm <= lim * lim else lim / np.sqrt(norm)
        for j in range(nb):
            P1[verts[j], 0] += s * rhs[2 * j]
            P1[verts[j], 1] += s * rhs[2 * j + 1]
        it += 1
        if norm <= tol * tol:  # the correction just kept moved no vertex further than tol: converged
            break
    if code == OK:
        sgn = general_sign(P1, verts, rows, dist_a, dist_b, att_vpq, uv, slide, sd, loc, M, rhs)
        for j in range(nb):
            loc[verts[j]] = j
        if sgn == 0.0 or (sign_ref != 0.0 and (sgn > 0.0) != (sign_ref > 0.0)):
            code = SIGN
        elif checks:
            for j in range(nb):
                v = verts[j]
                mx = P1[v, 0] - (P0[v, 0] + h * V0[v, 0])
                my = P1[v, 1] - (P0[v, 1] + h * V0[v, 1])
                if mx * mx + my * my > 4.0 * lim * lim:
                    code = SUSPECT
    if code == OK:
        general_rates(P1, V1, A1, verts, rows, dist_a, dist_b, att_vpq, uv, slide, sd, loc, M, rhs, False)
        if want_acc:
            general_rates(P1, V1, A1, verts, rows, dist_a, dist_b, att_vpq, uv, slide, sd, loc, M, rhs, True)
    for j in range(nb):
        loc[verts[j]] = -1
    return code, it


@njit(cache=True)
def general_rates(P, V, A, verts, rows, dist_a, dist_b, att_vpq, uv, slide, sd, loc, M, rhs, accel):
    """Tangent (accel=False: V) or second derivative (accel=True: A) of a general block's vertices:
    the block's Jacobian times the unknown rates equals each row's right-hand side (its equation
    type's ``rates_rhs``: the known (upstream) vertices' terms and the curvature)."""
    nb = verts.shape[0]
    _general_jacobian(P, verts, rows, dist_a, dist_b, att_vpq, uv, slide, sd, loc, M)
    R = A if accel else V
    for r in range(rows.shape[0]):
        typ = rows[r, 0]
        e = rows[r, 1]
        if typ == eq_slide.ROW:
            rhs[r] = eq_slide.rates_rhs(P, V, R, e, slide, sd, loc, accel)
        elif typ == eq_distance.ROW:
            rhs[r] = eq_distance.rates_rhs(P, V, R, e, dist_a, dist_b, loc, accel)
        else:
            rhs[r] = eq_attach.rates_rhs(R, e, 0 if typ == eq_attach.ROW_X else 1, att_vpq, uv, loc)
    lu_solve(M, rhs, 2 * nb)
    for j in range(nb):
        R[verts[j], 0] = rhs[2 * j]
        R[verts[j], 1] = rhs[2 * j + 1]


@njit(cache=True)
def general_solve(ctx, k, signs, P0, V0, Vp, P1, V1, A1, h, hp, tol, maxit, want_acc, checks):
    """:func:`solve_general` of block k of the table in ``ctx`` (a ``GenericContext``)."""
    g = ctx.table[k].slot
    return solve_general(P0, V0, Vp, P1, V1, A1, ctx.gen_verts[ctx.gen_vptr[g]:ctx.gen_vptr[g + 1]],
                         ctx.gen_rows[ctx.gen_rptr[g]:ctx.gen_rptr[g + 1]], ctx.dist_a, ctx.dist_b, ctx.att_vpq,
                         ctx.dist, ctx.uv, ctx.slide, ctx.sd, h, hp, tol, maxit, signs[k], want_acc, checks, ctx.loc,
                         ctx.M, ctx.rhs)


@njit(cache=True)
def general_reactions(g, topo, uv, sd, P, R, act, lam_d, lam_a, lam_s, loc, M, x):
    """The forces effect: the multipliers of coupled block g's rows for every right-hand side r with
    act[r] (R (nr, nv, 2) the loads on its vertices): its Jacobian (``_general_jacobian``) transposed,
    solved per right-hand side; each row's pull on the vertices outside the block (its equation type's
    gradient times the multiplier) moves to them. False if the Jacobian is singular."""
    verts = topo.gen_verts[topo.gen_vptr[g]:topo.gen_vptr[g + 1]]
    rows = topo.gen_rows[topo.gen_rptr[g]:topo.gen_rptr[g + 1]]
    dist_a = topo.dist_a
    dist_b = topo.dist_b
    att = topo.att_vpq
    slide = topo.slide
    nb = verts.shape[0]
    n = 2 * nb
    for j in range(nb):
        loc[verts[j]] = j
    ok = True
    for rr in range(R.shape[0]):
        if not act[rr]:
            continue
        _general_jacobian(P, verts, rows, dist_a, dist_b, att, uv, slide, sd, loc, M)
        for r in range(n):  # transpose in place
            for c in range(r + 1, n):
                t = M[r, c]
                M[r, c] = M[c, r]
                M[c, r] = t
        for j in range(nb):
            x[2 * j] = R[rr, verts[j], 0]
            x[2 * j + 1] = R[rr, verts[j], 1]
            R[rr, verts[j], 0] = 0.0
            R[rr, verts[j], 1] = 0.0
        if lu_solve(M, x, n) == 0.0:
            ok = False
            break
        for r in range(n):  # store the multipliers; push what the rows put on vertices outside the block
            typ = rows[r, 0]
            e = rows[r, 1]
            lam = x[r]
            if typ == eq_slide.ROW:
                lam_s[rr, e] = lam
                _, jpx, jpy, jax, jay, jbx, jby = slide_row(P, e, slide, sd)
                for vv, gx, gy in ((slide[e, 0], jpx, jpy), (slide[e, 1], jax, jay), (slide[e, 2], jbx, jby)):
                    if vv >= 0 and loc[vv] < 0:
                        R[rr, vv, 0] -= gx * lam
                        R[rr, vv, 1] -= gy * lam
            elif typ == eq_distance.ROW:
                lam_d[rr, e] = lam
                a = dist_a[e]
                b = dist_b[e]
                gx = 2.0 * (P[b, 0] - P[a, 0])
                gy = 2.0 * (P[b, 1] - P[a, 1])
                if loc[a] < 0:
                    R[rr, a, 0] += gx * lam
                    R[rr, a, 1] += gy * lam
                if loc[b] < 0:
                    R[rr, b, 0] -= gx * lam
                    R[rr, b, 1] -= gy * lam
            else:
                ax = 0 if typ == eq_attach.ROW_X else 1
                lam_a[rr, e, ax] = lam
                u = uv[e, 0]
                w = uv[e, 1]
                j_ = att[e, 0]
                p = att[e, 1]
                q = att[e, 2]
                # the row's gradient: e_ax on j, (A − I) row ax on p, −A row ax on q (A = [[u, −w], [w, u]])
                a0 = u if ax == 0 else w
                a1 = -w if ax == 0 else u
                if loc[j_] < 0:
                    R[rr, j_, ax] -= lam
                if loc[p] < 0:
                    R[rr, p, 0] -= (a0 - (1.0 if ax == 0 else 0.0)) * lam
                    R[rr, p, 1] -= (a1 - (1.0 if ax == 1 else 0.0)) * lam
                if loc[q] < 0:
                    R[rr, q, 0] += a0 * lam
                    R[rr, q, 1] += a1 * lam
    for j in range(nb):
        loc[verts[j]] = -1
    return ok


ARRAY = {
    "imports": "from explorer.kinds.general import general_reactions, general_sign, general_solve",
    "fill": "rec.slot = row[0]\n",
    "place": "return j\n",
    "step": """\
code, it = general_solve(ctx, k, signs, P0, V0, Vp, P1, V1, A1, h, hp, tol, maxit, want_acc, checks)
iters += it
if code != OK:
    return code, k, iters
""",
    "check": """\
g = rec.slot
sg = general_sign(P1, ctx.gen_verts[ctx.gen_vptr[g]:ctx.gen_vptr[g + 1]],
                  ctx.gen_rows[ctx.gen_rptr[g]:ctx.gen_rptr[g + 1]], ctx.dist_a, ctx.dist_b, ctx.att_vpq,
                  ctx.uv, ctx.slide, ctx.sd, ctx.loc, ctx.M, ctx.rhs)
if sg == 0.0 or (sg > 0.0) != (signs[k] > 0.0):
    return SIGN, k
""",
    "sign": """\
g = rec.slot
out[k] = general_sign(P, gen_verts[gen_vptr[g]:gen_vptr[g + 1]], gen_rows[gen_rptr[g]:gen_rptr[g + 1]],
                      dist_a, dist_b, att_vpq, uv, slide, sd, loc, M, rhs)
""",
    "singular": """\
g = rec.slot
if general_sign(P, topo.gen_verts[topo.gen_vptr[g]:topo.gen_vptr[g + 1]],
                topo.gen_rows[topo.gen_rptr[g]:topo.gen_rptr[g + 1]], topo.dist_a, topo.dist_b, topo.att_vpq, uv,
                topo.slide, sd, loc, M, x) == 0.0:
    return k
""",
    "reactions": """\
if not general_reactions(rec.slot, topo, uv, sd, P, R, act, lam_d, lam_a, lam_s, loc, M, x):
    return k
""",
}

SCALAR = None
