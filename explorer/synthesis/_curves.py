"""Closed curves as comparable shapes: the curve atlas's descriptors and its alignment scans.

A design's foot path over one crank cycle is a closed curve. The atlas (:mod:`explorer.synthesis._atlas`)
keeps each design's curve in two *normalised* forms, each of ``n`` points (``N_CURVE`` = 32):

``curve`` (arc length)
    the path resampled at n points evenly spaced in arc length, starting at the crank's θ = 0 point
    and going the way the crank drives it, then moved and scaled: the n points' centroid to the
    origin, their RMS distance from it to 1 (the *centre* (2,) and *scale* of the design's path).
``timed`` (crank angle)
    the foot at θ_k = 2πk/n, moved and scaled by the same centre and scale.

Neither is rotated: a design's orientation is kept, and the scans below fit it.

Descriptor (the nearest-neighbour index of closed untimed targets)
------------------------------------------------------------------
z_j = x_j + i·y_j of the arc-length curve; its discrete Fourier coefficients c_k = (1/n) Σ_j z_j
e^{−2πijk/n}. Translating the path changes c_0 only (the centroid is 0 here); scaling multiplies every
c_k by s (the scale is 1 here); rotating by φ multiplies every c_k by e^{iφ}; starting the resampling
at another point, a shift of m samples, multiplies c_k by e^{2πikm/n}. So the magnitudes |c_k| do not
change with position, rotation, scale or starting point: the descriptor is

    (|c_1|, |c_−1|, |c_2|, |c_−2|, …, |c_K|, |c_−K|)      (2K numbers, K = ``N_HARMONICS`` = 8)

and running the curve the other way swaps |c_k| and |c_−k| (a query asks both ways). By the
triangle inequality, the Euclidean distance between two descriptors is at most the RMS distance
between the two curves after the best rotation and starting point: a curve within d of the target
is among the descriptors within d, so nearest descriptors are a safe first cut, which the exact
alignment (:func:`align_closed`) then ranks.

Scans (exact alignment of a target with many atlas curves; Numba, parallel over designs)
----------------------------------------------------------------------------------------
:func:`align_closed`
    a closed target resampled like ``curve``, against every starting point (n) and both directions:
    the best complex a (rotation and scale) of ‖q − a·w‖², closed form.
:func:`align_open`
    an open target (a stretch the foot passes through, in order) resampled to m points by arc
    length, against stretches of the closed curve: every start (n), both directions and each
    fraction of the path in ``OPEN_FRACTIONS``; the best similarity (a, t) in closed form.
:func:`align_timed`
    target points at crank angles θ_i against the ``timed`` curve (periodic linear interpolation):
    with a fixed phase, the design turned by φ is also started φ later (its crank angle is measured
    in the target's frame), so q_i ≈ s·e^{iφ}·w(θ_i − φ) + t, φ scanned over ``n_phase`` angles and
    s ≥ 0, t in closed form; with a free phase ψ (the angles known up to a common shift), q_i ≈
    a·w(θ_i + ψ) + t with a complex, ψ scanned.

Every scan returns, per design, the residual as a share of the target's spread about its centroid
(0: the same shape; 1: no better than a point) and the fitted transform; they are first cuts at the
resolution of n points, which the polish (:mod:`explorer.synthesis._synth`) finishes on the real
kinematics.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

#: Points of each normalised curve in the atlas.
N_CURVE = 32
#: Harmonics per direction in the descriptor (2·N_HARMONICS numbers).
N_HARMONICS = 8
#: Shares of the closed path an open target may span (align_open tries each).
OPEN_FRACTIONS = (0.25, 0.375, 0.5, 0.625, 0.75, 0.875)
#: align_open tries every OPEN_START_STEP-th sample as the start of the stretch (the polish moves it).
OPEN_START_STEP = 2
#: Points an open target is resampled to for align_open.
OPEN_POINTS = 12
#: A design whose foot moves more than this share of its path length in one solver step is not kept
#: in an atlas (a near-toggle whip the samples cannot describe).
MAX_STEP_SHARE = 1.0 / 16.0


@njit(cache=True, nogil=True)
def _resample_row(P, n, out):
    """Resample closed polyline P (S, 2) at n points evenly spaced in arc length from P[0], forward,
    into out (n, 2); returns (total length, largest segment)."""
    S = P.shape[0]
    seg = np.empty(S)
    total = 0.0
    biggest = 0.0
    for k in range(S):
        k1 = k + 1 if k + 1 < S else 0
        d = math.hypot(P[k1, 0] - P[k, 0], P[k1, 1] - P[k, 1])
        seg[k] = d
        total += d
        if d > biggest:
            biggest = d
    if not (total > 0.0) or not math.isfinite(total):
        return total, biggest
    k = 0
    acc = 0.0
    for j in range(n):
        t = j * total / n
        while k < S - 1 and acc + seg[k] < t:
            acc += seg[k]
            k += 1
        k1 = k + 1 if k + 1 < S else 0
        u = (t - acc) / seg[k] if seg[k] > 0.0 else 0.0
        if u > 1.0:
            u = 1.0
        out[j, 0] = P[k, 0] + u * (P[k1, 0] - P[k, 0])
        out[j, 1] = P[k, 1] + u * (P[k1, 1] - P[k, 1])
    return total, biggest


@njit(parallel=True, cache=True)
def _normalise_jit(paths, n, every, curve, timed, centre, scale, step_share):
    """Fill curve (N, n, 2), timed (N, n, 2), centre (N, 2), scale (N,) and step_share (N,) from paths
    (N, S, 2) (crank-uniform samples; S = n·every). A row that cannot be normalised gets scale NaN."""
    N = paths.shape[0]
    for r in prange(N):
        buf = np.empty((n, 2))
        total, biggest = _resample_row(paths[r], n, buf)
        if not (total > 0.0) or not math.isfinite(total):
            scale[r] = np.nan
            step_share[r] = np.nan
            continue
        step_share[r] = biggest / total
        cx = 0.0
        cy = 0.0
        for j in range(n):
            cx += buf[j, 0]
            cy += buf[j, 1]
        cx /= n
        cy /= n
        ss = 0.0
        for j in range(n):
            ss += (buf[j, 0] - cx) ** 2 + (buf[j, 1] - cy) ** 2
        s = math.sqrt(ss / n)
        if not (s > 0.0) or not math.isfinite(s):
            scale[r] = np.nan
            continue
        centre[r, 0] = cx
        centre[r, 1] = cy
        scale[r] = s
        for j in range(n):
            curve[r, j, 0] = (buf[j, 0] - cx) / s
            curve[r, j, 1] = (buf[j, 1] - cy) / s
            timed[r, j, 0] = (paths[r, j * every, 0] - cx) / s
            timed[r, j, 1] = (paths[r, j * every, 1] - cy) / s


def normalise(paths, n: int = N_CURVE):
    """The atlas's forms of foot paths (N, S, 2), crank-uniform over one cycle with S a multiple of n.

    Returns (curve (N, n, 2), timed (N, n, 2), centre (N, 2), scale (N,), step_share (N,)), float64:
    the arc-length and crank-angle curves, each moved by -centre and divided by scale (see the module
    docstring), and each path's largest step as a share of its length. Rows that cannot be normalised
    (no length, NaN) have scale NaN."""
    paths = np.ascontiguousarray(paths, dtype=np.float64)
    N, S, _ = paths.shape
    if S % n:
        raise ValueError(f"normalise: {S} samples is not a multiple of {n}")
    curve = np.zeros((N, n, 2))
    timed = np.zeros((N, n, 2))
    centre = np.zeros((N, 2))
    scale = np.zeros(N)
    share = np.zeros(N)
    _normalise_jit(paths, n, S // n, curve, timed, centre, scale, share)
    return curve, timed, centre, scale, share


def resample_target(points, n: int, *, closed: bool):
    """Target points (M, 2) resampled at n points evenly spaced in arc length along their polyline
    (closed: back to the first point; open: first to last, both included), and the centroid (2,) and
    RMS radius of the resampled points. Raises ValueError when the points have no length."""
    P = np.asarray(points, dtype=np.float64)
    if closed:
        out = np.empty((n, 2))
        total, _ = _resample_row(P, n, out)
    else:
        d = np.hypot(*np.diff(P, axis=0).T)
        total = float(d.sum())
        if total > 0:
            s = np.concatenate([[0.0], np.cumsum(d)])
            t = np.linspace(0.0, total, n)
            out = np.column_stack([np.interp(t, s, P[:, 0]), np.interp(t, s, P[:, 1])])
    if not total > 0:
        raise ValueError("the target's points have no length")
    c = out.mean(axis=0)
    r = float(np.sqrt(np.mean(np.sum((out - c) ** 2, axis=1))))
    return out, c, r


def descriptors(curve, harmonics: int = N_HARMONICS) -> np.ndarray:
    """(N, 2·harmonics) float32: |c_1|, |c_−1|, …, |c_K|, |c_−K| of normalised arc-length curves
    (N, n, 2) (see the module docstring)."""
    curve = np.asarray(curve)
    z = curve[..., 0].astype(np.float64) + 1j * curve[..., 1].astype(np.float64)
    c = np.fft.fft(z, axis=-1) / z.shape[-1]
    k = np.arange(1, harmonics + 1)
    out = np.empty((z.shape[0], 2 * harmonics), dtype=np.float32)
    out[:, 0::2] = np.abs(c[:, k])
    out[:, 1::2] = np.abs(c[:, -k])
    return out


def reverse_descriptor(d):
    """The descriptor of the same curve run the other way (|c_k| and |c_−k| swapped)."""
    d = np.asarray(d)
    out = d.copy()
    out[..., 0::2] = d[..., 1::2]
    out[..., 1::2] = d[..., 0::2]
    return out


@njit(parallel=True, cache=True)
def _align_closed_jit(curve, rows, q, err, shift, direction, a):
    n = curve.shape[1]
    qq = 0.0
    for j in range(n):
        qq += q[j, 0] ** 2 + q[j, 1] ** 2
    for r in prange(rows.shape[0]):
        w = curve[rows[r]]
        best = np.inf
        for d in (1, -1):
            for o in range(n):
                ww = 0.0
                sr = 0.0
                si = 0.0
                for j in range(n):
                    k = (o + d * j) % n
                    wx = np.float64(w[k, 0])
                    wy = np.float64(w[k, 1])
                    ww += wx * wx + wy * wy
                    # conj(w)·q
                    sr += wx * q[j, 0] + wy * q[j, 1]
                    si += wx * q[j, 1] - wy * q[j, 0]
                if ww <= 0.0:
                    continue
                e = (qq - (sr * sr + si * si) / ww) / qq
                if e < best:
                    best = e
                    shift[r] = o
                    direction[r] = d
                    a[r, 0] = sr / ww
                    a[r, 1] = si / ww
        err[r] = best


def align_closed(curve, rows, q):
    """Align a closed target q (n, 2), normalised like the atlas's arc-length curves, with curves[rows]
    (curve (N, n, 2)), trying every starting point and both directions.

    Returns (err (K,), shift (K,), direction (K,), a (K, 2)): the residual ‖q − a·w‖² as a share of
    ‖q‖², the best start o (q_j is compared with w[(o + direction·j) mod n]), the direction (+1: the
    way the crank drives it) and a = (Re, Im) of the complex factor (scale and rotation)."""
    rows = np.ascontiguousarray(rows, dtype=np.int64)
    K = len(rows)
    err = np.full(K, np.inf)
    shift = np.zeros(K, dtype=np.int64)
    direction = np.ones(K, dtype=np.int64)
    a = np.zeros((K, 2))
    if K:
        _align_closed_jit(curve, rows, np.ascontiguousarray(q, dtype=np.float64), err, shift, direction, a)
    return err, shift, direction, a


@njit(cache=True, nogil=True)
def _at(w, u):
    """Point of the closed polygon w (n, 2) at parameter u (sample units, any real), linearly."""
    n = w.shape[0]
    fl = math.floor(u)
    f = u - fl
    i0 = int(fl) % n
    i1 = (i0 + 1) % n
    return ((1.0 - f) * np.float64(w[i0, 0]) + f * np.float64(w[i1, 0]),
            (1.0 - f) * np.float64(w[i0, 1]) + f * np.float64(w[i1, 1]))


@njit(cache=True, nogil=True)
def _similarity(px, py, qx, qy, m):
    """Best q ≈ a·p + t (a complex, t complex) over m points; returns (residual, ar, ai, tx, ty)."""
    pcx = 0.0
    pcy = 0.0
    qcx = 0.0
    qcy = 0.0
    for j in range(m):
        pcx += px[j]
        pcy += py[j]
        qcx += qx[j]
        qcy += qy[j]
    pcx /= m
    pcy /= m
    qcx /= m
    qcy /= m
    pp = 0.0
    qq = 0.0
    sr = 0.0
    si = 0.0
    for j in range(m):
        x = px[j] - pcx
        y = py[j] - pcy
        u = qx[j] - qcx
        v = qy[j] - qcy
        pp += x * x + y * y
        qq += u * u + v * v
        sr += x * u + y * v
        si += x * v - y * u
    if pp <= 0.0:
        return qq, 0.0, 0.0, qcx, qcy
    ar = sr / pp
    ai = si / pp
    res = qq - (sr * sr + si * si) / pp
    return res, ar, ai, qcx - (ar * pcx - ai * pcy), qcy - (ar * pcy + ai * pcx)


@njit(cache=True, nogil=True)
def _spread(q):
    """(x (m,), y (m,), centroid x, centroid y, sum of squared distances from it) of points q (m, 2)."""
    qx = q[:, 0].copy()
    qy = q[:, 1].copy()
    qcx = qx.mean()
    qcy = qy.mean()
    qq = 0.0
    for j in range(q.shape[0]):
        qq += (qx[j] - qcx) ** 2 + (qy[j] - qcy) ** 2
    return qx, qy, qcx, qcy, qq


@njit(parallel=True, cache=True)
def _align_open_jit(curve, rows, q, fractions, err, start, direction, fraction, a, t):
    n = curve.shape[1]
    m = q.shape[0]
    qx, qy, qcx, qcy, qq = _spread(q)
    for r in prange(rows.shape[0]):
        w = curve[rows[r]]
        px = np.empty(m)
        py = np.empty(m)
        best = np.inf
        for fi in range(fractions.shape[0]):
            span = fractions[fi] * n
            for d in (1, -1):
                for o in range(0, n, OPEN_START_STEP):
                    for j in range(m):
                        p = _at(w, o + d * span * j / (m - 1))
                        px[j] = p[0]
                        py[j] = p[1]
                    res, ar, ai, tx, ty = _similarity(px, py, qx, qy, m)
                    e = res / qq
                    if e < best:
                        best = e
                        start[r] = o
                        direction[r] = d
                        fraction[r] = fractions[fi]
                        a[r, 0] = ar
                        a[r, 1] = ai
                        t[r, 0] = tx
                        t[r, 1] = ty
        err[r] = best


def align_open(curve, rows, q, fractions=OPEN_FRACTIONS):
    """Align an open target q (m, 2), resampled evenly by arc length (first to last point), with
    stretches of curves[rows]: q_j against the curve at arc parameter start + direction·fraction·n·j/(m−1)
    (sample units), for every ``OPEN_START_STEP``-th start, both directions and each fraction.

    Returns (err (K,), start, direction, fraction, a (K, 2), t (K, 2)): the residual of the best
    similarity q ≈ a·w + t as a share of q's spread about its centroid, and that fit."""
    rows = np.ascontiguousarray(rows, dtype=np.int64)
    K = len(rows)
    err = np.full(K, np.inf)
    start = np.zeros(K, dtype=np.int64)
    direction = np.ones(K, dtype=np.int64)
    fraction = np.zeros(K)
    a = np.zeros((K, 2))
    t = np.zeros((K, 2))
    if K:
        _align_open_jit(curve, rows, np.ascontiguousarray(q, dtype=np.float64),
                        np.asarray(fractions, dtype=np.float64), err, start, direction, fraction, a, t)
    return err, start, direction, fraction, a, t


