"""The GENERAL block kind (Newton on a coupled block), and what every kind shares: step codes, the
between-sample gap check, the dense LU (Numba, pure: arrays in, arrays out).

Conventions shared by every kernel:

* ``P``, ``V``, ``A`` are (n_vertices, 2) arrays of positions, dV/dθ and d²V/dθ² (model units,
  per radian, per radian²).
* ``tol`` is a distance (model units): Newton stops once it has applied a correction that moves no
  vertex of the block further than ``tol``. Newton converges quadratically, so the error left after
  such a correction is of the order of its square: every solved vertex is within ``tol`` of the
  exact root (the runners pass tolerance × the design's longest link). It also stops when every
  scaled residual is at rounding level (:data:`ROUNDING`), where no closer position exists.
* Return codes: OK, INFEASIBLE (a dyad's two circles do not meet: the design cannot assemble here),
  SIGN (the block's branch sign differs from the reference), NOCONV (Newton did not converge),
  SUSPECT (this step may have skipped over trouble: refine it).
"""

import numpy as np
from numba import njit

from ..plan import ROW_ATTACH_X, ROW_DIST, ROW_SLIDE

OK = 0
INFEASIBLE = 1
SIGN = 2
NOCONV = 3
SUSPECT = 4

# A predictor or Newton correction longer than this fraction of the block's shortest link means the
# step is too coarse for the local geometry: refine it instead of trusting where Newton lands.
MAX_MOVE = 0.25
# A scaled residual (|p_w − p_u|² − d²)/d² this small is rounding: no floating-point position is
# closer to the root, so Newton stops there too. It matters only next to a fold (a double root),
# where the position is fixed by the lengths to about sqrt(rounding) and no correction gets shorter
# than that; elsewhere it bounds the position error by ~1e-15 d / sin(angle at the joint).
ROUNDING = 1e-15
# A Hermite-interpolated squared parent distance within this relative margin of a dyad's assembly
# limit makes the step SUSPECT (it may hide a gap between samples).
GAP_MARGIN = 1e-6


@njit(cache=True, inline="always")
def _hermite_extremes(q0, m0, q1, m1, h):
    """Min and max over t∈[0, 1] of the cubic Hermite interpolant of q (values q0, q1, slopes m0, m1 per radian) on a step h."""
    c1 = h * m0
    c2 = -3.0 * q0 - 2.0 * h * m0 + 3.0 * q1 - h * m1
    c3 = 2.0 * q0 + h * m0 - 2.0 * q1 + h * m1
    lo = min(q0, q1)
    hi = max(q0, q1)
    # roots of c1 + 2 c2 t + 3 c3 t² = 0 in (0, 1)
    a = 3.0 * c3
    b = 2.0 * c2
    if abs(a) > 1e-300:
        disc = b * b - 4.0 * a * c1
        if disc >= 0.0:
            sq = np.sqrt(disc)
            for t in ((-b - sq) / (2.0 * a), (-b + sq) / (2.0 * a)):
                if 0.0 < t < 1.0:
                    val = q0 + t * (c1 + t * (c2 + t * c3))
                    lo = min(lo, val)
                    hi = max(hi, val)
    elif abs(b) > 1e-300:
        t = -c1 / b
        if 0.0 < t < 1.0:
            val = q0 + t * (c1 + t * c2)
            lo = min(lo, val)
            hi = max(hi, val)
    return lo, hi


@njit(cache=True)
def gap_suspect(q0, m0, q1, m1, h, hi2, lo2):
    """True if a dyad's squared parent distance q may leave [lo2, hi2] between two samples a step h apart.

    q0, q1 are its values and m0, m1 its slopes dq/dparameter at the two ends. A cheap bound comes
    first (the Hermite basis overshoots by at most 4/27·|h|·(|m0| + |m1|)); only when it cannot rule
    trouble out are the extremes of the cubic Hermite interpolant computed.
    """
    ext = (4.0 / 27.0) * abs(h) * (abs(m0) + abs(m1))
    if max(q0, q1) + ext < hi2 * (1.0 - GAP_MARGIN) and min(q0, q1) - ext > lo2 * (1.0 + GAP_MARGIN):
        return False
    lo, hi = _hermite_extremes(q0, m0, q1, m1, h)
    return hi >= hi2 * (1.0 - GAP_MARGIN) or lo <= lo2 * (1.0 + GAP_MARGIN)


