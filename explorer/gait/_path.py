"""Path error: how far a design's foot path is from a target path given as points.

The objective ``path_error`` of path synthesis (``explorer optimize``). Everything here is in model
units and radians; shapes use N designs, S crank samples, M target points.

The foot path
-------------
``foot`` (N, S, 2) holds each design's foot at the crank angles θ_k = 2πk/S, k = 0 … S−1: one closed
cycle of a crank-driven mechanism (sample S is sample 0 again). Between samples the path is

* with ``velocity`` (N, S, 2), dF/dθ per radian at the same samples (``Cycle.velocities``, the batch
  kernel's velocities): the cubic Hermite interpolant of positions and velocities on each step
  h = 2π/S. Its error is at most h⁴/384 · max|d⁴F/dθ⁴| (for a foot on a circle of radius R driven at
  a constant rate, R·h⁴/384: 2.4e-10 R at S = 360);
* without: straight segments (the polyline through the samples). Their error is at most
  h²/8 · max|d²F/dθ²| (R·h²/8 = 3.8e-5 R for that circle at S = 360).

The derivative bounds are along the path; they grow near a near-singular position of the linkage
(where the foot speeds up sharply), so a design that nearly locks is interpolated less well.

Matching (``match``)
--------------------
The target is M points q_i (M, 2). Each is compared with one point of the foot path, its *match*:

``"timed"``
    q_i is compared with the foot at crank angle ``angles[i]`` (radians, the crank angle θ of
    :class:`~explorer.Crank`: counter-clockwise from +x; ``angle_offset`` (N,) is added per design,
    for parametrisations whose crank angle is measured from a rotated frame), interpolated as above.
    With a *free phase* (``phase = "free"``) the angles are known up to a common shift ψ (a closed
    curve timed at even steps from a start nobody prescribes): each design is compared at angles[i] + ψ
    with its own best ψ (least sum of squared distances: the best of 64 evenly spaced shifts, the best
    three refined by Gauss–Newton on ψ).
``"closest"``
    q_i is compared with the point of the closed foot path closest to it (each point independently:
    no order, no timing). The path point is found on the segment whose chord is closest to q_i and
    its two neighbours (Newton on the Hermite cubic, or the exact projection on a straight segment).
    The result is exact to rounding, except where another, non-neighbouring part of the path lies
    within 2 × (chord sag) of the same distance; the error is then below that: 2 · h²/8 ·
    max|d²F/dθ²| at most.
``"arc"``
    by arc length, in the direction of motion. Let L_i be the length of the target polyline
    q_0 → … → q_i (cumulative chord lengths, L_0 = 0) and f_i = L_i / L_{M−1} (the target's points
    must not all coincide). On the foot path, let a_0 be the point closest to q_0 and a_e the point
    closest to q_{M−1}, and Λ the arc length from a_0 forward (increasing θ) to a_e, in (0, A] (A the
    whole cycle; Λ = A when a_e = a_0, e.g. a closed target that repeats its first point). q_i is
    compared with the foot point at arc length f_i · Λ forward of a_0. A target that is a whole loop
    is thus spread over the whole cycle, a partial one (a stance line) over the stretch of path it
    faces. Arc lengths of Hermite segments are 5-point Gauss–Legendre sums (straight segments: chord
    lengths).

What the match ignores (``ignore``)
-----------------------------------
Any subset of {"translation", "rotation", "scale"}: the error is measured after the best similarity
T(p) = s·R(φ)·p + t of that kind moves the foot path onto the target (s > 0, a rotation without
reflection), so it stays in the target's units. What is not ignored stays fixed: t = 0, φ = 0, s = 1
(without translation, rotation and scale act about the model origin).

* timed: T is the closed-form least-squares fit (Umeyama/Procrustes, restricted to the kinds ignored).
* closest: the error is min over T of the RMS distance from the q_i to T(foot path), found by
  alternating matching and fitting: Gauss–Newton (Levenberg–Marquardt damped) steps on the
  point-to-tangent-line distances, which converge quadratically near an exact fit, each step accepted
  only if the matched error goes down. It starts from the design as it is (T = identity) and from
  moment-aligned starts (centroids, RMS radii, and rotations 0°, 90°, 180°, 270° when rotation is
  ignored); every start gets :data:`START_ROUNDS` rounds, the best goes on for at most
  :data:`MAX_ROUNDS`. A local search: the best transform is not guaranteed to be global.
* arc: the same starts, alternating the arc matching with the closed-form fit, while the error
  goes down.

Result
------
``path_error`` returns the RMS over the M target points of the distance from q_i to its (transformed)
match, (N,), model units; NaN for a design whose foot (or velocity, when given) has a NaN.
``path_residuals`` returns the M distances (N, M); ``path_match`` everything, with the matched crank
angles and the transform. Each design's result depends on that design alone, bit for bit, however the
designs are batched.
"""

from __future__ import annotations

import csv
import math
from dataclasses import dataclass
from pathlib import Path
from typing import NamedTuple

import numpy as np
from numba import njit

from ..errors import UserError, where
from ..kernels import parallel_rows

#: The ways of matching target points with the foot path.
MATCHES = ("timed", "closest", "arc")
#: What a match may ignore.
IGNORES = ("translation", "rotation", "scale")
#: Rounds of matching and fitting each start gets (closest and arc matching with ``ignore``).
START_ROUNDS = 3
#: Most rounds of matching and fitting in all (the best start goes on until it stops improving).
MAX_ROUNDS = 60
#: Segments per bounding circle in the closest-point search (pruning only; results do not depend on it).
_BLOCK = 12
#: A design's search stops when a round lowers its RMS error by no more than _RTOL × the error +
#: _ATOL × the target's RMS radius about its centroid.
_RTOL = 1e-9
_ATOL = 1e-14


class PathMatch(NamedTuple):
    """Everything :func:`path_match` finds, for N designs and M target points.

    error : (N,) RMS distance over the target points, model units (NaN: the foot path has a NaN).
    distances : (N, M) distance from each target point to its (transformed) match.
    theta : (N, M) crank angle of each match, radians in [0, 2π).
    points : (N, M, 2) the matched foot points, untransformed (model units, the design's frame).
    scale, rotation : (N,) s and φ (radians) of the similarity T(p) = s·R(φ)·p + t.
    translation : (N, 2) t, model units.
    """

    error: np.ndarray
    distances: np.ndarray
    theta: np.ndarray
    points: np.ndarray
    scale: np.ndarray
    rotation: np.ndarray
    translation: np.ndarray


# ---------------------------------------------------------------------------------------------
# Numba kernels: the foot path between samples, the closest point, the arc-length matching
# ---------------------------------------------------------------------------------------------

