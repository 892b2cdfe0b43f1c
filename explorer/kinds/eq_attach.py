"""The attach equation: p_j − p_p − u (p_q − p_p) − w R(p_q − p_p) = 0, R a quarter turn
counter-clockwise: a rigid body's joint j from its base pair (p, q), (u, w) the joint's coordinates
in the frame of the pair scaled by its length (``Designs.uv``). Two rows, x and y; linear in the
positions, so its rates obey the same rows with the rates in place of the positions and no curvature.

One convention for every kernel: residual r = p_j − (p_p + A (p_q − p_p)), A = [[u, −w], [w, u]];
gradient ∂r/∂p_j = I, ∂r/∂p_p = A − I, ∂r/∂p_q = −A. A multiplier λ (2,) pulls p_j by λ, p_p by
(Aᵀ − I)λ and p_q by −Aᵀλ.

Equations, in order: each body's joints other than its base pair (``Plan.attach``: joint, p, q).
"""

import numpy as np
from numba import njit

NAME = "attach"
ORDER = 1
ROWS = 2
#: the row type codes of its x and y rows in a coupled block
ROW_X = 1
ROW_Y = 2


def gather(mech, index, bases):
    """Each attach equation's (joint, p, q) vertices, and the plan fields that name its body and joint."""
    attach, attach_body, attach_joint = [], [], []
    for bi, (body, (p, q)) in enumerate(zip(mech.bodies, bases)):
        for ji, j in enumerate(body.joints):
            if ji not in (p, q):
                attach.append((index[j], index[body.joints[p]], index[body.joints[q]]))
                attach_body.append(bi)
                attach_joint.append(ji)
    return attach, {"attach": np.array(attach, dtype=np.int64).reshape(-1, 3),
                    "attach_body": np.array(attach_body, dtype=np.int64),
                    "attach_joint": np.array(attach_joint, dtype=np.int64)}


def key(mech) -> tuple:
    """Its structure is the bodies' (in the distance equations' key)."""
    return ()


def describe(mech, plan, t: int) -> str:
    names = mech.vertices
    j, p, q = (int(k) for k in plan.attach[t])
    body = mech.bodies[int(plan.attach_body[t])]
    return f"body {body.name}: {names[j]} rigidly from {names[p]}, {names[q]}"


@njit(cache=True, inline="always")
def residual(P, t, ax, att_vpq, uv):
    """The x (ax 0) or y (ax 1) component of p_j − (p_p + u (p_q − p_p) + w R(p_q − p_p))."""
    j = att_vpq[t, 0]
    p = att_vpq[t, 1]
    q = att_vpq[t, 2]
    gx = P[q, 0] - P[p, 0]
    gy = P[q, 1] - P[p, 1]
    if ax == 0:
        return P[j, 0] - (P[p, 0] + uv[t, 0] * gx - uv[t, 1] * gy)
    return P[j, 1] - (P[p, 1] + uv[t, 0] * gy + uv[t, 1] * gx)


@njit(cache=True, inline="always")
def jacobian(t, ax, att_vpq, uv, loc, M, r):
    """Add row ``ax`` of attach equation t to row r of M (columns 2·loc[v] + axis, loc[v] ≥ 0)."""
    u = att_vpq[t, 0]
    w = att_vpq[t, 1]
    z = att_vpq[t, 2]
    cu = uv[t, 0]
    cv = uv[t, 1]
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


@njit(cache=True, inline="always")
def rates_rhs(R, t, ax, att_vpq, uv, loc):
    """Minus row ``ax``'s terms in the known vertices (loc < 0) at rates R (no curvature: linear)."""
    u = att_vpq[t, 0]
    w = att_vpq[t, 1]
    z = att_vpq[t, 2]
    cu = uv[t, 0]
    cv = uv[t, 1]
    oth = 1 - ax
    sv = 1.0 if ax == 0 else -1.0
    val = 0.0
    if loc[u] < 0:
        val -= R[u, ax]
    if loc[w] < 0:
        val -= (cu - 1.0) * R[w, ax] - sv * cv * R[w, oth]
    if loc[z] < 0:
        val -= -cu * R[z, ax] + sv * cv * R[z, oth]
    return val


#: :func:`pull` as the forces code generated per topology writes it (``explorer.kernels._forces_scalar``):
#: equation {t} (its numbers ut_{t}, wt_{t}: ``Designs.uv``), its multiplier (lamx{r}_{t}, lamy{r}_{t})
#: for right-hand side {r}, into the incidence forces F{r}_{ij}, F{r}_{ip}, F{r}_{iq} (x, y). The same
#: arithmetic.
PULL_SCALAR = """\
atx = ut_{t} * lamx{r}_{t} + wt_{t} * lamy{r}_{t}
aty = -wt_{t} * lamx{r}_{t} + ut_{t} * lamy{r}_{t}
F{r}_{ij}x += lamx{r}_{t}
F{r}_{ij}y += lamy{r}_{t}
F{r}_{ip}x -= lamx{r}_{t} - atx
F{r}_{ip}y -= lamy{r}_{t} - aty
F{r}_{iq}x -= atx
F{r}_{iq}y -= aty
"""


@njit(cache=True, inline="always")
def pull(t, uv, lx, ly, F, r, inc_j, inc_p, inc_q):
    """Add the pull of multiplier (lx, ly) of attach equation t on its three pins to the incidence
    forces F[r] (F: (n_rhs, K, 2)): λ on j, (Aᵀ − I)λ on p, −Aᵀλ on q."""
    u = uv[t, 0]
    w = uv[t, 1]
    atx = u * lx + w * ly
    aty = -w * lx + u * ly
    F[r, inc_j, 0] += lx
    F[r, inc_j, 1] += ly
    F[r, inc_p, 0] -= lx - atx
    F[r, inc_p, 1] -= ly - aty
    F[r, inc_q, 0] -= atx
    F[r, inc_q, 1] -= aty
