"""ATTACH: one joint of a rigid body placed from its body's known base pair p, q, exactly: at
p + u (q − p) + w R(q − p) (R a quarter turn counter-clockwise), (u, w) the joint's coordinates in
the frame of the base pair scaled by its length (``Designs.uv``).

A rigid transform: no Newton, no branch (a body never mirrors), no way to fail; its rates follow by
the same map (the attach equation is linear), and its reactions are the identity (the multiplier of
its two rows is the load on the joint, passed to the base pair by Aᵀ).
"""

import numpy as np
from numba import njit


NAME = "ATTACH"
NUMBER = 1
TEXT = "a body joint placed rigidly from its body's two known joints (exact)"
#: its columns of ``Topology.blk``: the joint, its base pair and its attach equation
COLUMNS = ("vertex", "p", "q", "eq")
#: per-design fields: the joint, the base pair (as a, b), its frame coordinates u, v
FIELDS = (("vertex", "i8"), ("a", "i8"), ("b", "i8"), ("u", "f8"), ("v", "f8"))
#: the vertices (columns) its generated code reads
READS = ("p", "q")
#: the start places it from its base pair (no branch)
START = "always"


def classify(vertices, rows, tables) -> bool:
    """One vertex, the two rows of one attach equation that places it."""
    return (len(vertices) == 1 and len(rows) == 2 and all(r[0] == "attach" for r in rows)
            and rows[0][1] == rows[1][1] and int(tables["attach"][rows[0][1]][0]) == vertices[0])


def lower(plan, block, crank: bool, shared: dict) -> tuple:
    t = block.attaches[0][0]
    j, p, q = (int(x) for x in plan.attach[t])
    return (j, p, q, t)


def assemble(k, P, ctx):
    """The joint by its body's rigid transform of its base pair (always placed)."""
    t = ctx.plan.blocks[k].attaches[0][0]
    j, p, q = ctx.plan.attach[t]
    (u, w), g = ctx.des.uv[0][t], P[q] - P[p]
    P[j] = P[p] + u * g + w * np.array([-g[1], g[0]])
    return True


def branch(k, P, ctx) -> float:
    """No branch: 0."""
    return 0.0


@njit(cache=True, error_model="numpy")
def attach_vector(j, p, q, u, w, X, Y, VX, VY):
    """Joint j over every sample at once from its base pair's rows of X, Y (positions) and VX, VY
    (tangents), (n_vertices, S) each: p + u (q − p) + w R(q − p), and the same map of the tangents."""
    xp = X[p]
    yp = Y[p]
    xq = X[q]
    yq = Y[q]
    up = VX[p]
    wp = VY[p]
    uq = VX[q]
    wq = VY[q]
    xj = X[j]
    yj = Y[j]
    uj = VX[j]
    wj = VY[j]
    for k in range(xp.shape[0]):
        gx = xq[k] - xp[k]
        gy = yq[k] - yp[k]
        xj[k] = xp[k] + u * gx - w * gy
        yj[k] = yp[k] + u * gy + w * gx
        hx = uq[k] - up[k]
        hy = wq[k] - wp[k]
        uj[k] = up[k] + u * hx - w * hy
        wj[k] = wp[k] + u * hy + w * hx


ARRAY = {
    "imports": "from explorer.kinds.attach import attach_vector",
    "fill": """\
t = row[3]
rec.vertex = att_vpq[t, 0]
rec.a = att_vpq[t, 1]
rec.b = att_vpq[t, 2]
rec.u = uv[t, 0]
rec.v = uv[t, 1]
""",
    "place": """\
a = rec.a
b = rec.b
P[rec.vertex, 0], P[rec.vertex, 1] = frame_point(rec.u, rec.v, P[a, 0], P[a, 1], P[b, 0], P[b, 1])
""",
    "step": """\
v = rec.vertex
a = rec.a
b = rec.b
u = rec.u
w = rec.v
P1[v, 0], P1[v, 1] = frame_point(u, w, P1[a, 0], P1[a, 1], P1[b, 0], P1[b, 1])
V1[v, 0], V1[v, 1] = frame_point(u, w, V1[a, 0], V1[a, 1], V1[b, 0], V1[b, 1])
if want_acc:
    A1[v, 0], A1[v, 1] = frame_point(u, w, A1[a, 0], A1[a, 1], A1[b, 0], A1[b, 1])
""",
    "check": "",  # no branch, nothing to check
    # the vectorised first pass: every sample at once by the rigid transform (nothing to flag)
    "vector": """\
attach_vector(rec.vertex, rec.a, rec.b, rec.u, rec.v, X, Y, VX, VY)
""",
    "good": "pass  # its vector form flags nothing\n",
    "sign": "",   # no branch: 0
    "singular": "",  # never singular
    # the forces effect: its two rows' multipliers are the load on the joint; Aᵀλ goes to q, λ − Aᵀλ to p
    "reactions": """\
t = blk[k, 3]
j = rec.vertex
p = rec.a
q = rec.b
u = rec.u
w = rec.v
for r in range(R.shape[0]):
    if act[r]:
        lx = R[r, j, 0]
        ly = R[r, j, 1]
        lam_a[r, t, 0] = lx
        lam_a[r, t, 1] = ly
        R[r, j, 0] = 0.0
        R[r, j, 1] = 0.0
        atx = u * lx + w * ly  # Aᵀ λ with A = [[u, −w], [w, u]]
        aty = -w * lx + u * ly
        R[r, p, 0] += lx - atx
        R[r, p, 1] += ly - aty
        R[r, q, 0] += atx
        R[r, q, 1] += aty
""",
}

SCALAR = {
    "init": """\
u_{k} = tab[{k}].u
w_{k} = tab[{k}].v
""",
    "step": """\
# block {k}: body joint {v} from its base pair {p}, {q}
x{v}, y{v} = frame_point(u_{k}, w_{k}, x{p}, y{p}, x{q}, y{q})
vx{v}, vy{v} = frame_point(u_{k}, w_{k}, vx{p}, vy{p}, vx{q}, vy{q})
""",
    "acc": """\
zx{v}, zy{v} = frame_point(u_{k}, w_{k}, zx{p}, zy{p}, zx{q}, zy{q})
""",
    "imports": "from explorer.kinds._common import frame_point",
    # the forces effect's code generated per topology (``explorer.kernels._forces_scalar``): never
    # singular; for right-hand side {r} its two rows' multipliers are the load on the joint, Aᵀλ goes to
    # q and λ − Aᵀλ to p (the table-driven ``reactions`` snippet's arithmetic, in scalars)
    "forces_init": """\
fu_{k} = table[{k}].u
fw_{k} = table[{k}].v
""",
    "forces_geometry": "",
    "reactions": """\
lamx{r}_{eq} = R{r}_{v}x
lamy{r}_{eq} = R{r}_{v}y
atx = fu_{k} * R{r}_{v}x + fw_{k} * R{r}_{v}y  # Aᵀ λ with A = [[u, −w], [w, u]]
aty = -fw_{k} * R{r}_{v}x + fu_{k} * R{r}_{v}y
R{r}_{p}x += R{r}_{v}x - atx
R{r}_{p}y += R{r}_{v}y - aty
R{r}_{q}x += atx
R{r}_{q}y += aty
""",
}