@njit(cache=True, nogil=True)
def _coeffs(P, V, hermite, h, k):
    """Coefficients of the foot path on segment k (sample k to k+1, cyclic) as c(u) = a0 + a1·u +
    a2·u² + a3·u³, u in [0, 1]: the cubic Hermite interpolant, or the straight chord."""
    S = P.shape[0]
    k1 = k + 1
    if k1 == S:
        k1 = 0
    p0x = P[k, 0]
    p0y = P[k, 1]
    p1x = P[k1, 0]
    p1y = P[k1, 1]
    if hermite:
        m0x = h * V[k, 0]
        m0y = h * V[k, 1]
        m1x = h * V[k1, 0]
        m1y = h * V[k1, 1]
        return (p0x, p0y, m0x, m0y,
                -3.0 * p0x - 2.0 * m0x + 3.0 * p1x - m1x, -3.0 * p0y - 2.0 * m0y + 3.0 * p1y - m1y,
                2.0 * p0x + m0x - 2.0 * p1x + m1x, 2.0 * p0y + m0y - 2.0 * p1y + m1y)
    return (p0x, p0y, p1x - p0x, p1y - p0y, 0.0, 0.0, 0.0, 0.0)


@njit(cache=True, nogil=True)
def _speed(c, u):
    """|dc/du| at u."""
    dx = c[2] + u * (2.0 * c[4] + 3.0 * u * c[6])
    dy = c[3] + u * (2.0 * c[5] + 3.0 * u * c[7])
    return math.sqrt(dx * dx + dy * dy)


# 5-point Gauss–Legendre on [0, 1]
_GL_X = np.array([0.04691007703066800, 0.23076534494715845, 0.5, 0.76923465505284155, 0.95308992296933200])
_GL_W = np.array([0.11846344252809454, 0.23931433524968324, 0.28444444444444444, 0.23931433524968324,
                  0.11846344252809454])


@njit(cache=True, nogil=True)
def _arc(c, u, glx, glw):
    """Arc length of c over [0, u] (5-point Gauss–Legendre; exact for a straight chord)."""
    total = 0.0
    for j in range(5):
        total += glw[j] * _speed(c, u * glx[j])
    return u * total


@njit(cache=True, nogil=True)
def _refine(c, u0, qx, qy):
    """The parameter u in [0, 1] of the point of cubic c closest to q, by safeguarded Newton from u0;
    returns (u, squared distance)."""
    u = u0
    for _ in range(12):
        x = c[0] + u * (c[2] + u * (c[4] + u * c[6])) - qx
        y = c[1] + u * (c[3] + u * (c[5] + u * c[7])) - qy
        dx = c[2] + u * (2.0 * c[4] + 3.0 * u * c[6])
        dy = c[3] + u * (2.0 * c[5] + 3.0 * u * c[7])
        ddx = 2.0 * c[4] + 6.0 * u * c[6]
        ddy = 2.0 * c[5] + 6.0 * u * c[7]
        g = x * dx + y * dy
        v2 = dx * dx + dy * dy
        gp = v2 + x * ddx + y * ddy
        if gp > 1e-300:
            step = -g / gp
        elif v2 > 1e-300:
            step = -g / v2
        else:
            break
        un = min(1.0, max(0.0, u + step))
        if abs(un - u) <= 1e-13:
            u = un
            break
        u = un
    best_u = u
    best = math.inf
    for cand in (u, u0, 0.0, 1.0):
        x = c[0] + cand * (c[2] + cand * (c[4] + cand * c[6])) - qx
        y = c[1] + cand * (c[3] + cand * (c[5] + cand * c[7])) - qy
        d2 = x * x + y * y
        if d2 < best:
            best = d2
            best_u = cand
    return best_u, best


@njit(cache=True, nogil=True)
def _blocks(P, block, cx, cy, cr):
    """Bounding circles of the chords of each block of ``block`` segments (centre = mean vertex)."""
    S = P.shape[0]
    nb = cx.shape[0]
    for b in range(nb):
        lo = b * block
        hi = min(lo + block, S)  # vertices lo … hi (hi cyclic)
        sx = 0.0
        sy = 0.0
        for k in range(lo, hi + 1):
            kk = k % S
            sx += P[kk, 0]
            sy += P[kk, 1]
        n = hi - lo + 1
        mx = sx / n
        my = sy / n
        r2 = 0.0
        for k in range(lo, hi + 1):
            kk = k % S
            dx = P[kk, 0] - mx
            dy = P[kk, 1] - my
            d2 = dx * dx + dy * dy
            if d2 > r2:
                r2 = d2
        cx[b] = mx
        cy[b] = my
        cr[b] = math.sqrt(r2) * (1.0 + 1e-12)


@njit(cache=True, nogil=True)
def _closest(P, V, hermite, h, block, cx, cy, cr, lb, qx, qy):
    """Closest point of the foot path (P, V) to q: returns (segment k, u in [0, 1]). The chord
    closest to q (exact; blocks whose bounding circle is farther than the best chord so far are
    skipped, the nearest block first), then Newton on its Hermite cubic and its two neighbours'.
    lb: scratch, one entry per block."""
    S = P.shape[0]
    nb = cx.shape[0]
    first = 0
    for b in range(nb):
        dx = qx - cx[b]
        dy = qy - cy[b]
        lb[b] = math.sqrt(dx * dx + dy * dy) - cr[b]
        if lb[b] < lb[first]:
            first = b
    best = math.inf
    bk = 0
    bu = 0.0
    for j in range(nb):
        b = first if j == 0 else (j - 1 if j - 1 < first else j)  # every block once, the nearest first
        if j > 0 and lb[b] > 0.0 and lb[b] * lb[b] >= best:
            continue
        lo = b * block
        hi = min(lo + block, S)
        for k in range(lo, hi):
            k1 = k + 1
            if k1 == S:
                k1 = 0
            ax = P[k, 0]
            ay = P[k, 1]
            dx = P[k1, 0] - ax
            dy = P[k1, 1] - ay
            L2 = dx * dx + dy * dy
            u = 0.0
            if L2 > 0.0:
                u = ((qx - ax) * dx + (qy - ay) * dy) / L2
                u = min(1.0, max(0.0, u))
            ex = ax + u * dx - qx
            ey = ay + u * dy - qy
            d2 = ex * ex + ey * ey
            if d2 < best:
                best = d2
                bk = k
                bu = u
    if not hermite:
        return bk, bu
    best = math.inf
    rk = bk
    ru = bu
    for off in (-1, 0, 1):
        k = (bk + off) % S
        c = _coeffs(P, V, True, h, k)
        u0 = bu if off == 0 else (1.0 if off == -1 else 0.0)
        u, d2 = _refine(c, u0, qx, qy)
        if d2 < best:
            best = d2
            rk = k
            ru = u
    return rk, ru


