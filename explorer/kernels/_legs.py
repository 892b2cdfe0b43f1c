"""A walker's legs on one crankshaft, read off the sampled foot of one leg (one home for the convention).

Leg j = 0 … L−1 has crank phase offset φ_j; a plain leg's foot at crank angle θ is the leg's foot at
θ + φ_j, a mirrored leg's is the mirror image (about the vertical through the crank centre) of the
foot at π − θ − φ_j (driven backwards). The ground is the lowest foot; the contact leg is the
lowest foot's leg, ties going to the lower j. ``gait._walker`` (the walker metrics) and ``_forces``
(which foot carries the load) both read the legs through these functions.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit


def leg_samples(walker, S: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Where each leg reads the sampled foot: (base, frac, sign), each (L,).

    Leg j at sample k reads the foot at fractional sample index u = sign_j·k + base_j + frac_j
    (mod S), with base_j an integer and 0 ≤ frac_j < 1; sign_j = −1 for a mirrored leg.
    """
    L = walker.legs
    base = np.empty(L, dtype=np.int64)
    frac = np.empty(L, dtype=np.float64)
    sign = np.empty(L, dtype=np.int64)
    for j in range(L):
        shift = walker.phases[j] * S / (2.0 * math.pi)
        if walker.mirrored[j]:
            u, s = S / 2.0 - shift, -1
        else:
            u, s = shift, 1
        r = round(u)
        if abs(u - r) < 1e-9:  # on the grid: read the sample itself, exactly
            u = float(r)
        b = math.floor(u)
        base[j], frac[j], sign[j] = b % S, u - b, s
    return base, frac, sign


@njit(cache=True, nogil=True)
def leg_feet(base, frac, sign, mirrored, path, vel, Y, VX, VY):
    """Every leg's foot height Y and velocity (VX, VY) (L, S) in the walker's frame, from one leg's
    sampled foot ``path``, ``vel`` (S, 2) (per radian of crank); base, frac, sign (L,) from
    :func:`leg_samples`, mirrored (L,) bool. A phase between two samples reads the cubic Hermite
    interpolant of the samples and their θ-derivatives."""
    S = path.shape[0]
    L = base.shape[0]
    d = 2.0 * math.pi / S
    for j in range(L):
        f = frac[j]
        for k in range(S):
            u0 = (sign[j] * k + base[j]) % S
            if f == 0.0:
                y = path[u0, 1]
                vx = vel[u0, 0]
                vy = vel[u0, 1]
            else:
                u1 = (u0 + 1) % S
                # cubic Hermite on [θ_u0, θ_u0 + Δ] from the samples and their θ-derivatives
                f2 = f * f
                f3 = f2 * f
                h00 = 2.0 * f3 - 3.0 * f2 + 1.0
                h10 = f3 - 2.0 * f2 + f
                h01 = -2.0 * f3 + 3.0 * f2
                h11 = f3 - f2
                g00 = (6.0 * f2 - 6.0 * f) / d
                g10 = 3.0 * f2 - 4.0 * f + 1.0
                g01 = (-6.0 * f2 + 6.0 * f) / d
                g11 = 3.0 * f2 - 2.0 * f
                y = h00 * path[u0, 1] + h10 * d * vel[u0, 1] + h01 * path[u1, 1] + h11 * d * vel[u1, 1]
                vx = g00 * path[u0, 0] + g10 * vel[u0, 0] + g01 * path[u1, 0] + g11 * vel[u1, 0]
                vy = g00 * path[u0, 1] + g10 * vel[u0, 1] + g01 * path[u1, 1] + g11 * vel[u1, 1]
            Y[j, k] = y
            if mirrored[j]:  # reflected (x' → −x') and driven backwards (dα/dθ = −1)
                VX[j, k] = vx
                VY[j, k] = -vy
            else:
                VX[j, k] = vx
                VY[j, k] = vy


@njit(cache=True, nogil=True)
def ground_contact(Y, G, C):
    """Ground G (S,) = the lowest foot at each sample, and the contact leg C (S,) attaining it (ties:
    the lower j), from the feet's heights Y (L, S)."""
    L = Y.shape[0]
    for k in range(Y.shape[1]):
        c = 0
        g = Y[0, k]
        for j in range(1, L):
            if Y[j, k] < g:
                g = Y[j, k]
                c = j
        G[k] = g
        C[k] = c


@njit(cache=True, nogil=True)
def contact_stroke(VX, C):
    """(Σ_k VX[C_k, k], Σ_k |VX[C_k, k]|) over the S samples: the contact feet's net horizontal rate sum
    (travel per turn = |2π/S · net|, the body moving by −dx of the planted foot) and its total stroke.
    A net within 1e-9 of the stroke is rounding (a walker whose contact feet come back to where they
    started, e.g. one leg, whose foot path is closed) and is returned as exactly 0: such a machine
    travels nothing (it made the cost of transport 1e16 and the slip per unit of travel as large).
    One home for the walker metrics (``gait._walker``) and the forces (``_forces``)."""
    net = 0.0
    stroke = 0.0
    for k in range(C.shape[0]):
        v = VX[C[k], k]
        net += v
        stroke += abs(v)
    if abs(net) <= 1e-9 * stroke:
        net = 0.0
    return net, stroke
