"""The walker scene: the study's leg replicated on one crankshaft, the body resting on the lowest foot.

Computed from the foot path and velocity the kernels already produce (no second solve), for N
variants at once by a Numba kernel.

Model (the contract; body held level, flat ground, feet do not slip)
--------------------------------------------------------------------
The foot path p(θ) = (x, y) and its velocity p'(θ) = dp/dθ are sampled at θ_k = 2πk/S, in the
frame of the body. Leg j = 0 … L−1 has crank phase offset φ_j; its foot is

    p_j(θ) = p(θ + φ_j),                         p_j'(θ) = p'(θ + φ_j)           (a plain leg)
    p_j(θ) = M p(π − θ − φ_j),                   p_j'(θ) = (x', −y')(π − θ − φ_j) (a mirrored leg)

with M the reflection about the vertical through the crank centre (x → 2c_x − x). A phase that falls
between two samples is read off the cubic Hermite interpolant of the samples and their velocities
(exact when every φ_j is a multiple of 2π/S, as the evenly spaced defaults are for S divisible by L
and by 2 with mirrored legs).

At each sample, with Δ = 2π/S:

* ground g_k = min_j y_j(θ_k); contact leg c_k = the smallest j attaining it (ties go to the lower j);
* ``bob`` = max_k g_k − min_k g_k;
* ``travel`` = |Δ Σ_k x'_{c_k}(θ_k)| (the contact foot is planted, so the body moves by −dx_c);
* body speed s_k = |x'_{c_k}(θ_k)|; ``body_speed_ripple`` = std(s) / mean(s) (population std);
* torque: the ground pushes the contact foot with F = (u·D, W), u = −sign(Σ_k x'_{c_k}) the walking
  direction, W the weight and D = drag·W; by virtual work the quasi-static crank torque is
  τ_k = −F · p'_{c_k}(θ_k). ``peak_torque`` = max_k |τ_k| / (W r), ``torque_ripple`` =
  (max_k τ_k − min_k τ_k) / (W r), r the crank radius;
* contact: leg j touches the ground at θ_k when y_j(θ_k) ≤ g_k + δ, δ = contact × r;
* ``contact_fraction`` = min_j (samples in which leg j touches) / S;
* ``slip`` = Δ Σ_k (max − min of x'_j(θ_k) over the legs j touching at θ_k) / travel: how far, per
  unit of travel, the feet sharing the ground would have to slide against each other;
* taps between samples: leg j also comes down between two samples it is off the ground at when the
  cubic Hermite interpolants of the legs' heights (from the samples and velocities) bring
  y_j − min_i y_i within δ somewhere between them (tested at 32 points of the interval, after a
  bound on the interpolants rules most intervals out); the nearer of the two samples (the lower
  y_j − g) then counts as down for the swing. So a brief near-touch mid-swing (Klann's foot comes
  within 0.02 of the ground near 145°, for 1.6°) splits the swing whether or not a sample lands in
  it, and ``clearance`` converges as S grows instead of jumping with S (2.38 at 184 steps, 0.031 at
  180, before). ``contact_fraction`` and ``slip`` count the samples only;
* ``clearance``: leg j's swing is its longest cyclic run of n samples neither touching nor down at
  a tap (ties: the run with the smallest start index); over the middle
  half of it (run offsets i with ⌊n/4⌋ ≤ i < n − ⌊n/4⌋) the height above the ground y_j − g is at
  least h_j = min of y_j − g there; ``clearance`` = min_j h_j (0 for a leg that never leaves the
  ground): the tallest obstacle every foot steps over mid-swing.

A variant whose status is not ok, or whose path or velocity holds a non-finite value, gets NaN.
``travel`` = 0 makes ``slip`` NaN (a net stroke within 1e-9 of the total stroke is rounding and reads 0:
:func:`explorer.kernels.contact_stroke`, shared with the forces); a body speed whose mean is 0 makes
``body_speed_ripple`` NaN.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from ..kernels import contact_stroke, ground_contact, leg_feet, leg_samples, parallel_rows
from ._runs import all_finite, longest_cyclic_run
from ._table import WALKER_METRICS

_N = len(WALKER_METRICS)
_COL = {name: i for i, name in enumerate(WALKER_METRICS)}
(_TRAVEL, _BOB, _RIPPLE, _PEAK, _TRIPPLE, _CLEAR, _SLIP, _CONTACT) = (
    _COL["travel"], _COL["bob"], _COL["body_speed_ripple"], _COL["peak_torque"], _COL["torque_ripple"],
    _COL["clearance"], _COL["slip"], _COL["contact_fraction"])


#: Points per sample interval at which a possible tap is tested (see the module docstring).
_TAP_POINTS = 32


@njit(cache=True, nogil=True)
def _hermite(y0, y1, v0, v1, d, t):
    """The cubic Hermite interpolant of (y0, v0) at 0 and (y1, v1) at d (v per unit of θ), at t·d."""
    t2 = t * t
    t3 = t2 * t
    return ((2.0 * t3 - 3.0 * t2 + 1.0) * y0 + (t3 - 2.0 * t2 + t) * d * v0
            + (-2.0 * t3 + 3.0 * t2) * y1 + (t3 - t2) * d * v1)


@njit(cache=True, nogil=True)
def _low_bound(f0, f1, v0, v1, d):
    """A lower bound of the cubic Hermite interpolant of (f0, v0), (f1, v1) over an interval d: the chord
    less d·4/27·(|v0 − s| + |v1 − s|), s the chord's slope (the cubic part is d·t(1−t)·((v0 − s)(1 − t)
    − (v1 − s)t), and t(1−t)² and t²(1−t) are at most 4/27 on [0, 1])."""
    s = (f1 - f0) / d
    return min(f0, f1) - d * (4.0 / 27.0) * (abs(v0 - s) + abs(v1 - s))


@njit(cache=True, nogil=True)
def _taps(j, d, delta, Y, VY, G, C, touch, down):
    """Mark in ``down`` (S,) the sample nearer each tap of leg j between two samples it is off the ground
    at: where the legs' Hermite interpolants bring y_j − min_i y_i within ``delta``."""
    L, S = Y.shape
    for k in range(S):
        k1 = (k + 1) % S
        if touch[j, k] or touch[j, k1]:
            continue
        # y_j − g ≥ y_j − y_c for any leg c: the interval is clear if it stays above delta for the
        # ground leg at either end (a bound on the interpolants, no evaluation)
        clear = False
        for c in (C[k], C[k1]):
            lb = _low_bound(Y[j, k] - Y[c, k], Y[j, k1] - Y[c, k1], VY[j, k] - VY[c, k], VY[j, k1] - VY[c, k1], d)
            if lb > delta:
                clear = True
        if clear:
            continue
        for m in range(1, _TAP_POINTS):
            t = m / _TAP_POINTS
            yj = _hermite(Y[j, k], Y[j, k1], VY[j, k], VY[j, k1], d, t)
            g = np.inf
            for i in range(L):
                yi = _hermite(Y[i, k], Y[i, k1], VY[i, k], VY[i, k1], d, t)
                if yi < g:
                    g = yi
            if yj - g <= delta:
                if Y[j, k] - G[k] <= Y[j, k1] - G[k1]:
                    down[k] = True
                else:
                    down[k1] = True
                break