@njit(cache=True)
def dyad_sign(P, v, a, b):
    """Orientation cross(b − a, p − a) of dyad vertex v against its parents a, b (its branch sign)."""
    return (P[b, 0] - P[a, 0]) * (P[v, 1] - P[a, 1]) - (P[b, 1] - P[a, 1]) * (P[v, 0] - P[a, 0])


@njit(cache=True)
def lu_solve(M, rhs, n):
    """Solve M[:n, :n] x = rhs[:n] in place by Gaussian elimination with partial pivoting.

    M is destroyed; rhs holds x on return. Returns the sign of det(M) (0.0 if singular).
    """
    sign = 1.0
    for k in range(n):
        p = k
        best = abs(M[k, k])
        for i in range(k + 1, n):
            if abs(M[i, k]) > best:
                best = abs(M[i, k])
                p = i
        if best == 0.0:
            return 0.0
        if p != k:
            sign = -sign
            for j in range(n):
                t = M[k, j]
                M[k, j] = M[p, j]
                M[p, j] = t
            t = rhs[k]
            rhs[k] = rhs[p]
            rhs[p] = t
        if M[k, k] < 0.0:
            sign = -sign
        for i in range(k + 1, n):
            f = M[i, k] / M[k, k]
            if f != 0.0:
                for j in range(k + 1, n):
                    M[i, j] -= f * M[k, j]
                rhs[i] -= f * rhs[k]
    for k in range(n - 1, -1, -1):
        s = rhs[k]
        for j in range(k + 1, n):
            s -= M[k, j] * rhs[j]
        rhs[k] = s / M[k, k]
    return sign


@njit(cache=True)
def slide_eval(ground, px, py, ax, ay, bx, by, lx, ly, nx, ny, off, L):
    """A slide equation's residual and partial derivatives: (r, ∂r/∂p (x, y), ∂r/∂a, ∂r/∂b).

    Ground line through (lx, ly) along the unit (nx, ny): r = n × (p − l) − off (a and b unused, their
    partials 0). Slot along a → b, |b − a| = L: r = cross(b − a, p − a)/L − off (bilinear: affine in
    each of p, a, b alone, so each partial is free of that vertex's own position)."""
    if ground:
        return nx * (py - ly) - ny * (px - lx) - off, -ny, nx, 0.0, 0.0, 0.0, 0.0
    gx = bx - ax
    gy = by - ay
    r = (gx * (py - ay) - gy * (px - ax)) / L - off
    return r, -gy / L, gx / L, (by - py) / L, (px - bx) / L, (py - ay) / L, (ax - px) / L


@njit(cache=True)
def slide_row(P, k, slide, sd):
    """:func:`slide_eval` of slide equation k at positions P (n_vertices, 2); slide (n_slide, 3) and sd
    (n_slide, 6): ``_inputs.Topology.slide`` and ``Designs.slide``."""
    p = slide[k, 0]
    a = slide[k, 1]
    b = slide[k, 2]
    if a < 0:
        return slide_eval(True, P[p, 0], P[p, 1], 0.0, 0.0, 0.0, 0.0, sd[k, 0], sd[k, 1], sd[k, 2], sd[k, 3],
                          sd[k, 4], sd[k, 5])
    return slide_eval(False, P[p, 0], P[p, 1], P[a, 0], P[a, 1], P[b, 0], P[b, 1], sd[k, 0], sd[k, 1], sd[k, 2],
                      sd[k, 3], sd[k, 4], sd[k, 5])


@njit(cache=True)
def slide_curvature(V, k, slide, sd):
    """The slide equation's second-derivative term 2 cross(v_b − v_a, v_p − v_a)/L at rates V (0 for a
    ground line): its rows obey J·A = −this."""
    a = slide[k, 1]
    b = slide[k, 2]
    if a < 0:
        return 0.0
    p = slide[k, 0]
    return 2.0 * ((V[b, 0] - V[a, 0]) * (V[p, 1] - V[a, 1]) - (V[b, 1] - V[a, 1]) * (V[p, 0] - V[a, 0])) / sd[k, 5]