@njit(parallel=True, cache=True)
def _align_timed_jit(timed, rows, q, theta, n_phase, free, err, phase, a, t):
    n = timed.shape[1]
    M = q.shape[0]
    qx, qy, qcx, qcy, qq = _spread(q)
    if qq <= 0.0:
        qq = 1.0
    per = n / (2.0 * math.pi)
    for r in prange(rows.shape[0]):
        w = timed[rows[r]]
        px = np.empty(M)
        py = np.empty(M)
        best = np.inf
        for k in range(n_phase):
            phi = 2.0 * math.pi * k / n_phase
            c = math.cos(phi)
            s = math.sin(phi)
            for i in range(M):
                if free:
                    p = _at(w, (theta[i] + phi) * per)
                    px[i] = p[0]
                    py[i] = p[1]
                else:  # the design turned by φ: its foot at θ is R(φ)·w(θ − φ)
                    p = _at(w, (theta[i] - phi) * per)
                    px[i] = c * p[0] - s * p[1]
                    py[i] = s * p[0] + c * p[1]
            if free:
                res, ar, ai, tx, ty = _similarity(px, py, qx, qy, M)
            else:  # a real scale s >= 0 only (the rotation is φ)
                pcx = px.mean()
                pcy = py.mean()
                pp = 0.0
                sr = 0.0
                for i in range(M):
                    x = px[i] - pcx
                    y = py[i] - pcy
                    pp += x * x + y * y
                    sr += x * (qx[i] - qcx) + y * (qy[i] - qcy)
                sc = sr / pp if pp > 0.0 and sr > 0.0 else 0.0
                res = qq - sc * sr
                ar = sc * c
                ai = sc * s
                # t = q̄ − s·p̄ (p already turned)
                tx = qcx - sc * pcx
                ty = qcy - sc * pcy
            e = res / qq
            if e < best:
                best = e
                phase[r] = phi
                a[r, 0] = ar
                a[r, 1] = ai
                t[r, 0] = tx
                t[r, 1] = ty
        err[r] = best