@njit(cache=True, nogil=True)
def _emit(P, V, hermite, h, k, u, theta, point, tangent, n, i):
    """Write the match (segment k, parameter u) of target point i of row n."""
    c = _coeffs(P, V, hermite, h, k)
    point[n, i, 0] = c[0] + u * (c[2] + u * (c[4] + u * c[6]))
    point[n, i, 1] = c[1] + u * (c[3] + u * (c[5] + u * c[7]))
    tangent[n, i, 0] = (c[2] + u * (2.0 * c[4] + 3.0 * u * c[6])) / h
    tangent[n, i, 1] = (c[3] + u * (2.0 * c[5] + 3.0 * u * c[7])) / h
    th = (k + u) * h
    if th >= 2.0 * math.pi:
        th -= 2.0 * math.pi
    theta[n, i] = th


@njit(cache=True, nogil=True)
def _row_ok(P, V, hermite):
    S = P.shape[0]
    for k in range(S):
        if not (math.isfinite(P[k, 0]) and math.isfinite(P[k, 1])):
            return False
        if hermite and not (math.isfinite(V[k, 0]) and math.isfinite(V[k, 1])):
            return False
    return True


@njit(cache=True, nogil=True)
def _closest_rows(hermite, h, block, paths, vels, idx, q, theta, point, tangent):
    """Closest matches of the target points q[n] (R, M, 2), given in the frame of design idx[n]."""
    N = q.shape[0]
    S = paths.shape[1]
    M = q.shape[1]
    nb = (S + block - 1) // block
    cx = np.empty(nb)
    cy = np.empty(nb)
    cr = np.empty(nb)
    lb = np.empty(nb)
    for n in range(N):
        P = paths[idx[n]]
        V = vels[idx[n]]
        ok = _row_ok(P, V, hermite)
        for i in range(M):
            if not (math.isfinite(q[n, i, 0]) and math.isfinite(q[n, i, 1])):
                ok = False
        if not ok:
            for i in range(M):
                theta[n, i] = np.nan
                point[n, i, 0] = np.nan
                point[n, i, 1] = np.nan
                tangent[n, i, 0] = np.nan
                tangent[n, i, 1] = np.nan
            continue
        _blocks(P, block, cx, cy, cr)
        for i in range(M):
            k, u = _closest(P, V, hermite, h, block, cx, cy, cr, lb, q[n, i, 0], q[n, i, 1])
            _emit(P, V, hermite, h, k, u, theta, point, tangent, n, i)


@njit(cache=True, nogil=True)
def _arc_rows(hermite, h, block, glx, glw, frac, paths, vels, idx, ends, theta, point, tangent):
    """Arc-length matches: ends[n] = (first, last) target point in the frame of design idx[n]; frac
    (M,) the target's cumulative chord-length fractions."""
    N = ends.shape[0]
    S = paths.shape[1]
    M = frac.shape[0]
    nb = (S + block - 1) // block
    cx = np.empty(nb)
    cy = np.empty(nb)
    cr = np.empty(nb)
    lb = np.empty(nb)
    seg = np.empty(S)
    cum = np.empty(S + 1)
    for n in range(N):
        P = paths[idx[n]]
        V = vels[idx[n]]
        ok = _row_ok(P, V, hermite)
        for j in range(2):
            if not (math.isfinite(ends[n, j, 0]) and math.isfinite(ends[n, j, 1])):
                ok = False
        if not ok:
            for i in range(M):
                theta[n, i] = np.nan
                point[n, i, 0] = np.nan
                point[n, i, 1] = np.nan
                tangent[n, i, 0] = np.nan
                tangent[n, i, 1] = np.nan
            continue
        _blocks(P, block, cx, cy, cr)
        cum[0] = 0.0
        for k in range(S):
            c = _coeffs(P, V, hermite, h, k)
            seg[k] = _arc(c, 1.0, glx, glw)
            cum[k + 1] = cum[k] + seg[k]
        A = cum[S]
        k0, u0 = _closest(P, V, hermite, h, block, cx, cy, cr, lb, ends[n, 0, 0], ends[n, 0, 1])
        k1, u1 = _closest(P, V, hermite, h, block, cx, cy, cr, lb, ends[n, 1, 0], ends[n, 1, 1])
        a0 = cum[k0] + _arc(_coeffs(P, V, hermite, h, k0), u0, glx, glw)
        a1 = cum[k1] + _arc(_coeffs(P, V, hermite, h, k1), u1, glx, glw)
        span = a1 - a0
        if span < 0.0:
            span += A
        if span <= 1e-12 * A:
            span = A
        for i in range(M):
            a = a0 + frac[i] * span
            a = a % A if A > 0.0 else 0.0
            # the segment holding arc length a
            lo = 0
            hi = S
            while hi - lo > 1:
                mid = (lo + hi) // 2
                if cum[mid] <= a:
                    lo = mid
                else:
                    hi = mid
            k = lo
            r = a - cum[k]
            c = _coeffs(P, V, hermite, h, k)
            u = r / seg[k] if seg[k] > 0.0 else 0.0
            u = min(1.0, max(0.0, u))
            if hermite and seg[k] > 0.0:
                for _ in range(8):
                    sp = _speed(c, u)
                    if sp <= 0.0:
                        break
                    un = min(1.0, max(0.0, u - (_arc(c, u, glx, glw) - r) / sp))
                    if abs(un - u) < 1e-15:
                        u = un
                        break
                    u = un
            _emit(P, V, hermite, h, k, u, theta, point, tangent, n, i)


# ---------------------------------------------------------------------------------------------
# numpy: interpolation at given angles, fits
# ---------------------------------------------------------------------------------------------

def _at_angles(foot, velocity, theta):
    """Foot points (N, M, 2) and tangents dF/dθ at crank angles theta (N, M), interpolated."""
    N, S, _ = foot.shape
    h = 2.0 * math.pi / S
    x = np.mod(theta, 2.0 * math.pi) / h
    k = np.floor(x)
    u = (x - k)[..., None]
    k = np.where(np.isfinite(k), k, 0).astype(np.int64) % S
    k1 = (k + 1) % S
    rows = np.arange(N)[:, None]
    p0 = foot[rows, k]
    p1 = foot[rows, k1]
    if velocity is None:
        return p0 + u * (p1 - p0), (p1 - p0) / h
    m0 = h * velocity[rows, k]
    m1 = h * velocity[rows, k1]
    a2 = -3.0 * p0 - 2.0 * m0 + 3.0 * p1 - m1
    a3 = 2.0 * p0 + m0 - 2.0 * p1 + m1
    pts = p0 + u * (m0 + u * (a2 + u * a3))
    tan = (m0 + u * (2.0 * a2 + 3.0 * u * a3)) / h
    return pts, tan


def _rot(phi):
    c, s = np.cos(phi), np.sin(phi)
    return np.stack([np.stack([c, -s], -1), np.stack([s, c], -1)], -2)  # (..., 2, 2)


