"""The distance equation: |p_b − p_a|² − d² = 0 (a link, or a rigid body's base pair). One scalar row.

One sign and scale convention for every kernel that reads it (a coupled block's Newton and rates,
the dense method, the forces' multipliers): residual r = |g|² − d² with g = p_b − p_a; gradient
∂r/∂p_b = 2g, ∂r/∂p_a = −2g; curvature (the term its rows' second derivative adds) 2|v_b − v_a|², so
the rates obey 2g·(V_b − V_a) = 0 and 2g·(A_b − A_a) = −2|V_b − V_a|². A multiplier λ of this row
pulls p_b by 2g·λ and p_a by −2g·λ.

Equations, in order: the mechanism's links, then each rigid body's base pair (``Plan.link_a``,
``Plan.link_b``); their lengths are ``Designs.dist``.
"""

import numpy as np
from numba import njit

NAME = "distance"
#: the equation types' order in a plan (a plan's rows: every distance equation, then attach, ...)
ORDER = 0
#: rows per equation
ROWS = 1
#: the row type code of a coupled block's row (``Topology.gen_rows[:, 0]``)
ROW = 0


def gather(mech, index, bases):
    """Each distance equation's two vertices: the links', then each body's base pair (``bases``: the
    chosen base pair of each body, indices into its joints). Returns (ends (n, 2) list, plan fields)."""
    ends = [(index[lk.a], index[lk.b]) for lk in mech.links]
    for body, (p, q) in zip(mech.bodies, bases):
        ends.append((index[body.joints[p]], index[body.joints[q]]))
    link_a = np.array([a for a, _ in ends], dtype=np.int64)
    link_b = np.array([b for _, b in ends], dtype=np.int64)
    return ends, {"link_a": link_a, "link_b": link_b, "n_links": len(mech.links),
                  "body_base": np.array(bases, dtype=np.int64).reshape(-1, 2)}


def key(mech) -> tuple:
    """What of the mechanism its equations' structure depends on (part of the plan's cache key)."""
    return (tuple((lk.a, lk.b) for lk in mech.links), tuple(b.joints for b in mech.bodies))


def describe(mech, plan, e: int) -> str:
    """The equation in words (``explorer describe``)."""
    if e < plan.n_links:
        lk = mech.links[e]
        return f"link {lk.name}" + (f" ({lk.a}-{lk.b})" if lk.name != f"{lk.a}-{lk.b}" else "")
    body = mech.bodies[e - plan.n_links]
    p, q = (int(k) for k in plan.body_base[e - plan.n_links])
    return f"body {body.name}: distance {body.joints[p]}-{body.joints[q]}"


@njit(cache=True, inline="always")
def residual(P, e, dist_a, dist_b, L):
    """(r, d²): the residual |p_b − p_a|² − d² of equation e at positions P, and d²."""
    u = dist_a[e]
    w = dist_b[e]
    gx = P[w, 0] - P[u, 0]
    gy = P[w, 1] - P[u, 1]
    d2 = L[e] * L[e]
    return gx * gx + gy * gy - d2, d2


@njit(cache=True, inline="always")
def jacobian(P, e, dist_a, dist_b, loc, M, r):
    """Add equation e's gradient to row r of M in the columns 2·loc[v] + axis of its vertices with
    loc[v] ≥ 0 (the unknowns)."""
    u = dist_a[e]
    w = dist_b[e]
    gx = P[w, 0] - P[u, 0]
    gy = P[w, 1] - P[u, 1]
    if loc[u] >= 0:
        M[r, 2 * loc[u]] -= 2.0 * gx
        M[r, 2 * loc[u] + 1] -= 2.0 * gy
    if loc[w] >= 0:
        M[r, 2 * loc[w]] += 2.0 * gx
        M[r, 2 * loc[w] + 1] += 2.0 * gy


@njit(cache=True, inline="always")
def rates_rhs(P, V, R, e, dist_a, dist_b, loc, accel):
    """The right-hand side of equation e's rate row (accel: the second derivative's, R = A; else the
    tangent's, R = V): minus the curvature term, minus the known vertices' (loc < 0) terms."""
    u = dist_a[e]
    w = dist_b[e]
    gx = P[w, 0] - P[u, 0]
    gy = P[w, 1] - P[u, 1]
    val = 0.0
    if accel:
        wx = V[w, 0] - V[u, 0]
        wy = V[w, 1] - V[u, 1]
        val = -2.0 * (wx * wx + wy * wy)
    if loc[u] < 0:
        val += 2.0 * (gx * R[u, 0] + gy * R[u, 1])
    if loc[w] < 0:
        val -= 2.0 * (gx * R[w, 0] + gy * R[w, 1])
    return val


#: :func:`pull` as the forces code generated per topology writes it (``explorer.kernels._forces_scalar``):
#: equation {e} from {a} to {b}, its multiplier lam{r}_{e} for right-hand side {r}, into the incidence
#: forces F{r}_{ia}x/y (vertex a) and F{r}_{ib}x/y (vertex b); positions X{v}, Y{v}. The same arithmetic.
PULL_SCALAR = """\
dx = 2.0 * (X{b} - X{a}) * lam{r}_{e}
dy = 2.0 * (Y{b} - Y{a}) * lam{r}_{e}
F{r}_{ib}x += dx
F{r}_{ib}y += dy
F{r}_{ia}x -= dx
F{r}_{ia}y -= dy
"""


@njit(cache=True, inline="always")
def pull(P, e, dist_a, dist_b, lam, F, r, inc_a, inc_b):
    """Add the pull of multiplier ``lam`` of equation e on its two pins, (∂r/∂p)ᵀλ, to the incidence
    forces F[r] (F: (n_rhs, K, 2)) at inc_a (vertex a) and inc_b (vertex b)."""
    a = dist_a[e]
    b = dist_b[e]
    dx = 2.0 * (P[b, 0] - P[a, 0]) * lam
    dy = 2.0 * (P[b, 1] - P[a, 1]) * lam
    F[r, inc_b, 0] += dx
    F[r, inc_b, 1] += dy
    F[r, inc_a, 0] -= dx
    F[r, inc_a, 1] -= dy