@njit(cache=True, nogil=True)
def _walker_kernel(base, frac, sign, mirrored, drag, contact, paths, vel, status, crank, out):
    """Fill out[i, :] with the walker metrics (WALKER_METRICS order) of every ok variant i; out comes
    NaN-filled. base, frac, sign (L,) from :func:`leg_samples`; mirrored (L,) bool; drag, contact
    floats; per-row arrays last: paths, vel (N, S, 2), status (N,), crank (N,), out (N, n_metrics)."""
    N = paths.shape[0]
    S = paths.shape[1]
    L = base.shape[0]
    d = 2.0 * math.pi / S
    Y = np.empty((L, S))
    VX = np.empty((L, S))
    VY = np.empty((L, S))
    touch = np.empty((L, S), dtype=np.bool_)
    down = np.empty(S, dtype=np.bool_)
    G = np.empty(S)
    C = np.empty(S, dtype=np.int64)
    for i in range(N):
        r = crank[i]
        if status[i] != 0 or not (r > 0.0) or not (all_finite(paths[i]) and all_finite(vel[i])):
            continue
        # -- every leg's foot height and velocity at every sample -------------------------------------
        leg_feet(base, frac, sign, mirrored, paths[i], vel[i], Y, VX, VY)
        # -- ground, contact leg, body motion ----------------------------------------------------------
        gmin = np.inf
        gmax = -np.inf
        ground_contact(Y, G, C)
        for k in range(S):
            g = G[k]
            if g < gmin:
                gmin = g
            if g > gmax:
                gmax = g
        sum_vx, sum_s = contact_stroke(VX, C)  # sum_vx exactly 0 for a walker that does not travel
        travel = abs(d * sum_vx)
        walk = 0.0
        if sum_vx < 0.0:
            walk = 1.0
        elif sum_vx > 0.0:
            walk = -1.0
        mean_s = sum_s / S
        var_s = 0.0
        tmax = -np.inf
        tmin = np.inf
        tpeak = 0.0
        delta = contact * r
        slip = 0.0
        for k in range(S):
            c = C[k]
            g = G[k]
            e = abs(VX[c, k]) - mean_s
            var_s += e * e
            tau = -(walk * drag * VX[c, k] + VY[c, k])
            if tau > tmax:
                tmax = tau
            if tau < tmin:
                tmin = tau
            if abs(tau) > tpeak:
                tpeak = abs(tau)
            lo = np.inf
            hi = -np.inf
            for j in range(L):
                t = Y[j, k] <= g + delta
                touch[j, k] = t
                if t:
                    if VX[j, k] < lo:
                        lo = VX[j, k]
                    if VX[j, k] > hi:
                        hi = VX[j, k]
            slip += hi - lo
        # -- per leg: contact fraction and mid-swing clearance ----------------------------------------
        cmin = np.inf
        clear = np.inf
        for j in range(L):
            n_touch = 0
            for k in range(S):
                if touch[j, k]:
                    n_touch += 1
            if n_touch / S < cmin:
                cmin = n_touch / S
            if n_touch == S:  # never leaves the ground
                clear = 0.0
                continue
            # the swing: the longest cyclic run of samples off the ground (ties: the smallest start),
            # a tap between two samples counting as down (see the module docstring)
            for k in range(S):
                down[k] = touch[j, k]
            _taps(j, d, delta, Y, VY, G, C, touch, down)
            best_s, best_n = longest_cyclic_run(~down)
            q = best_n // 4
            h = np.inf
            for m in range(q, best_n - q):
                k = (best_s + m) % S
                if Y[j, k] - G[k] < h:
                    h = Y[j, k] - G[k]
            if h < clear:
                clear = h
        out[i, _TRAVEL] = travel
        out[i, _BOB] = gmax - gmin
        if mean_s > 0.0:
            out[i, _RIPPLE] = math.sqrt(var_s / S) / mean_s
        out[i, _PEAK] = tpeak / r
        out[i, _TRIPPLE] = (tmax - tmin) / r
        out[i, _CLEAR] = clear
        if travel > 0.0:
            out[i, _SLIP] = d * slip / travel
        out[i, _CONTACT] = cmin


def walker_metrics(paths, velocities, status, crank, walker) -> np.ndarray:
    """(N, len(WALKER_METRICS)) walker metrics; inputs validated by :func:`compute_metrics`.

    paths, velocities (N, S, 2) float64 contiguous; status (N,) int64; crank (N,) crank radii;
    walker : :class:`explorer.mechanism.Walker`.
    """
    N, S = paths.shape[0], paths.shape[1]
    out = np.full((N, _N), np.nan)
    if N == 0:
        return out
    base, frac, sign = leg_samples(walker, S)
    mirrored = np.array(walker.mirrored, dtype=np.bool_)
    parallel_rows(_walker_kernel, (base, frac, sign, mirrored, float(walker.drag), float(walker.contact)),
                  (paths, velocities, status, np.ascontiguousarray(crank, dtype=np.float64), out))
    return out
