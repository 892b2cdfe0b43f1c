"""The slide equation: a slider vertex p's signed distance from its line equals the slot's offset.
One scalar row.

A ground line through l along the unit n: r = n × (p − l) − off (off = 0). A slot along a member that
holds a and b at the fixed distance L = |b − a|: r = cross(b − a, p − a)/L − off, bilinear (affine in
each of p, a, b alone, so each partial is free of that vertex's own position). One convention for
every kernel: that residual, its partials (:func:`slide_eval`), and the curvature term
2 cross(v_b − v_a, v_p − v_a)/L of a slot (0 for a ground line), so its rows obey J·V = 0 and
J·A = −curvature. A multiplier λ pulls each of its vertices by its partial × λ (the guide's push,
normal to the line: no friction).

Equations, in order: each slider that no linear actuator drives (``Plan.slide``: p, a, b, a = b = −1
for a ground line); their lines are ``Designs.slide`` (lx, ly, nx, ny, off, L).
"""

import numpy as np
from numba import njit

NAME = "slide"
ORDER = 2
ROWS = 1
ROW = 3


def gather(mech, index, bases):
    """Each slide equation's (p, a, b) vertices (a = b = −1: a ground line), and its slider's index."""
    actuated = mech.path.slider if mech.path is not None else None
    slide, slide_slider = [], []
    for si, sl in enumerate(mech.sliders):
        if sl.name != actuated:
            a, b = (-1, -1) if sl.ground else (index[sl.line[0]], index[sl.line[1]])
            slide.append((index[sl.vertex], a, b))
            slide_slider.append(si)
    return slide, {"slide": np.array(slide, dtype=np.int64).reshape(-1, 3),
                   "slide_slider": np.array(slide_slider, dtype=np.int64)}


def key(mech) -> tuple:
    """What of the mechanism its equations' structure depends on (part of the plan's cache key)."""
    return (tuple((s.vertex, s.line) for s in mech.sliders), mech.path.slider if mech.path is not None else None)


def describe(mech, plan, k: int) -> str:
    sl = mech.sliders[int(plan.slide_slider[k])]
    where = (f"the line through {[float(sl.point[0]), float(sl.point[1])]}" if sl.ground
             else f"the slot {sl.line[0]}-{sl.line[1]}")
    return f"slider {sl.name}: {sl.vertex} on {where}"


@njit(cache=True)
def slide_eval(ground, px, py, ax, ay, bx, by, lx, ly, nx, ny, off, L):
    """A slide equation's residual and partial derivatives: (r, ∂r/∂p (x, y), ∂r/∂a, ∂r/∂b).

    Ground line through (lx, ly) along the unit (nx, ny): r = n × (p − l) − off (a and b unused, their
    partials 0). Slot along a → b, |b − a| = L: r = cross(b − a, p − a)/L − off."""
    if ground:
        return nx * (py - ly) - ny * (px - lx) - off, -ny, nx, 0.0, 0.0, 0.0, 0.0
    gx = bx - ax
    gy = by - ay
    r = (gx * (py - ay) - gy * (px - ax)) / L - off
    return r, -gy / L, gx / L, (by - py) / L, (px - bx) / L, (py - ay) / L, (ax - px) / L


@njit(cache=True)
def slide_row(P, k, slide, sd):
    """:func:`slide_eval` of slide equation k at positions P (n_vertices, 2); slide (n_slide, 3) and sd
    (n_slide, 6): ``Topology.slide`` and ``Designs.slide``."""
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


@njit(cache=True, inline="always")
def jacobian(P, k, slide, sd, loc, M, r):
    """Add slide equation k's partials to row r of M (columns 2·loc[v] + axis, loc[v] ≥ 0)."""
    _, jpx, jpy, jax, jay, jbx, jby = slide_row(P, k, slide, sd)
    for c, gx, gy in ((slide[k, 0], jpx, jpy), (slide[k, 1], jax, jay), (slide[k, 2], jbx, jby)):
        if c >= 0 and loc[c] >= 0:
            M[r, 2 * loc[c]] += gx
            M[r, 2 * loc[c] + 1] += gy


@njit(cache=True, inline="always")
def rates_rhs(P, V, R, k, slide, sd, loc, accel):
    """Minus the curvature term (accel) minus the known vertices' (loc < 0) terms of slide row k at rates R."""
    _, jpx, jpy, jax, jay, jbx, jby = slide_row(P, k, slide, sd)
    val = -slide_curvature(V, k, slide, sd) if accel else 0.0
    for c, gx, gy in ((slide[k, 0], jpx, jpy), (slide[k, 1], jax, jay), (slide[k, 2], jbx, jby)):
        if c >= 0 and loc[c] < 0:
            val -= gx * R[c, 0] + gy * R[c, 1]
    return val


@njit(cache=True, inline="always")
def pull(P, k, slide, sd, lam, F, r, sinc):
    """Add the pull of multiplier ``lam`` of slide equation k to the incidence forces F[r] (F: (n_rhs,
    K, 2)) at its guide's incidences sinc[k] (p, a, b)."""
    _, jpx, jpy, jax, jay, jbx, jby = slide_row(P, k, slide, sd)
    F[r, sinc[k, 0], 0] += jpx * lam
    F[r, sinc[k, 0], 1] += jpy * lam
    if slide[k, 1] >= 0:
        F[r, sinc[k, 1], 0] += jax * lam
        F[r, sinc[k, 1], 1] += jay * lam
        F[r, sinc[k, 2], 0] += jbx * lam
        F[r, sinc[k, 2], 1] += jby * lam