def align_timed(timed, rows, q, theta, *, free_phase: bool = False, n_phase: int = 64):
    """Align target points q (M, 2) at crank angles theta (M,) (radians) with the crank-angle curves
    timed[rows] (timed (N, n, 2)), the phase scanned over n_phase angles (see the module docstring).

    Returns (err (K,), phase (K,), a (K, 2), t (K, 2)): the residual as a share of q's spread about its
    centroid; the phase φ (fixed phase: the rotation, which also delays the crank) or ψ (free phase: the
    shift of the angles); the fit q ≈ a·p + t where p is the design's point (turned by φ for a fixed
    phase: a is then the scale times (cos φ, sin φ))."""
    rows = np.ascontiguousarray(rows, dtype=np.int64)
    K = len(rows)
    err = np.full(K, np.inf)
    phase = np.zeros(K)
    a = np.zeros((K, 2))
    t = np.zeros((K, 2))
    if K:
        _align_timed_jit(timed, rows, np.ascontiguousarray(q, dtype=np.float64),
                         np.ascontiguousarray(theta, dtype=np.float64), int(n_phase), bool(free_phase), err, phase,
                         a, t)
    return err, phase, a, t


def arc_fractions(points, *, closed: bool) -> np.ndarray:
    """(M,) each target point's share of the way along the target's polyline from its first point:
    cumulative chord lengths over the whole polyline (closed: back to the first point)."""
    P = np.asarray(points, dtype=np.float64)
    d = np.hypot(*np.diff(P, axis=0).T)
    total = float(d.sum()) + (float(np.hypot(*(P[0] - P[-1]))) if closed else 0.0)
    return np.concatenate([[0.0], np.cumsum(d)]) / (total if total > 0 else 1.0)