def _apply(p, scale, phi, t):
    """T(p) = s·R(φ)·p + t for p (N, M, 2)."""
    c = (scale * np.cos(phi))[:, None]
    s = (scale * np.sin(phi))[:, None]
    x, y = p[..., 0], p[..., 1]
    return np.stack([c * x - s * y + t[:, None, 0], s * x + c * y + t[:, None, 1]], -1)


def _inverse(q, scale, phi, t):
    """T⁻¹(q) for q (N, M, 2)."""
    c = (np.cos(phi) / scale)[:, None]
    s = (np.sin(phi) / scale)[:, None]
    x, y = q[..., 0] - t[:, None, 0], q[..., 1] - t[:, None, 1]
    return np.stack([c * x + s * y, -s * x + c * y], -1)


def _fit(p, q, ignore):
    """Closed-form least-squares similarity (restricted to ``ignore``) moving p (N, M, 2) onto
    q (N, M, 2): returns scale (N,), rotation (N,), translation (N, 2)."""
    N = p.shape[0]
    trans = "translation" in ignore
    if trans:
        mp = p.mean(axis=1)
        mq = q.mean(axis=1)
    else:
        mp = np.zeros((N, 2))
        mq = np.zeros((N, 2))
    X = p - mp[:, None]
    Y = q - mq[:, None]
    dot = np.sum(X * Y, axis=(1, 2))
    cross = np.sum(X[..., 0] * Y[..., 1] - X[..., 1] * Y[..., 0], axis=1)
    xx = np.sum(X * X, axis=(1, 2))
    phi = np.arctan2(cross, dot) if "rotation" in ignore else np.zeros(N)
    if "scale" in ignore:
        with np.errstate(invalid="ignore", divide="ignore"):
            s = (np.cos(phi) * dot + np.sin(phi) * cross) / xx
        # s > 0: a fit that wants s <= 0 (only possible without rotation) takes the smallest scale
        s = np.where(xx > 0, np.maximum(s, 1e-12), 1.0)
    else:
        s = np.ones(N)
    t = mq - s[:, None] * np.einsum("nij,nj->ni", _rot(phi), mp) if trans else np.zeros((N, 2))
    return s, phi, t


def _gn_step(p, tang, q, scale, phi, t, ignore, mu):
    """One Levenberg–Marquardt step of the point-to-tangent-line distances from the targets q to
    T(foot) at the matches p (tangents tang, in the design's frame): returns the new transform.

    The step composes T with ΔT(x) = e^σ·R(δ)·(x − c) + c + δt (c: the target centroid when
    translation is ignored, else the origin), its parameters those that ``ignore`` frees, linearised
    at 0; each residual x_i − q_i is weighted by W = n nᵀ + λ τ τᵀ (n, τ: unit normal and tangent of
    T(foot) at x_i; λ = 1e-3 keeps sliding along a straight target determined; W = I where the path
    has no tangent)."""
    N, M, _ = p.shape
    x = _apply(p, scale, phi, t)
    e = x - q
    c, sn = np.cos(phi)[:, None], np.sin(phi)[:, None]
    tx = c * tang[..., 0] - sn * tang[..., 1]
    ty = sn * tang[..., 0] + c * tang[..., 1]
    tn = np.hypot(tx, ty)
    has = tn > 0
    with np.errstate(invalid="ignore", divide="ignore"):
        tx = np.where(has, tx / tn, 1.0)
        ty = np.where(has, ty / tn, 0.0)
    lam = np.where(has, 1e-3, 1.0)
    trans = "translation" in ignore
    cen = q.mean(axis=1) if trans else np.zeros((N, 2))
    dx = x[..., 0] - cen[:, None, 0]
    dy = x[..., 1] - cen[:, None, 1]
    cols = []  # (jx, jy) of each free parameter, (N, M) each
    if "scale" in ignore:
        cols.append((dx, dy))
    if "rotation" in ignore:
        cols.append((-dy, dx))
    if trans:
        one, zero = np.ones((N, M)), np.zeros((N, M))
        cols.append((one, zero))
        cols.append((zero, one))
    # projections on the normal n = (−τy, τx) and the tangent τ
    Jn = np.stack([-ty * jx + tx * jy for jx, jy in cols], -1)  # (N, M, k)
    Jt = np.stack([tx * jx + ty * jy for jx, jy in cols], -1)
    en = -ty * e[..., 0] + tx * e[..., 1]
    et = tx * e[..., 0] + ty * e[..., 1]
    wl = lam[..., None]
    JnT = Jn.transpose(0, 2, 1)
    JtT = (wl * Jt).transpose(0, 2, 1)
    H = JnT @ Jn + JtT @ Jt
    g = (JnT @ en[..., None] + JtT @ et[..., None])[..., 0]
    k = H.shape[-1]
    diag = np.diagonal(H, axis1=1, axis2=2)
    ref = np.maximum(diag.max(axis=1, keepdims=True), 1e-300)
    A = H + (mu[:, None] * (diag + 1e-12 * ref))[:, :, None] * np.eye(k)
    A = np.where(np.isfinite(A), A, 0.0) + 1e-300 * np.eye(k)
    g = np.where(np.isfinite(g), g, 0.0)
    try:
        delta = -np.linalg.solve(A, g[..., None])[..., 0]
    except np.linalg.LinAlgError:
        delta = -np.einsum("nkl,nl->nk", np.linalg.pinv(A), g)
    j = 0
    sig = np.zeros(N)
    dphi = np.zeros(N)
    dt = np.zeros((N, 2))
    if "scale" in ignore:
        sig = np.clip(delta[:, j], -5.0, 5.0)
        j += 1
    if "rotation" in ignore:
        dphi = delta[:, j]
        j += 1
    if trans:
        dt = delta[:, j:j + 2]
    es = np.exp(sig)
    new_t = es[:, None] * np.einsum("nij,nj->ni", _rot(dphi), t - cen) + cen + dt
    return scale * es, phi + dphi, new_t


def _rms(p, q, scale, phi, t):
    d = np.linalg.norm(_apply(p, scale, phi, t) - q, axis=-1)
    return np.sqrt(np.mean(d * d, axis=1)), d


# ---------------------------------------------------------------------------------------------
# public
# ---------------------------------------------------------------------------------------------

def _foot_and_velocity(foot, velocity):
    """foot (N, S, 2) and velocity (the same shape, or None) as contiguous float64, or a ValueError."""
    foot = np.ascontiguousarray(foot, dtype=np.float64)
    if foot.ndim != 3 or foot.shape[2] != 2 or foot.shape[1] < 3:
        raise ValueError(f"foot: expected shape (N, S, 2) with S >= 3, got {foot.shape}")
    if velocity is not None:
        velocity = np.ascontiguousarray(velocity, dtype=np.float64)
        if velocity.shape != foot.shape:
            raise ValueError(f"velocity: expected shape {foot.shape} (that of foot), got {velocity.shape}")
    return foot, velocity


