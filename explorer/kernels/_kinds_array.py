"""The table-driven kernels' per-block dispatch: rendered from the block kinds by ``explorer.kernels._render``;
do not edit (edit the kind's module in ``explorer/kinds``, then ``python -m explorer.kernels._render``).
"""

import math

import numpy as np
from numba import njit

from explorer.kinds._common import MAX_MOVE, OK, SIGN, SUSPECT, frame_point, gap_suspect
from explorer.kinds.attach import attach_vector
from explorer.kinds.dyad import FOLD_SIN, dyad_acc, dyad_fill, dyad_good, dyad_sign, dyad_vector, place_dyad
from explorer.kinds.eq_slide import slide_row
from explorer.kinds.gears import gear_place, gear_vector
from explorer.kinds.general import general_reactions, general_sign, general_solve
from explorer.kinds.slide import slide_partial, slide_root, slide_sign, slide_step, slide_vector

#: the dense method's check: a dyad on the mirror root at a fold (not a branch change)
FOLD = -1


@njit(cache=True)
def block_table(tab, kind, blk, tip, dist, uv, sd, extra, att_vpq, slide, P, cx, cy, scale, crank):
    """Fill the block table of one design, tab (nb,) records of ``BLOCK_DTYPE`` (zeros) in plan order,
    each block by its kind from its row of the lowered plan (``blk``) and the design's numbers: dist
    (n_dist,), uv (n_attach, 2), sd (n_slide, 6), extra (n_extra,) (``Designs``); P (n_vertices, 2) its
    start (fixed vertices in place); (cx, cy), scale: its crank centre and radius; crank: whether the
    driver is a crank."""
    nb = kind.shape[0]
    for k in range(nb):
        rec = tab[k]
        rec.kind = kind[k]
        row = blk[k]
        if rec.kind == 0:  # DYAD
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
        elif rec.kind == 1:  # ATTACH
            t = row[3]
            rec.vertex = att_vpq[t, 0]
            rec.a = att_vpq[t, 1]
            rec.b = att_vpq[t, 2]
            rec.u = uv[t, 0]
            rec.v = uv[t, 1]
        elif rec.kind == 2:  # GENERAL
            rec.slot = row[0]
        elif rec.kind == 3:  # SLIDE
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
        elif rec.kind == 4:  # GEARS
            o = row[4]
            rec.vertex = row[0]
            rec.a = row[1]
            rec.gx = extra[o]
            rec.gy = extra[o + 1]
            rec.gr = extra[o + 2]
            rec.gph = extra[o + 3]
            rec.gn = row[3]
            rec.ccx = cx
            rec.ccy = cy
            rec.cr = scale


@njit(cache=True)
def place_closed(tab, tip, cx, cy, scale, d, signs, P, start):
    """Place the driven vertex at (cx, cy) + scale * d[:2], then every block of the block table
    ``tab`` in order by its kind's closed form on the side ``signs[j]``. Writes P (n_vertices, 2) in
    place; returns the first block it could not place, or −1.

    start: placing a design's start for Newton (the kernels' first sample): then it also stops,
    leaving that vertex and the later ones where they were, at a block with no closed form (GENERAL)
    or with no branch to keep (sign 0), which Newton places from there."""
    P[tip, 0] = cx + scale * d[0]
    P[tip, 1] = cy + scale * d[1]
    for j in range(tab.shape[0]):
        rec = tab[j]
        if rec.kind == 0:  # DYAD
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
        elif rec.kind == 1:  # ATTACH
            a = rec.a
            b = rec.b
            P[rec.vertex, 0], P[rec.vertex, 1] = frame_point(rec.u, rec.v, P[a, 0], P[a, 1], P[b, 0], P[b, 1])
        elif rec.kind == 2:  # GENERAL
            return j
        elif rec.kind == 3:  # SLIDE
            if start and signs[j] == 0.0:
                return j
            code, x, y = slide_root(rec, signs[j], P, P[rec.vertex, 0], P[rec.vertex, 1])
            if code != OK:
                return j
            P[rec.vertex, 0] = x
            P[rec.vertex, 1] = y
        elif rec.kind == 4:  # GEARS
            t = rec.a
            P[rec.vertex, 0], P[rec.vertex, 1], _, _, _, _ = gear_place(P[t, 0], P[t, 1], rec.ccx, rec.ccy, rec.gx, rec.gy,
                                                                       rec.gr, rec.gn, rec.gph)
    return -1


