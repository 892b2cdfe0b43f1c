"""Per-block Newton solves, tangents and checks (Numba, pure: arrays in, arrays out).

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
def _general_jacobian(P, verts, links, link_a, link_b, loc, M):
    """Unscaled Jacobian of a general block's link equations w.r.t. its own vertices (rows: links)."""
    n = 2 * verts.shape[0]
    for i in range(n):
        for j in range(n):
            M[i, j] = 0.0
    for r in range(links.shape[0]):
        e = links[r]
        u = link_a[e]
        w = link_b[e]
        gx = P[w, 0] - P[u, 0]
        gy = P[w, 1] - P[u, 1]
        if loc[u] >= 0:
            M[r, 2 * loc[u]] -= 2.0 * gx
            M[r, 2 * loc[u] + 1] -= 2.0 * gy
        if loc[w] >= 0:
            M[r, 2 * loc[w]] += 2.0 * gx
            M[r, 2 * loc[w] + 1] += 2.0 * gy


@njit(cache=True)
def general_sign(P, verts, links, link_a, link_b, loc, M, rhs):
    """Sign of the determinant of a general block's Jacobian at P (its branch sign); 0.0 if singular."""
    for j in range(verts.shape[0]):
        loc[verts[j]] = j
    _general_jacobian(P, verts, links, link_a, link_b, loc, M)
    for j in range(verts.shape[0]):
        loc[verts[j]] = -1
    return lu_solve(M, rhs, 2 * verts.shape[0])


@njit(cache=True)
def solve_general(P0, V0, Vp, P1, V1, A1, verts, links, link_a, link_b, L, h, hp, tol, maxit, sign_ref,
                  want_acc, checks, loc, M, rhs):
    """Newton on one coupled block (e.g. an Assur triad) with a step limit; then its tangent.

    ``verts`` and ``links`` are the block's vertex and link indices; ``loc`` (n_vertices,) is scratch
    filled with −1, ``M`` and ``rhs`` are scratch of at least the block's size. Returns (code, iterations).
    """
    nb = verts.shape[0]
    n = 2 * nb
    shortest = np.inf
    for r in range(links.shape[0]):
        shortest = min(shortest, L[links[r]])
    lim = MAX_MOVE * shortest
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
        for r in range(links.shape[0]):
            e = links[r]
            u = link_a[e]
            w = link_b[e]
            gx = P1[w, 0] - P1[u, 0]
            gy = P1[w, 1] - P1[u, 1]
            d2 = L[e] * L[e]
            rhs[r] = d2 - (gx * gx + gy * gy)
            worst = max(worst, abs(rhs[r]) / d2)
        if worst <= ROUNDING:
            break
        if it >= maxit:
            code = NOCONV
            break
        _general_jacobian(P1, verts, links, link_a, link_b, loc, M)
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
        sgn = general_sign(P1, verts, links, link_a, link_b, loc, M, rhs)
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
        _general_rates(P1, V1, A1, verts, links, link_a, link_b, loc, M, rhs, False)
        if want_acc:
            _general_rates(P1, V1, A1, verts, links, link_a, link_b, loc, M, rhs, True)
    for j in range(nb):
        loc[verts[j]] = -1
    return code, it


@njit(cache=True)
def _general_rates(P, V, A, verts, links, link_a, link_b, loc, M, rhs, accel):
    """Tangent (accel=False: V) or second derivative (accel=True: A) of a general block's vertices.

    Differentiating (p_w − p_u)·(p_w − p_u) = d² once gives (p_w − p_u)·(v_w − v_u) = 0; twice gives
    (p_w − p_u)·(a_w − a_u) = −|v_w − v_u|². Known (upstream) vertices move to the right-hand side.
    """
    nb = verts.shape[0]
    _general_jacobian(P, verts, links, link_a, link_b, loc, M)
    for r in range(links.shape[0]):
        e = links[r]
        u = link_a[e]
        w = link_b[e]
        gx = P[w, 0] - P[u, 0]
        gy = P[w, 1] - P[u, 1]
        val = 0.0
        if accel:
            wx = V[w, 0] - V[u, 0]
            wy = V[w, 1] - V[u, 1]
            val = -2.0 * (wx * wx + wy * wy)
            if loc[u] < 0:
                val += 2.0 * (gx * A[u, 0] + gy * A[u, 1])
            if loc[w] < 0:
                val -= 2.0 * (gx * A[w, 0] + gy * A[w, 1])
        else:
            if loc[u] < 0:
                val += 2.0 * (gx * V[u, 0] + gy * V[u, 1])
            if loc[w] < 0:
                val -= 2.0 * (gx * V[w, 0] + gy * V[w, 1])
        rhs[r] = val
    lu_solve(M, rhs, 2 * nb)
    out = A if accel else V
    for j in range(nb):
        out[verts[j], 0] = rhs[2 * j]
        out[verts[j], 1] = rhs[2 * j + 1]