def _check(foot, velocity, target, angles, match, ignore, angle_offset):
    foot, velocity = _foot_and_velocity(foot, velocity)
    target = np.ascontiguousarray(target, dtype=np.float64)
    if target.ndim != 2 or target.shape[1] != 2 or target.shape[0] < 1:
        raise ValueError(f"target: expected shape (M, 2) with M >= 1, got {target.shape}")
    if not np.all(np.isfinite(target)):
        raise ValueError("target: every coordinate must be finite")
    if match not in MATCHES:
        raise ValueError(f"match: expected one of {', '.join(MATCHES)}, got {match!r}")
    if isinstance(ignore, str):
        ignore = (ignore,)
    ignore = frozenset(ignore)
    bad = ignore - set(IGNORES)
    if bad:
        raise ValueError(f"ignore: unknown {', '.join(sorted(bad))} (allowed: {', '.join(IGNORES)})")
    N = foot.shape[0]
    if match == "timed":
        if angles is None:
            raise ValueError("match 'timed' needs angles (radians), one per target point")
        angles = np.asarray(angles, dtype=np.float64)
        if angles.shape != (target.shape[0],) or not np.all(np.isfinite(angles)):
            raise ValueError(f"angles: expected {target.shape[0]} finite crank angles (radians), "
                             f"got shape {angles.shape}")
        off = np.zeros(N) if angle_offset is None else np.broadcast_to(
            np.asarray(angle_offset, dtype=np.float64), (N,))
        angles = angles[None, :] + off[:, None]
    elif angle_offset is not None:
        raise ValueError(f"angle_offset applies to match 'timed' only, not {match!r}")
    if match == "arc" and target.shape[0] >= 2:
        if not np.sum(np.linalg.norm(np.diff(target, axis=0), axis=1)) > 0:
            raise ValueError("match 'arc' needs a target whose points do not all coincide")
    return foot, velocity, target, angles, ignore


def path_match(foot, target, *, velocity=None, angles=None, match: str = "closest", ignore=(),
               angle_offset=None, phase: str = "fixed") -> PathMatch:
    """Match every design's foot path with the target points; see the module docstring for the
    definitions.

    foot : (N, S, 2) foot positions at crank angles θ_k = 2πk/S (one closed cycle), model units.
    target : (M, 2) target points, model units.
    velocity : (N, S, 2) dF/dθ (per radian) at the same samples, or None (straight segments).
    angles : (M,) crank angles, radians, for match "timed" (required there, not used otherwise).
    match : "timed", "closest" or "arc".
    ignore : any of "translation", "rotation", "scale".
    angle_offset : (N,) or scalar, radians, added to ``angles`` per design (match "timed" only).
    phase : "fixed" (default) or "free": with "free" (match "timed", no ``ignore``) the angles are known up
        to a common shift ψ, each design's own (the one that matches best, :func:`_free_phase`), and
        ``theta`` holds angles + ψ.
    """
    if phase not in PHASES:
        raise ValueError(f"phase: expected one of {', '.join(PHASES)}, got {phase!r}")
    if phase == "free" and (match != "timed" or ignore):
        raise ValueError("phase 'free' applies to match 'timed' without ignore")
    foot, velocity, target, angles, ignore = _check(foot, velocity, target, angles, match, ignore, angle_offset)
    N, S, _ = foot.shape
    M = target.shape[0]
    h = 2.0 * math.pi / S
    bad = ~np.all(np.isfinite(foot), axis=(1, 2))
    if velocity is not None:
        bad |= ~np.all(np.isfinite(velocity), axis=(1, 2))
    if angles is not None:
        bad |= ~np.all(np.isfinite(angles), axis=1)
    Q = np.ascontiguousarray(np.broadcast_to(target, (N, M, 2)))
    ones, zeros, zeros2 = np.ones(N), np.zeros(N), np.zeros((N, 2))

    if match == "timed":
        if phase == "free":
            angles = angles + _free_phase(foot, velocity, target, np.where(bad[:, None], 0.0, angles), bad)[:, None]
        theta = np.where(bad[:, None], np.nan, np.mod(np.where(bad[:, None], 0.0, angles), 2.0 * math.pi))
        pts, _ = _at_angles(foot, velocity, np.where(bad[:, None], 0.0, theta))
        pts[bad] = np.nan
        s, phi, t = _fit(pts, Q, ignore) if ignore else (ones, zeros, zeros2)
        err, d = _rms(pts, Q, s, phi, t)
        return _result(bad, err, d, theta, pts, s, phi, t)

    matcher = _Matcher(foot, velocity, target, match, h)
    if not ignore:
        theta, pts, tang = matcher(Q)
        err, d = _rms(pts, Q, ones, zeros, zeros2)
        return _result(bad, err, d, theta, pts, ones, zeros, zeros2)

    # alternate matching and fitting, from several starts
    starts = _starts(foot, target, ignore)
    K = len(starts)
    rep = lambda a: np.concatenate([a] * K)  # noqa: E731
    s = np.concatenate([st[0] for st in starts])
    phi = np.concatenate([st[1] for st in starts])
    t = np.concatenate([st[2] for st in starts])
    rows = np.tile(np.arange(N), K)
    QK = rep(Q)
    size = _size(target)
    st = _Search(matcher, rows, QK, s, phi, t, ignore, match, size)
    st.run(START_ROUNDS)
    # the best start of each design goes on
    e = np.where(np.isfinite(st.err), st.err, np.inf).reshape(K, N)
    pick = np.argmin(e, axis=0) * N + np.arange(N)
    st = st.subset(pick)
    st.run(MAX_ROUNDS - START_ROUNDS)
    err, d = _rms(st.pts, Q, st.s, st.phi, st.t)
    return _result(bad, err, d, st.theta, st.pts, st.s, st.phi, st.t)


def _result(bad, err, d, theta, pts, s, phi, t):
    err = np.where(bad, np.nan, err)
    d = np.where(bad[:, None], np.nan, d)
    theta = np.where(bad[:, None], np.nan, theta)
    pts = np.where(bad[:, None, None], np.nan, pts)
    s = np.where(bad, np.nan, s)
    phi = np.where(bad, np.nan, np.mod(phi + math.pi, 2.0 * math.pi) - math.pi)
    t = np.where(bad[:, None], np.nan, t)
    return PathMatch(err, d, theta, pts, s, phi, t)


#: Phases of the free-phase search's grid (each refined by Gauss–Newton from the best three).
PHASE_GRID = 64