@njit(cache=True, inline="always")
def fast_step(table, signs, P0, V0, Vp, P1, V1, A1, h, hp, tol, maxit, want_acc, checks):
    """Place every block of the block table ``table`` (kinds with no generic context) in order at the
    new driver position (already in P1). Returns (code, failing block or −1, iterations)."""
    iters = 0
    c2 = 0.5 * h * h / hp if hp != 0.0 else 0.0
    tol2 = tol * tol
    for k in range(table.shape[0]):
        rec = table[k]
        if rec.kind == 0:  # DYAD
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
        elif rec.kind == 1:  # ATTACH
            v = rec.vertex
            a = rec.a
            b = rec.b
            u = rec.u
            w = rec.v
            P1[v, 0], P1[v, 1] = frame_point(u, w, P1[a, 0], P1[a, 1], P1[b, 0], P1[b, 1])
            V1[v, 0], V1[v, 1] = frame_point(u, w, V1[a, 0], V1[a, 1], V1[b, 0], V1[b, 1])
            if want_acc:
                A1[v, 0], A1[v, 1] = frame_point(u, w, A1[a, 0], A1[a, 1], A1[b, 0], A1[b, 1])
        elif rec.kind == 3:  # SLIDE
            code = slide_step(rec, signs[k], P0, V0, Vp, P1, V1, A1, h, c2, want_acc, checks)
            if code != OK:
                return code, k, iters
        elif rec.kind == 4:  # GEARS
            v = rec.vertex
            t = rec.a
            P1[v, 0], P1[v, 1], V1[v, 0], V1[v, 1], ax_, ay_ = gear_place(P1[t, 0], P1[t, 1], rec.ccx, rec.ccy, rec.gx, rec.gy,
                                                                         rec.gr, rec.gn, rec.gph)
            if want_acc:
                A1[v, 0] = ax_
                A1[v, 1] = ay_
    return OK, -1, iters


@njit(cache=True)
def block_step(ctx, signs, P0, V0, Vp, P1, V1, A1, h, hp, tol, maxit, want_acc, checks):
    """Place every block of ``ctx.table`` (any kind; ``ctx`` a ``_step.GenericContext``) in order at
    the new driver position. Returns (code, failing block or −1, iterations)."""
    iters = 0
    c2 = 0.5 * h * h / hp if hp != 0.0 else 0.0
    tol2 = tol * tol
    table = ctx.table
    for k in range(table.shape[0]):
        rec = table[k]
        if rec.kind == 0:  # DYAD
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
        elif rec.kind == 1:  # ATTACH
            v = rec.vertex
            a = rec.a
            b = rec.b
            u = rec.u
            w = rec.v
            P1[v, 0], P1[v, 1] = frame_point(u, w, P1[a, 0], P1[a, 1], P1[b, 0], P1[b, 1])
            V1[v, 0], V1[v, 1] = frame_point(u, w, V1[a, 0], V1[a, 1], V1[b, 0], V1[b, 1])
            if want_acc:
                A1[v, 0], A1[v, 1] = frame_point(u, w, A1[a, 0], A1[a, 1], A1[b, 0], A1[b, 1])
        elif rec.kind == 2:  # GENERAL
            code, it = general_solve(ctx, k, signs, P0, V0, Vp, P1, V1, A1, h, hp, tol, maxit, want_acc, checks)
            iters += it
            if code != OK:
                return code, k, iters
        elif rec.kind == 3:  # SLIDE
            code = slide_step(rec, signs[k], P0, V0, Vp, P1, V1, A1, h, c2, want_acc, checks)
            if code != OK:
                return code, k, iters
        elif rec.kind == 4:  # GEARS
            v = rec.vertex
            t = rec.a
            P1[v, 0], P1[v, 1], V1[v, 0], V1[v, 1], ax_, ay_ = gear_place(P1[t, 0], P1[t, 1], rec.ccx, rec.ccy, rec.gx, rec.gy,
                                                                         rec.gr, rec.gn, rec.gph)
            if want_acc:
                A1[v, 0] = ax_
                A1[v, 1] = ay_
    return OK, -1, iters