@njit(cache=True)
def _row_ends(row, dist_a, dist_b, att_vpq):
    """(type, first vertex, second vertex, third vertex or −1) of a GENERAL block's row."""
    typ = row[0]
    e = row[1]
    if typ == ROW_DIST:
        return typ, dist_a[e], dist_b[e], -1
    return typ, att_vpq[e, 0], att_vpq[e, 1], att_vpq[e, 2]


@njit(cache=True)
def _general_jacobian(P, verts, rows, dist_a, dist_b, att_vpq, uv, slide, sd, loc, M):
    """Jacobian of a general block's rows w.r.t. its own vertices (columns 2·loc + axis).

    A distance row is |p_w − p_u|² − d² (unscaled); an attach row is the x or y component of
    p_j − p_p − u (p_q − p_p) − v R(p_q − p_p), linear in the positions; a slide row is
    :func:`slide_eval`'s residual.
    """
    n = 2 * verts.shape[0]
    for i in range(n):
        for j in range(n):
            M[i, j] = 0.0
    for r in range(rows.shape[0]):
        if rows[r, 0] == ROW_SLIDE:
            k = rows[r, 1]
            _, jpx, jpy, jax, jay, jbx, jby = slide_row(P, k, slide, sd)
            for c, gx, gy in ((slide[k, 0], jpx, jpy), (slide[k, 1], jax, jay), (slide[k, 2], jbx, jby)):
                if c >= 0 and loc[c] >= 0:
                    M[r, 2 * loc[c]] += gx
                    M[r, 2 * loc[c] + 1] += gy
            continue
        typ, u, w, z = _row_ends(rows[r], dist_a, dist_b, att_vpq)
        if typ == ROW_DIST:
            gx = P[w, 0] - P[u, 0]
            gy = P[w, 1] - P[u, 1]
            if loc[u] >= 0:
                M[r, 2 * loc[u]] -= 2.0 * gx
                M[r, 2 * loc[u] + 1] -= 2.0 * gy
            if loc[w] >= 0:
                M[r, 2 * loc[w]] += 2.0 * gx
                M[r, 2 * loc[w] + 1] += 2.0 * gy
        else:
            # joint u, base p = w, q = z; x row: j.x − p.x − cu (q.x − p.x) + cv (q.y − p.y)
            cu = uv[rows[r, 1], 0]
            cv = uv[rows[r, 1], 1]
            ax = 0 if typ == ROW_ATTACH_X else 1
            oth = 1 - ax
            sv = 1.0 if ax == 0 else -1.0  # the sign of the cv term on the other axis
            if loc[u] >= 0:
                M[r, 2 * loc[u] + ax] += 1.0
            if loc[w] >= 0:
                M[r, 2 * loc[w] + ax] += cu - 1.0
                M[r, 2 * loc[w] + oth] -= sv * cv
            if loc[z] >= 0:
                M[r, 2 * loc[z] + ax] -= cu
                M[r, 2 * loc[z] + oth] += sv * cv