def _free_phase(foot, velocity, target, angles, bad):
    """(N,) the shift ψ of each design's angles (N, M) that brings its foot nearest the target (least
    sum of squared distances): the best of :data:`PHASE_GRID` evenly spaced shifts, the three best
    each refined by Gauss–Newton on ψ (the step −Σ r·t / Σ |t|², halved until the sum drops), the best
    kept. 0 for ``bad`` rows."""
    N, M = angles.shape
    K = PHASE_GRID
    grid = 2.0 * math.pi * np.arange(K) / K
    out = np.zeros(N)
    for a0 in range(0, N, 256):  # bounded memory: 256 designs x K x M points at a time
        a1 = min(a0 + 256, N)
        n = a1 - a0
        f = foot[a0:a1]
        v = None if velocity is None else velocity[a0:a1]
        th = angles[a0:a1, None, :] + grid[None, :, None]  # (n, K, M)
        pts, _ = _at_angles(f, v, th.reshape(n, K * M))
        e = np.sum((pts.reshape(n, K, M, 2) - target[None, None]) ** 2, axis=(2, 3))
        e = np.where(np.isfinite(e), e, np.inf)
        starts = np.argsort(e, axis=1, kind="stable")[:, :3]
        best_e = np.full(n, np.inf)
        best_psi = np.zeros(n)
        for j in range(starts.shape[1]):
            psi = grid[starts[:, j]].copy()
            cur = e[np.arange(n), starts[:, j]]
            for _ in range(30):
                p, t = _at_angles(f, v, angles[a0:a1] + psi[:, None])
                r = p - target[None]
                g = np.sum(r * t, axis=(1, 2))
                hh = np.sum(t * t, axis=(1, 2))
                step = np.where(hh > 0, -g / np.where(hh > 0, hh, 1.0), 0.0)
                moved = np.zeros(n, bool)
                for _half in range(20):
                    trial = psi + step
                    pt, _ = _at_angles(f, v, angles[a0:a1] + trial[:, None])
                    et = np.sum((pt - target[None]) ** 2, axis=(1, 2))
                    ok = np.isfinite(et) & (et < cur) & ~moved
                    psi = np.where(ok, trial, psi)
                    cur = np.where(ok, et, cur)
                    moved |= ok
                    if moved.all():
                        break
                    step = np.where(moved, step, 0.5 * step)
                if np.all(np.abs(step) <= 1e-15 * (1.0 + np.abs(psi))) or not moved.any():
                    break
            better = cur < best_e
            best_e = np.where(better, cur, best_e)
            best_psi = np.where(better, psi, best_psi)
        out[a0:a1] = np.mod(best_psi, 2.0 * math.pi)
    out[bad] = 0.0
    return out


def _size(target):
    """The target's RMS radius about its centroid (1 if it is a single point)."""
    r = float(np.sqrt(np.mean(np.sum((target - target.mean(axis=0)) ** 2, axis=1))))
    return r if r > 0 else 1.0


def _starts(foot, target, ignore):
    """Starting transforms: the identity, then moment-aligned ones (centroids, RMS radii, and four
    rotations when rotation is ignored)."""
    N = foot.shape[0]
    out = [(np.ones(N), np.zeros(N), np.zeros((N, 2)))]
    trans = "translation" in ignore
    with np.errstate(invalid="ignore"):
        cf = foot.mean(axis=1) if trans else np.zeros((N, 2))
        cq = target.mean(axis=0) if trans else np.zeros(2)
        rf = np.sqrt(np.mean(np.sum((foot - cf[:, None]) ** 2, axis=-1), axis=1))
        rq = float(np.sqrt(np.mean(np.sum((target - cq) ** 2, axis=-1))))
    if "scale" in ignore:
        with np.errstate(invalid="ignore", divide="ignore"):
            s0 = np.where((rf > 0) & np.isfinite(rf) & (rq > 0), rq / rf, 1.0)
    else:
        s0 = np.ones(N)
    rotations = (0.0, 0.5 * math.pi, math.pi, 1.5 * math.pi) if "rotation" in ignore else (0.0,)
    for a in rotations:
        phi = np.full(N, a)
        t = (cq[None] - s0[:, None] * np.einsum("nij,nj->ni", _rot(phi), cf)) if trans else np.zeros((N, 2))
        out.append((s0.copy(), phi, np.where(np.isfinite(t), t, 0.0)))
    return out


class _Matcher:
    """Closest or arc-length matches of target points given in each design's frame."""

    def __init__(self, foot, velocity, target, match, h):
        self.foot = foot
        self.vel = velocity if velocity is not None else foot
        self.hermite = velocity is not None
        self.match = match
        self.h = h
        if match == "arc":
            L = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(target, axis=0), axis=1))])
            self.frac = L / L[-1] if L[-1] > 0 else np.zeros_like(L)

    def __call__(self, qf, rows=None):
        """qf (R, M, 2): target points in the frame of design rows[r] (default: r)."""
        R, M, _ = qf.shape
        idx = np.arange(R) if rows is None else np.ascontiguousarray(rows, dtype=np.int64)
        if idx.shape != (R,) or (R and (idx.min() < 0 or idx.max() >= self.foot.shape[0])):
            raise ValueError(f"rows: expected {R} indices into {self.foot.shape[0]} foot paths")
        theta = np.empty((R, M))
        pts = np.empty((R, M, 2))
        tang = np.empty((R, M, 2))
        qf = np.ascontiguousarray(qf, dtype=np.float64)
        if self.match == "closest":
            parallel_rows(_closest_rows, (self.hermite, self.h, _BLOCK, self.foot, self.vel),
                          (idx, qf, theta, pts, tang))
        else:
            ends = np.ascontiguousarray(qf[:, [0, -1]])
            parallel_rows(_arc_rows, (self.hermite, self.h, _BLOCK, _GL_X, _GL_W, self.frac, self.foot, self.vel),
                          (idx, ends, theta, pts, tang))
        return theta, pts, tang