@njit(cache=True)
def check_dense(ctx, signs, P0, V0, P1, V1, h, checks):
    """The per-block branch, gap and move checks on a full-system solution. Returns (code, block);
    code FOLD marks a dyad on the mirror root at a fold (not a branch change: both roots meet there)."""
    table = ctx.table
    for k in range(table.shape[0]):
        rec = table[k]
        if rec.kind == 0:  # DYAD
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
        elif rec.kind == 2:  # GENERAL
            g = rec.slot
            sg = general_sign(P1, ctx.gen_verts[ctx.gen_vptr[g]:ctx.gen_vptr[g + 1]],
                              ctx.gen_rows[ctx.gen_rptr[g]:ctx.gen_rptr[g + 1]], ctx.dist_a, ctx.dist_b, ctx.att_vpq,
                              ctx.uv, ctx.slide, ctx.sd, ctx.loc, ctx.M, ctx.rhs)
            if sg == 0.0 or (sg > 0.0) != (signs[k] > 0.0):
                return SIGN, k
        elif rec.kind == 3:  # SLIDE
            sg = slide_sign(rec, P1)
            if sg == 0.0 or (sg > 0.0) != (signs[k] > 0.0):
                return SIGN, k
    return OK, -1


@njit(cache=True)
def block_signs(P, table, gen_vptr, gen_verts, gen_rptr, gen_rows, dist_a, dist_b, att_vpq, uv, slide, sd):
    """Branch sign (+1.0 / −1.0, 0.0 if singular or without a branch) of every block at positions P."""
    nb = table.shape[0]
    out = np.zeros(nb)
    n = 2 * P.shape[0]
    loc = np.full(P.shape[0], -1, dtype=np.int64)
    M = np.empty((n, n))
    rhs = np.empty(n)
    for k in range(nb):
        rec = table[k]
        if rec.kind == 0:  # DYAD
            out[k] = np.sign(dyad_sign(P, rec.vertex, rec.a, rec.b))
        elif rec.kind == 2:  # GENERAL
            g = rec.slot
            out[k] = general_sign(P, gen_verts[gen_vptr[g]:gen_vptr[g + 1]], gen_rows[gen_rptr[g]:gen_rptr[g + 1]],
                                  dist_a, dist_b, att_vpq, uv, slide, sd, loc, M, rhs)
        elif rec.kind == 3:  # SLIDE
            out[k] = np.sign(slide_sign(rec, P))
    return out


@njit(cache=True)
def place_explicit(table, explicit, P1, V1, A1, want_acc):
    """Place the blocks ``explicit`` (kinds that place their vertex from the driver alone, ``EXPLICIT``)
    at the driver's new position (already in P1, V1, A1): the dense method then takes them as known."""
    for q in range(explicit.shape[0]):
        k = explicit[q]
        rec = table[k]
        if rec.kind == 4:  # GEARS
            v = rec.vertex
            t = rec.a
            P1[v, 0], P1[v, 1], V1[v, 0], V1[v, 1], ax_, ay_ = gear_place(P1[t, 0], P1[t, 1], rec.ccx, rec.ccy, rec.gx, rec.gy,
                                                                         rec.gr, rec.gn, rec.gph)
            if want_acc:
                A1[v, 0] = ax_
                A1[v, 1] = ay_