def angles_at_arc(foot, start, u) -> np.ndarray:
    """The crank angles (N, M) at which each design's foot path has run the shares u (N, M) of its length
    (any real: taken modulo 1) forward from crank angle ``start`` (N,) (radians). foot (N, S, 2) at
    θ_k = 2πk/S; the arc length between samples is the chord's, and the start is taken at the first
    sample at or after ``start``. Rows whose path has no length get NaN."""
    foot = np.asarray(foot, dtype=np.float64)
    N, S, _ = foot.shape
    h = 2.0 * math.pi / S
    out = np.full(np.shape(u), np.nan)
    for r in range(N):
        k0 = int(math.ceil(np.mod(start[r], 2.0 * math.pi) / h - 1e-9)) % S
        idx = (k0 + np.arange(S + 1)) % S
        seg = np.hypot(*np.diff(foot[r, idx], axis=0).T)
        s = np.concatenate([[0.0], np.cumsum(seg)])
        if not (s[-1] > 0) or not np.all(np.isfinite(s)):
            continue
        out[r] = k0 * h + np.interp(np.mod(u[r], 1.0) * s[-1], s, h * np.arange(S + 1))
    return out


@njit(cache=True, nogil=True)
def _ordered_row(P, q, k0, direction, ks):
    """Least-squares assignment of target points q (M, 2), in order, to samples of the closed path P
    (S, 2) visited from sample k0 in ``direction`` (+1: the way the crank drives it), never going back and
    at most once round: dynamic programming over (point, samples gone); fills ks (M,) (sample indices)
    and returns the sum of squared distances."""
    S = P.shape[0]
    M = q.shape[0]
    D = np.empty((M, S))
    Bk = np.zeros((M, S), dtype=np.int64)
    for j in range(S):
        D[0, j] = np.inf
    D[0, 0] = (P[k0, 0] - q[0, 0]) ** 2 + (P[k0, 1] - q[0, 1]) ** 2
    for i in range(1, M):
        run = np.inf
        arg = 0
        for j in range(S):
            if D[i - 1, j] < run:
                run = D[i - 1, j]
                arg = j
            k = (k0 + direction * j) % S
            D[i, j] = run + (P[k, 0] - q[i, 0]) ** 2 + (P[k, 1] - q[i, 1]) ** 2
            Bk[i, j] = arg
    best = np.inf
    jb = 0
    for j in range(S):
        if D[M - 1, j] < best:
            best = D[M - 1, j]
            jb = j
    for i in range(M - 1, -1, -1):
        ks[i] = (k0 + direction * jb) % S
        if i > 0:
            jb = Bk[i, jb]
    return best