class _Search:
    """Alternating matching and fitting over rows (design rows[r], transform r)."""

    def __init__(self, matcher, rows, Q, s, phi, t, ignore, match, size):
        self.matcher, self.rows, self.Q, self.ignore, self.match = matcher, rows, Q, ignore, match
        self.size = size
        self.s, self.phi, self.t = s, phi, t
        self.theta, self.pts, self.tang = matcher(_inverse(Q, s, phi, t), rows)
        self.err, _ = _rms(self.pts, Q, s, phi, t)
        self.mu = np.full(len(rows), 1e-4)
        self.active = np.isfinite(self.err)

    def subset(self, pick):
        new = object.__new__(_Search)
        new.matcher, new.ignore, new.match, new.size = self.matcher, self.ignore, self.match, self.size
        for name in ("rows", "Q", "s", "phi", "t", "theta", "pts", "tang", "err", "mu", "active"):
            setattr(new, name, getattr(self, name)[pick])
        return new

    def run(self, rounds):
        for _ in range(rounds):
            a = np.flatnonzero(self.active)
            if a.size == 0:
                return
            Q = self.Q[a]
            if self.match == "closest":
                s, phi, t = _gn_step(self.pts[a], self.tang[a], Q, self.s[a], self.phi[a], self.t[a], self.ignore,
                                     self.mu[a])
            else:
                s, phi, t = _fit(self.pts[a], Q, self.ignore)
            ok = np.isfinite(s) & np.isfinite(phi) & np.all(np.isfinite(t), axis=1) & (s > 0)
            s, phi, t = np.where(ok, s, self.s[a]), np.where(ok, phi, self.phi[a]), np.where(ok[:, None], t, self.t[a])
            theta, pts, tang = self.matcher(_inverse(Q, s, phi, t), self.rows[a])
            err, _ = _rms(pts, Q, s, phi, t)
            better = ok & np.isfinite(err) & (err < self.err[a])
            gain = np.where(better, self.err[a] - err, 0.0)
            b = a[better]
            self.s[b], self.phi[b], self.t[b] = s[better], phi[better], t[better]
            self.theta[b], self.pts[b], self.tang[b] = theta[better], pts[better], tang[better]
            self.err[b] = err[better]
            if self.match == "closest":
                # Levenberg–Marquardt: trust the Gauss–Newton model more after a success, less after a failure
                self.mu[a] = np.where(better, np.maximum(self.mu[a] / 10.0, 1e-12), self.mu[a] * 10.0)
                # converged: a step that gains (next to) nothing, or a rejected step that changed (next to)
                # nothing, or damping so strong that the steps vanish
                flat = ~better & np.isfinite(err) & (err <= self.err[a] * (1.0 + 1e-12) + _ATOL * self.size)
                done = (better & (gain <= _RTOL * err + _ATOL * self.size)) | flat | (~better & (self.mu[a] > 1e8))
            else:
                done = ~better | (gain <= _RTOL * err + _ATOL * self.size)
            self.active[a[done]] = False


def path_error(foot, target, *, velocity=None, angles=None, match: str = "closest", ignore=(),
               angle_offset=None, phase: str = "fixed") -> np.ndarray:
    """RMS distance (model units) from the M target points to their matches on each design's foot
    path, shape (N,); NaN for a design whose foot path (or velocity) has a NaN. Arguments as for
    :func:`path_match`; definitions in the module docstring."""
    return path_match(foot, target, velocity=velocity, angles=angles, match=match, ignore=ignore,
                      angle_offset=angle_offset, phase=phase).error


def path_at(foot, theta, *, velocity=None):
    """The foot path between its samples at given crank angles: points (N, M, 2), model units, and
    tangents dF/dθ (N, M, 2), model units per radian, interpolated as the module docstring says (cubic
    Hermite with ``velocity``, straight segments without). foot : (N, S, 2) at θ_k = 2πk/S; theta :
    (N, M) or (M,) radians (any real value: taken modulo 2π); velocity : (N, S, 2) or None."""
    foot, velocity = _foot_and_velocity(foot, velocity)
    theta = np.asarray(theta, dtype=np.float64)
    if theta.ndim == 1:
        theta = np.broadcast_to(theta, (foot.shape[0], theta.shape[0]))
    if theta.ndim != 2 or theta.shape[0] != foot.shape[0]:
        raise ValueError(f"theta: expected shape (N, M) with N = {foot.shape[0]} or (M,), got {theta.shape}")
    return _at_angles(foot, velocity, theta)


def path_residuals(foot, target, *, velocity=None, angles=None, match: str = "closest", ignore=(),
                   angle_offset=None, phase: str = "fixed") -> np.ndarray:
    """Distance (model units) from each target point to its match, shape (N, M); the RMS of a row
    is :func:`path_error`."""
    return path_match(foot, target, velocity=velocity, angles=angles, match=match, ignore=ignore,
                      angle_offset=angle_offset, phase=phase).distances


# ---------------------------------------------------------------------------------------------
# the target, from a study file
# ---------------------------------------------------------------------------------------------

#: Keys of a target table.
TARGET_KEYS = ("points", "csv", "angles_deg", "match", "ignore", "phase", "closed")
#: A timed target's phase: "fixed" (the angles as given) or "free" (known up to a common shift).
PHASES = ("fixed", "free")


@dataclass(frozen=True)
class Target:
    """A target path: points (M, 2) in model units; angles (M,) crank angles in **radians** (given in
    the file in degrees, ``angles_deg``) or None; match (one of :data:`MATCHES`); ignore (a sorted
    tuple of :data:`IGNORES`); phase ("fixed", or "free": timed angles known up to a common shift); closed
    (the points go all round a closed curve, not along a stretch of one: how the curve atlas looks the
    target up; the error does not depend on it)."""

    points: np.ndarray
    angles: np.ndarray | None
    match: str
    ignore: tuple[str, ...]
    phase: str = "fixed"
    closed: bool = False

    def error(self, foot, velocity=None, angle_offset=None) -> np.ndarray:
        """:func:`path_error` of foot paths (N, S, 2) against this target, (N,), model units."""
        return path_error(foot, self.points, velocity=velocity, angles=self.angles, match=self.match,
                          ignore=self.ignore, angle_offset=angle_offset, phase=self.phase)

    def fit(self, foot, velocity=None, angle_offset=None) -> PathMatch:
        """:func:`path_match` of foot paths against this target."""
        return path_match(foot, self.points, velocity=velocity, angles=self.angles, match=self.match,
                          ignore=self.ignore, angle_offset=angle_offset, phase=self.phase)


def _number(x) -> bool:
    return isinstance(x, (int, float)) and not isinstance(x, bool)