@njit(cache=True)
def _attach_residual(P, row, att_vpq, uv):
    """The x or y component of p_j − (p_p + u (p_q − p_p) + v R(p_q − p_p)) for an attach row."""
    t = row[1]
    j = att_vpq[t, 0]
    p = att_vpq[t, 1]
    q = att_vpq[t, 2]
    gx = P[q, 0] - P[p, 0]
    gy = P[q, 1] - P[p, 1]
    if row[0] == ROW_ATTACH_X:
        return P[j, 0] - (P[p, 0] + uv[t, 0] * gx - uv[t, 1] * gy)
    return P[j, 1] - (P[p, 1] + uv[t, 0] * gy + uv[t, 1] * gx)


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

    ``verts`` are the block's vertices and ``rows`` its equations (``_inputs.Topology.gen_rows``);
    ``loc`` (n_vertices,) is scratch filled with −1, ``M`` and ``rhs`` are scratch of at least the
    block's size. Returns (code, iterations).
    """
    nb = verts.shape[0]
    n = 2 * nb
    shortest = np.inf
    for r in range(rows.shape[0]):
        if rows[r, 0] == ROW_DIST:
            shortest = min(shortest, L[rows[r, 1]])
        elif rows[r, 0] == ROW_SLIDE:
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
            if rows[r, 0] == ROW_DIST:
                e = rows[r, 1]
                u = dist_a[e]
                w = dist_b[e]
                gx = P1[w, 0] - P1[u, 0]
                gy = P1[w, 1] - P1[u, 1]
                d2 = L[e] * L[e]
                rhs[r] = d2 - (gx * gx + gy * gy)
                worst = max(worst, abs(rhs[r]) / d2)
            elif rows[r, 0] == ROW_SLIDE:
                res = slide_row(P1, rows[r, 1], slide, sd)[0]
                rhs[r] = -res
                worst = max(worst, abs(res) / ref)
            else:
                res = _attach_residual(P1, rows[r], att_vpq, uv)
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
        _general_rates(P1, V1, A1, verts, rows, dist_a, dist_b, att_vpq, uv, slide, sd, loc, M, rhs, False)
        if want_acc:
            _general_rates(P1, V1, A1, verts, rows, dist_a, dist_b, att_vpq, uv, slide, sd, loc, M, rhs, True)
    for j in range(nb):
        loc[verts[j]] = -1
    return code, it


@njit(cache=True)
def _general_rates(P, V, A, verts, rows, dist_a, dist_b, att_vpq, uv, slide, sd, loc, M, rhs, accel):
    """Tangent (accel=False: V) or second derivative (accel=True: A) of a general block's vertices.

    Differentiating (p_w − p_u)·(p_w − p_u) = d² once gives (p_w − p_u)·(v_w − v_u) = 0; twice gives
    (p_w − p_u)·(a_w − a_u) = −|v_w − v_u|². An attach row is linear: its rates obey the same row
    with the rates in place of the positions; a slide row gives J·V = 0 and J·A = −(its curvature
    term, :func:`slide_curvature`). Known (upstream) vertices move to the right-hand side.
    """
    nb = verts.shape[0]
    _general_jacobian(P, verts, rows, dist_a, dist_b, att_vpq, uv, slide, sd, loc, M)
    R = A if accel else V
    for r in range(rows.shape[0]):
        if rows[r, 0] == ROW_SLIDE:
            k = rows[r, 1]
            _, jpx, jpy, jax, jay, jbx, jby = slide_row(P, k, slide, sd)
            val = -slide_curvature(V, k, slide, sd) if accel else 0.0
            for c, gx, gy in ((slide[k, 0], jpx, jpy), (slide[k, 1], jax, jay), (slide[k, 2], jbx, jby)):
                if c >= 0 and loc[c] < 0:
                    val -= gx * R[c, 0] + gy * R[c, 1]
            rhs[r] = val
            continue
        typ, u, w, z = _row_ends(rows[r], dist_a, dist_b, att_vpq)
        val = 0.0
        if typ == ROW_DIST:
            gx = P[w, 0] - P[u, 0]
            gy = P[w, 1] - P[u, 1]
            if accel:
                wx = V[w, 0] - V[u, 0]
                wy = V[w, 1] - V[u, 1]
                val = -2.0 * (wx * wx + wy * wy)
            if loc[u] < 0:
                val += 2.0 * (gx * R[u, 0] + gy * R[u, 1])
            if loc[w] < 0:
                val -= 2.0 * (gx * R[w, 0] + gy * R[w, 1])
        else:
            # minus the row's terms in known vertices (the rates of the unknown ones are solved for)
            cu = uv[rows[r, 1], 0]
            cv = uv[rows[r, 1], 1]
            ax = 0 if typ == ROW_ATTACH_X else 1
            oth = 1 - ax
            sv = 1.0 if ax == 0 else -1.0
            if loc[u] < 0:
                val -= R[u, ax]
            if loc[w] < 0:
                val -= (cu - 1.0) * R[w, ax] - sv * cv * R[w, oth]
            if loc[z] < 0:
                val -= -cu * R[z, ax] + sv * cv * R[z, oth]
        rhs[r] = val
    lu_solve(M, rhs, 2 * nb)
    for j in range(nb):
        R[verts[j], 0] = rhs[2 * j]
        R[verts[j], 1] = rhs[2 * j + 1]