@njit(cache=True, nogil=True)
def vector_blocks(tab, signs, X, Y, VX, VY, Q, M, P, V, h, closed, first):
    """The vectorised first pass over one design's blocks (``explorer.kernels._vector``): each block of
    the block table ``tab`` from block ``first`` on, in order, over every sample at once by its kind's closed form on the side
    ``signs[k]``, with its tangents, from the rows of X, Y (positions) and VX, VY (tangents),
    (n_vertices, S) each, into its own rows, then its checks between samples a step h apart
    (``closed``: the last and the first too). Q, M (S,), P, V (n_vertices, 2): scratch. Returns the
    first block that flags the design (leave it to Newton), or −1. Only for plans whose every kind has
    a vector form (``_vector.applies``)."""
    for k in range(first, tab.shape[0]):
        rec = tab[k]
        if rec.kind == 0:  # DYAD
            if dyad_vector(rec.vertex, rec.a, rec.b, rec.da2, rec.db2, rec.hi2, rec.lo2, rec.lim2, rec.gap != 0, signs[k],
                           X, Y, VX, VY, Q, M, h, closed):
                return k
        elif rec.kind == 1:  # ATTACH
            attach_vector(rec.vertex, rec.a, rec.b, rec.u, rec.v, X, Y, VX, VY)
        elif rec.kind == 3:  # SLIDE
            if slide_vector(rec, signs[k], X, Y, VX, VY, Q, M, P, V, h, closed):
                return k
        elif rec.kind == 4:  # GEARS
            gear_vector(rec.vertex, rec.a, rec.ccx, rec.ccy, rec.gx, rec.gy, rec.gr, rec.gn, rec.gph, X, Y, VX, VY)
    return -1


@njit(cache=True, nogil=True)
def vector_good(tab, X, Y, VX, VY, h, closed, good_at, good_to):
    """Where a design the first pass flagged passes its blocks' checks, sample by sample (``_vector.
    restart_points``): each block of ``tab`` by its kind's ``good`` snippet clears good_at[k] (S,) where
    sample k fails a check and good_to[k] where the step from sample k to k + 1 does (X, Y, VX, VY
    (n_vertices, S): its rows, as ``vector_blocks`` left them). Returns False where a block's kind does
    not tell its checks sample by sample (no ``good`` snippet: Newton then solves the whole sweep)."""
    for k in range(tab.shape[0]):
        rec = tab[k]
        if rec.kind == 0:  # DYAD
            dyad_good(rec.vertex, rec.a, rec.b, rec.da2, rec.db2, rec.hi2, rec.lo2, rec.lim2, rec.gap != 0, X, Y, VX, VY, h, closed,
                      good_at, good_to)
        elif rec.kind == 1:  # ATTACH
            pass  # its vector form flags nothing
        elif rec.kind == 4:  # GEARS
            pass  # its vector form flags nothing
        else:
            return False
    return True


@njit(cache=True, nogil=True)
def singular_closed(table, topo, uv, sd, P, loc, M, x, tol):
    """The forces effect's check at positions P: the first block whose Jacobian is singular (for a
    dyad or a slider, |det| ≤ tol × the sum of its terms' sizes), or −1."""
    blk = topo.blk
    for k in range(table.shape[0]):
        rec = table[k]
        if rec.kind == 0:  # DYAD
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
        elif rec.kind == 3:  # SLIDE
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
    return -1


@njit(cache=True, nogil=True)
def singular_any(table, topo, uv, sd, P, loc, M, x, tol):
    """The forces effect's check at positions P: the first block whose Jacobian is singular (for a
    dyad or a slider, |det| ≤ tol × the sum of its terms' sizes), or −1."""
    blk = topo.blk
    for k in range(table.shape[0]):
        rec = table[k]
        if rec.kind == 0:  # DYAD
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
        elif rec.kind == 2:  # GENERAL
            g = rec.slot
            if general_sign(P, topo.gen_verts[topo.gen_vptr[g]:topo.gen_vptr[g + 1]],
                            topo.gen_rows[topo.gen_rptr[g]:topo.gen_rptr[g + 1]], topo.dist_a, topo.dist_b, topo.att_vpq, uv,
                            topo.slide, sd, loc, M, x) == 0.0:
                return k
        elif rec.kind == 3:  # SLIDE
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
    return -1