@njit(parallel=True, cache=True)
def _ordered_jit(paths, q, starts, out, cost):
    N, S, _ = paths.shape
    M = q.shape[0]
    for r in prange(N):
        P = paths[r]
        ks = np.empty(M, dtype=np.int64)
        best = np.inf
        for s in range(starts.shape[1]):
            k0 = starts[r, s]
            if k0 < 0:
                continue
            for direction in (1, -1):
                c = _ordered_row(P, q, k0, direction, ks)
                if c < best:
                    best = c
                    for i in range(M):
                        out[r, i] = 2.0 * math.pi * ks[i] / S
        cost[r] = best


def ordered_match(paths, q, n_starts: int = 4):
    """Crank angles (N, M) matching target points q (M, 2), taken in order, to each design's closed path
    (N, S, 2) (samples at θ_k = 2πk/S): the least sum of squared distances over assignments that go round
    the path one way (either way), never back and at most once, starting at one of the ``n_starts``
    samples nearest q[0] on separate stretches of the path (local minima of the distance along it).
    Returns (theta (N, M) radians at the samples, cost (N,)); rows with NaN get NaN. The closest point of
    each target point on its own can lie on another stretch of a path that passes near itself; this
    assignment cannot, which is why the polish of a drawn curve starts from it."""
    paths = np.ascontiguousarray(paths, dtype=np.float64)
    q = np.ascontiguousarray(q, dtype=np.float64)
    N, S, _ = paths.shape
    d = np.sum((paths - q[0]) ** 2, axis=2)  # (N, S)
    local = (d <= np.roll(d, 1, axis=1)) & (d <= np.roll(d, -1, axis=1))
    d_local = np.where(local, d, np.inf)
    order = np.argsort(d_local, axis=1, kind="stable")[:, :n_starts]
    starts = np.where(np.isfinite(np.take_along_axis(d_local, order, axis=1)), order, -1).astype(np.int64)
    out = np.full((N, len(q)), np.nan)
    cost = np.full(N, np.inf)
    bad = ~np.all(np.isfinite(paths), axis=(1, 2))
    _ordered_jit(np.where(bad[:, None, None], 0.0, paths), q, starts, out, cost)
    out[bad] = np.nan
    cost[bad] = np.nan
    return out, cost
