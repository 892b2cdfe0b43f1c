"""Where the driven vertex is: the crank's circle, or a prescribed path with a timing law.

A driver maps its parameter (the crank angle θ in radians, or time t in seconds for a path) to the
driven vertex's position, velocity and acceleration with respect to that parameter. Values are
"unit" values: the kernels place the vertex at ``center + scale * value`` (for a crank, center is
the crank centre and scale its radius, which varies per variant; for a path, 0 and 1).

Kinds and their parameter vectors ``prm``:
  CRANK  []                                        unit circle, θ counter-clockwise from +x
  LINE   [T, timing, x0, y0, x1, y1]               straight line from (x0, y0) to (x1, y1)
  ARC    [T, timing, cx, cy, R, phi0, phi1]        circular arc, angles in radians
  SPLINE [T, timing, n, c...]                      natural cubic spline through n points, uniform
                                                   knots in path fraction s; c = scipy
                                                   CubicSpline coefficients (4, n−1, 2) flattened
Timing laws give the path fraction s(t) on [0, T]: LINEAR s = t/T; QUINTIC the rest-to-rest law
s = 10τ³ − 15τ⁴ + 6τ⁵, τ = t/T (zero velocity and acceleration at both ends, seed 004).
"""

import math

import numpy as np
from numba import njit

CRANK = 0
LINE = 1
ARC = 2
SPLINE = 3
LINEAR = 0
QUINTIC = 1


@njit(cache=True)
def timing(law, T, t):
    """(s, ds/dt, d²s/dt²) of timing law ``law`` over duration T at time t (clamped to [0, T])."""
    tau = min(max(t / T, 0.0), 1.0)
    if law == QUINTIC:
        s = tau * tau * tau * (10.0 + tau * (-15.0 + 6.0 * tau))
        ds = 30.0 * tau * tau * (1.0 - tau) * (1.0 - tau) / T
        dds = (60.0 * tau - 180.0 * tau * tau + 120.0 * tau * tau * tau) / (T * T)
        return s, ds, dds
    return tau, 1.0 / T, 0.0


@njit(cache=True)
def drive(kind, prm, t, out):
    """Write (x, y, dx, dy, ddx, ddy) of the driver at parameter t into out (6,)."""
    if kind == CRANK:
        c = math.cos(t)
        s = math.sin(t)
        out[0] = c
        out[1] = s
        out[2] = -s
        out[3] = c
        out[4] = -c
        out[5] = -s
        return
    s, ds, dds = timing(int(prm[1]), prm[0], t)
    if kind == LINE:
        gx = prm[4] - prm[2]
        gy = prm[5] - prm[3]
        out[0] = prm[2] + s * gx
        out[1] = prm[3] + s * gy
        out[2] = ds * gx
        out[3] = ds * gy
        out[4] = dds * gx
        out[5] = dds * gy
    elif kind == ARC:
        R = prm[4]
        dphi = prm[6] - prm[5]
        phi = prm[5] + s * dphi
        w = ds * dphi
        al = dds * dphi
        c = math.cos(phi)
        sn = math.sin(phi)
        out[0] = prm[2] + R * c
        out[1] = prm[3] + R * sn
        out[2] = -R * w * sn
        out[3] = R * w * c
        out[4] = -R * al * sn - R * w * w * c
        out[5] = R * al * c - R * w * w * sn
    else:
        n = int(prm[2])
        m = n - 1
        i = min(int(s * m), m - 1)
        u = s - i / m
        for ax in range(2):
            # coefficient c[p, i, ax] of (u)^(3 - p) sits at 3 + (p * m + i) * 2 + ax
            c3 = prm[3 + (0 * m + i) * 2 + ax]
            c2 = prm[3 + (1 * m + i) * 2 + ax]
            c1 = prm[3 + (2 * m + i) * 2 + ax]
            c0 = prm[3 + (3 * m + i) * 2 + ax]
            p = ((c3 * u + c2) * u + c1) * u + c0
            dp = (3.0 * c3 * u + 2.0 * c2) * u + c1
            ddp = 6.0 * c3 * u + 2.0 * c2
            out[ax] = p
            out[2 + ax] = dp * ds
            out[4 + ax] = ddp * ds * ds + dp * dds


def drive_table(kind: int, prm: np.ndarray, params: np.ndarray) -> np.ndarray:
    """Driver values at every sample parameter, shape (len(params), 6) (computed once per study)."""
    out = np.empty((len(params), 6))
    for k, t in enumerate(params):
        drive(kind, prm, float(t), out[k])
    return out
