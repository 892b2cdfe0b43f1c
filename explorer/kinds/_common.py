"""What every block kind shares: the step codes, the step limits, the between-sample gap check, the
frame point of a pair, and the dense LU (Numba, pure: scalars or arrays in, results out).

Conventions shared by every kind and kernel:

* ``P``, ``V``, ``A`` are (n_vertices, 2) arrays of positions, dV/dθ and d²V/dθ² (model units,
  per radian, per radian²).
* ``tol`` is a distance (model units): Newton stops once it has applied a correction that moves no
  vertex of the block further than ``tol``. Newton converges quadratically, so the error left after
  such a correction is of the order of its square: every solved vertex is within ``tol`` of the
  exact root (the runners pass tolerance × the design's longest link). It also stops when every
  scaled residual is at rounding level (:data:`ROUNDING`), where no closer position exists.
* Step codes: OK, INFEASIBLE (a dyad's two circles do not meet: the design cannot assemble here),
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
    """True if a squared distance q may leave [lo2, hi2] between two samples a step h apart.

    q0, q1 are its values and m0, m1 its slopes dq/dparameter at the two ends. A cheap bound comes
    first (the Hermite basis overshoots by at most 4/27·|h|·(|m0| + |m1|)); only when it cannot rule
    trouble out are the extremes of the cubic Hermite interpolant computed.
    """
    ext = (4.0 / 27.0) * abs(h) * (abs(m0) + abs(m1))
    if max(q0, q1) + ext < hi2 * (1.0 - GAP_MARGIN) and min(q0, q1) - ext > lo2 * (1.0 + GAP_MARGIN):
        return False
    lo, hi = _hermite_extremes(q0, m0, q1, m1, h)
    return hi >= hi2 * (1.0 - GAP_MARGIN) or lo <= lo2 * (1.0 + GAP_MARGIN)


@njit(cache=True, error_model="numpy")
def vector_moves(xv, yv, uv, wv, h, closed, lim2):
    """The vectorised first pass's move limit for one block (``explorer.kernels._vector``): True if
    between two samples a step h apart (``closed``: the last and the first as well) its vertex, at
    xv, yv with tangents uv, wv (S,), moves further than √lim2 from its linear prediction (the sweep's
    largest move). A branch-free pass."""
    S = xv.shape[0]
    bad = 0
    for k in range(S - 1):
        mx = xv[k + 1] - xv[k] - h * uv[k]
        my = yv[k + 1] - yv[k] - h * wv[k]
        bad += mx * mx + my * my > lim2
    if closed:
        mx = xv[0] - xv[S - 1] - h * uv[S - 1]
        my = yv[0] - yv[S - 1] - h * wv[S - 1]
        bad += mx * mx + my * my > lim2
    return bad > 0


@njit(cache=True, error_model="numpy")
def vector_gaps(Q, M, h, closed, hi2, lo2):
    """The vectorised first pass's gap bound for one block: True if between two samples a step h apart
    (``closed``: the last and the first as well) a squared distance Q (S,) of slope M (S,) per unit of
    the parameter may leave [lo2, hi2]: the cheap Hermite bound of :func:`gap_suspect` as a branch-free
    pass, and where it cannot rule a gap out, the interpolant's extremes."""
    S = Q.shape[0]
    hi = hi2 * (1.0 - GAP_MARGIN)
    lo = lo2 * (1.0 + GAP_MARGIN)
    c = (4.0 / 27.0) * abs(h)
    near = 0
    for k in range(S - 1):
        ext = c * (abs(M[k]) + abs(M[k + 1]))
        near += (max(Q[k], Q[k + 1]) + ext >= hi) | (min(Q[k], Q[k + 1]) - ext <= lo)
    if closed:
        near += gap_suspect(Q[S - 1], M[S - 1], Q[0], M[0], h, hi2, lo2)
    if near:
        for k in range(S - 1):
            if gap_suspect(Q[k], M[k], Q[k + 1], M[k + 1], h, hi2, lo2):
                return True
        return closed and gap_suspect(Q[S - 1], M[S - 1], Q[0], M[0], h, hi2, lo2)
    return False


@njit(cache=True, forceinline=True)
def frame_point(u, w, ax, ay, bx, by):
    """The point (u, w) of the frame of a → b: a + u (b − a) + w R(b − a), R a quarter turn
    counter-clockwise. A body joint from its base pair (and, applied to tangents or second
    derivatives, its rates); a dyad's vertex from its parents (its closed form)."""
    gx = bx - ax
    gy = by - ay
    return ax + u * gx - w * gy, ay + u * gy + w * gx


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


def other_end(plan, e: int, v: int) -> int:
    """The vertex at the other end of distance equation e from v."""
    return int(plan.link_b[e] if plan.link_a[e] == v else plan.link_a[e])