def load_target(spec, base_dir=None, *, source: str = "<target>", key: str = "target") -> Target:
    """A :class:`Target` from a study file's table.

    spec : ``{points = [[x, y], ...], angles_deg = [...], match = "...", ignore = [...]}`` or
        ``{csv = "path.csv", match = ..., ignore = ...}``: a CSV file with a header row naming columns
        ``x``, ``y`` and optionally ``angle_deg`` (one row a point); a relative path resolves against
        ``base_dir`` (default: the working directory). Angles are crank angles in degrees
        (counter-clockwise from +x, as the crank's θ); ``match`` defaults to "timed" when angles are
        given and "closest" otherwise; ``ignore`` defaults to none.
    source, key : where the table came from (a file) and its key, for error messages.

    Raises :class:`~explorer.errors.UserError` (one line naming the key and value) for: an unknown
    key; neither or both of ``points`` and ``csv``; fewer than 2 points; a point that is not two finite
    numbers; an unreadable or malformed CSV; an unknown match or ignore name; "timed" without angles;
    angles with another match; an angle count other than the point count; non-finite angles; "arc"
    with all points coinciding.
    """
    if not isinstance(spec, dict):
        raise UserError(f"{where(source, key)}: expected a table with points (or csv), got {spec!r}")
    for k in spec:
        if k not in TARGET_KEYS:
            raise UserError(f"{where(source, f'{key}.{k}')}: unknown key (allowed: {', '.join(TARGET_KEYS)})")
    if ("points" in spec) == ("csv" in spec):
        raise UserError(f"{where(source, key)}: give exactly one of points = [[x, y], ...] or csv = \"file.csv\"")
    angles = None
    if "points" in spec:
        raw = spec["points"]
        k = f"{key}.points"
        if not isinstance(raw, list):
            raise UserError(f"{where(source, k)}: expected a list of [x, y] points, got {raw!r}")
        pts = []
        for i, p in enumerate(raw):
            if not (isinstance(p, list) and len(p) == 2 and all(_number(c) for c in p)
                    and all(math.isfinite(float(c)) for c in p)):
                raise UserError(f"{where(source, f'{k}[{i}]')}: expected [x, y] with two finite numbers, got {p!r}")
            pts.append((float(p[0]), float(p[1])))
        if "angles_deg" in spec:
            ra = spec["angles_deg"]
            ka = f"{key}.angles_deg"
            if not isinstance(ra, list):
                raise UserError(f"{where(source, ka)}: expected a list of crank angles in degrees, got {ra!r}")
            for i, a in enumerate(ra):
                if not (_number(a) and math.isfinite(float(a))):
                    raise UserError(f"{where(source, f'{ka}[{i}]')}: expected a finite number (degrees), got {a!r}")
            angles = [float(a) for a in ra]
    else:
        k = f"{key}.csv"
        if "angles_deg" in spec:
            raise UserError(f"{where(source, f'{key}.angles_deg')}: angles come from the CSV's angle_deg column "
                            f"when csv is given")
        pts, angles = _read_csv(spec["csv"], base_dir, source, k)
    if len(pts) < 2:
        raise UserError(f"{where(source, k)}: a target needs at least 2 points, got {len(pts)}")
    match = spec.get("match", "timed" if angles is not None else "closest")
    if match not in MATCHES:
        raise UserError(f"{where(source, f'{key}.match')}: expected one of {', '.join(MATCHES)}, got {match!r}")
    ign = spec.get("ignore", [])
    if isinstance(ign, str):
        ign = [ign]
    if not isinstance(ign, list):
        raise UserError(f"{where(source, f'{key}.ignore')}: expected a list of {', '.join(IGNORES)}, got {ign!r}")
    for i, g in enumerate(ign):
        if g not in IGNORES:
            raise UserError(f"{where(source, f'{key}.ignore[{i}]')}: expected one of {', '.join(IGNORES)}, got {g!r}")
    if len(set(ign)) != len(ign):
        raise UserError(f"{where(source, f'{key}.ignore')}: a name is repeated in {ign!r}")
    akey = f"{key}.angles_deg" if "points" in spec else f"{key}.csv"
    if match == "timed":
        if angles is None:
            raise UserError(f"{where(source, f'{key}.match')}: match = \"timed\" needs crank angles: angles_deg = "
                            f"[...] (or an angle_deg column in the CSV)")
        if len(angles) != len(pts):
            raise UserError(f"{where(source, akey)}: {len(angles)} angles for {len(pts)} points; give one per point")
    elif angles is not None:
        raise UserError(f"{where(source, akey)}: crank angles are used by match = \"timed\" only, "
                        f"not {match!r}; drop them or set match = \"timed\"")
    phase = spec.get("phase", "fixed")
    if phase not in PHASES:
        raise UserError(f"{where(source, f'{key}.phase')}: expected one of {', '.join(PHASES)}, got {phase!r}")
    if phase == "free" and (match != "timed" or ign):
        raise UserError(f"{where(source, f'{key}.phase')}: phase = \"free\" (the angles known up to a common shift) "
                        f"applies to match = \"timed\" without ignore, not match = {match!r}"
                        + (f" with ignore = {ign!r}" if ign else ""))
    points = np.array(pts, dtype=np.float64)
    if match == "arc" and not np.sum(np.linalg.norm(np.diff(points, axis=0), axis=1)) > 0:
        raise UserError(f"{where(source, k)}: match = \"arc\" needs points that do not all coincide")
    points.flags.writeable = False
    ang = None
    if angles is not None:
        ang = np.radians(np.array(angles, dtype=np.float64))
        ang.flags.writeable = False
    closed = spec.get("closed", False)
    if not isinstance(closed, bool):
        raise UserError(f"{where(source, f'{key}.closed')}: expected true or false, got {closed!r}")
    return Target(points, ang, match, tuple(sorted(ign, key=IGNORES.index)), phase, closed)


def _read_csv(value, base_dir, source, key):
    if not isinstance(value, str) or not value:
        raise UserError(f"{where(source, key)}: expected a file name, got {value!r}")
    path = Path(value)
    if not path.is_absolute() and base_dir is not None:
        path = Path(base_dir) / path
    try:
        text = path.read_text(encoding="utf-8-sig")
    except (OSError, UnicodeDecodeError) as exc:
        raise UserError(f"{where(source, key)}: cannot read {str(path)!r}: {exc}") from None
    rows = [r for r in csv.reader(text.splitlines()) if r and any(c.strip() for c in r)]
    if not rows:
        raise UserError(f"{where(source, key)}: {str(path)!r} is empty; expected a header x,y[,angle_deg] and points")
    header = [c.strip().lower() for c in rows[0]]
    allowed = ("x", "y", "angle_deg")
    for c in header:
        if c not in allowed:
            raise UserError(f"{where(source, key)}: {str(path)!r}: unknown column {c!r} (columns: x, y, angle_deg)")
    if "x" not in header or "y" not in header or len(set(header)) != len(header):
        raise UserError(f"{where(source, key)}: {str(path)!r}: the header must name columns x and y once each "
                        f"(and optionally angle_deg), got {rows[0]!r}")
    ix, iy = header.index("x"), header.index("y")
    ia = header.index("angle_deg") if "angle_deg" in header else None
    pts, angles = [], [] if ia is not None else None
    for line, r in enumerate(rows[1:], start=2):
        if len(r) != len(header):
            raise UserError(f"{where(source, key)}: {str(path)!r} row {line}: expected {len(header)} values, got {r!r}")
        try:
            vals = [float(c) for c in r]
        except ValueError:
            raise UserError(f"{where(source, key)}: {str(path)!r} row {line}: not a number in {r!r}") from None
        if not all(math.isfinite(v) for v in vals):
            raise UserError(f"{where(source, key)}: {str(path)!r} row {line}: non-finite value in {r!r}")
        pts.append((vals[ix], vals[iy]))
        if ia is not None:
            angles.append(vals[ia])
    return pts, angles