@njit(cache=True, nogil=True)
def reactions_closed(table, topo, uv, sd, P, R, act, lam_d, lam_a, lam_s, loc, M, x):
    """The forces effect's multipliers: Φ_qᵀ λ = R solved block by block in reverse plan order for
    every right-hand side r with act[r] (R (nr, n_vertices, 2) the loads, left holding what the plan's
    constraints do not carry: the crank's force on the tip, the frame's on the fixed vertices). Each
    block's multipliers by its kind into lam_d (nr, n_dist), lam_a (nr, n_attach, 2), lam_s (nr, n_slide),
    in the equation types' convention. Returns the first singular block or −1."""
    blk = topo.blk
    for k in range(table.shape[0] - 1, -1, -1):
        rec = table[k]
        if rec.kind == 0:  # DYAD
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
        elif rec.kind == 1:  # ATTACH
            t = blk[k, 3]
            j = rec.vertex
            p = rec.a
            q = rec.b
            u = rec.u
            w = rec.v
            for r in range(R.shape[0]):
                if act[r]:
                    lx = R[r, j, 0]
                    ly = R[r, j, 1]
                    lam_a[r, t, 0] = lx
                    lam_a[r, t, 1] = ly
                    R[r, j, 0] = 0.0
                    R[r, j, 1] = 0.0
                    atx = u * lx + w * ly  # Aᵀ λ with A = [[u, −w], [w, u]]
                    aty = -w * lx + u * ly
                    R[r, p, 0] += lx - atx
                    R[r, p, 1] += ly - aty
                    R[r, q, 0] += atx
                    R[r, q, 1] += aty
        elif rec.kind == 3:  # SLIDE
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
    return -1


@njit(cache=True, nogil=True)
def reactions_any(table, topo, uv, sd, P, R, act, lam_d, lam_a, lam_s, loc, M, x):
    """The forces effect's multipliers: Φ_qᵀ λ = R solved block by block in reverse plan order for
    every right-hand side r with act[r] (R (nr, n_vertices, 2) the loads, left holding what the plan's
    constraints do not carry: the crank's force on the tip, the frame's on the fixed vertices). Each
    block's multipliers by its kind into lam_d (nr, n_dist), lam_a (nr, n_attach, 2), lam_s (nr, n_slide),
    in the equation types' convention. Returns the first singular block or −1."""
    blk = topo.blk
    for k in range(table.shape[0] - 1, -1, -1):
        rec = table[k]
        if rec.kind == 0:  # DYAD
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
        elif rec.kind == 1:  # ATTACH
            t = blk[k, 3]
            j = rec.vertex
            p = rec.a
            q = rec.b
            u = rec.u
            w = rec.v
            for r in range(R.shape[0]):
                if act[r]:
                    lx = R[r, j, 0]
                    ly = R[r, j, 1]
                    lam_a[r, t, 0] = lx
                    lam_a[r, t, 1] = ly
                    R[r, j, 0] = 0.0
                    R[r, j, 1] = 0.0
                    atx = u * lx + w * ly  # Aᵀ λ with A = [[u, −w], [w, u]]
                    aty = -w * lx + u * ly
                    R[r, p, 0] += lx - atx
                    R[r, p, 1] += ly - aty
                    R[r, q, 0] += atx
                    R[r, q, 1] += aty
        elif rec.kind == 2:  # GENERAL
            if not general_reactions(rec.slot, topo, uv, sd, P, R, act, lam_d, lam_a, lam_s, loc, M, x):
                return k
        elif rec.kind == 3:  # SLIDE
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
    return -1
