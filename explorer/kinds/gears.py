"""GEARS: a second grounded crank geared to the driving crank (a geared five-bar's). Its tip B turns
about its centre c_g at radius r_g through the angle ψ = n·θ + φ, θ the driving crank's angle, n the
gear ratio (a nonzero integer: the turns it makes per turn of the driving crank, negative the other
way) and φ its phase: B = c_g + r_g (cos ψ, sin ψ).

It is its own equation type (``EQUATION``: two rows, B − c_g − r_g (cos ψ, sin ψ) = 0, in B alone),
so the plan makes B a block of its own, placed exactly from the driver (``EXPLICIT``): no Newton, no
branch, no way to fail; its rates follow by differentiating, dB/dθ = n·r_g (−sin ψ, cos ψ),
d²B/dθ² = −n²·r_g (cos ψ, sin ψ). The crank angle is read off the driving crank's tip, so every
kernel that places the tip places B from it.

The forces effect does not take it yet (``FORCES``): the motor then drives two cranks through a
gearbox, whose torque split (n times the geared crank's torque) and mesh forces are not modelled.
"""

import math

import numpy as np
from numba import njit

NAME = "GEARS"
NUMBER = 4
TEXT = "a geared crank's tip, turned from the driving crank through its gears (exact)"
#: its columns of ``Topology.blk``: the tip it places, the driving crank's tip, its gear equation, the
#: ratio, and the first of its numbers' columns in ``Designs.extra``
COLUMNS = ("vertex", "tip", "eq", "ratio", "col")
READS = ("tip",)
#: per-design fields: the tip (vertex) and the driving crank's (a); the gear's centre, radius, ratio and
#: phase (rad); the driving crank's centre and radius
FIELDS = (("vertex", "i8"), ("a", "i8"), ("gx", "f8"), ("gy", "f8"), ("gr", "f8"), ("gn", "f8"), ("gph", "f8"),
          ("ccx", "f8"), ("ccy", "f8"), ("cr", "f8"))
#: the start places it exactly (no branch)
START = "always"
#: its vertex follows from the driver alone: the dense method takes it as known
EXPLICIT = True
FORCES = False
FORCES_REFUSED = "a geared crank ([[gears]]: the gearbox's torque split is not modelled)"


class EQUATION:
    """The gear equation B − c_g − r_g (cos ψ, sin ψ) = 0, ψ = n·θ + φ: two rows (x, y), in its tip B
    alone (the driving crank's tip is known). Equations: ``Mechanism.gears``, in order; per design its
    centre (x, y), radius and phase (rad) are four columns of ``Designs.extra``."""

    NAME = "gear"
    ORDER = 3
    ROWS = 2
    NUMBERS = 4

    @staticmethod
    def gather(mech, index, bases):
        gears = getattr(mech, "gears", ())
        return [(index[g.tip],) for g in gears], {"gear_ratio": np.array([g.ratio for g in gears], dtype=np.int64)}

    @staticmethod
    def key(mech) -> tuple:
        return tuple((g.tip, g.ratio) for g in getattr(mech, "gears", ()))

    @staticmethod
    def describe(mech, plan, e: int) -> str:
        g = mech.gears[e]
        return (f"geared crank {g.name}: {g.tip} at radius {g.radius:g} about {[float(c) for c in g.center]}, "
                f"turned {g.ratio:+d}× the crank's angle {'+' if g.phase >= 0 else '−'} {abs(g.phase):g}°")

    @staticmethod
    def numbers(mech, plan, col, N) -> np.ndarray:
        """(N, 4·n_gears): each gear's centre x, y, radius (design parameters NAME.x, NAME.y, NAME; a
        radius out of [1e-150, 1e150] is NaN: the design is invalid) and phase in radians."""
        out = np.empty((N, 4 * len(mech.gears)))
        for e, g in enumerate(mech.gears):
            out[:, 4 * e] = col(f"{g.name}.x")
            out[:, 4 * e + 1] = col(f"{g.name}.y")
            r = col(g.name)
            out[:, 4 * e + 2] = np.where((r >= 1e-150) & (r <= 1e150), r, np.nan)  # out of range: invalid
            out[:, 4 * e + 3] = math.radians(g.phase)
        return out


def classify(vertices, rows, tables) -> bool:
    """One vertex, the two rows of its gear equation."""
    return len(vertices) == 1 and len(rows) == 2 and all(r[0] == "gear" for r in rows) and rows[0][1] == rows[1][1]


def lower(plan, block, crank: bool, shared: dict) -> tuple:
    from . import extra_columns

    e = block.rows[0][1]
    first, width = extra_columns(plan)["gear"]
    return (block.vertices[0], plan.tip, e, int(plan.extra["gear_ratio"][e]), first + width * e)


def assemble(k, P, ctx):
    """The tip from the crank's, exactly (always placed)."""
    rec = ctx.table[k]
    t = int(rec["a"])
    x, y, _, _, _, _ = gear_place(P[t, 0], P[t, 1], rec["ccx"], rec["ccy"], rec["gx"], rec["gy"], rec["gr"], rec["gn"],
                                  rec["gph"])
    P[int(rec["vertex"])] = x, y
    return True


def branch(k, P, ctx) -> float:
    """No branch: 0."""
    return 0.0


@njit(cache=True, forceinline=True)
def gear_place(tx, ty, ccx, ccy, gx, gy, gr, n, ph):
    """The geared crank's tip and its rates from the driving crank's tip (tx, ty) about (ccx, ccy): its
    centre (gx, gy), radius gr, ratio n, phase ph. Returns (x, y, dx, dy, ddx, ddy), rates per radian
    of the driving crank."""
    psi = n * math.atan2(ty - ccy, tx - ccx) + ph
    c = math.cos(psi)
    s = math.sin(psi)
    return gx + gr * c, gy + gr * s, -n * gr * s, n * gr * c, -n * n * gr * c, -n * n * gr * s


@njit(cache=True)
def gear_vector(v, t, ccx, ccy, gx, gy, gr, n, ph, X, Y, VX, VY):
    """The geared tip v over every sample at once from the driving crank's tip t's rows of X, Y
    ((n_vertices, S)): positions into X, Y and rates per radian into VX, VY (the vectorised first pass;
    exact, nothing to flag)."""
    for k in range(X.shape[1]):
        X[v, k], Y[v, k], VX[v, k], VY[v, k], _, _ = gear_place(X[t, k], Y[t, k], ccx, ccy, gx, gy, gr, n, ph)


ARRAY = {
    "imports": "from explorer.kinds.gears import gear_place, gear_vector",
    "fill": """\
o = row[4]
rec.vertex = row[0]
rec.a = row[1]
rec.gx = extra[o]
rec.gy = extra[o + 1]
rec.gr = extra[o + 2]
rec.gph = extra[o + 3]
rec.gn = row[3]
rec.ccx = cx
rec.ccy = cy
rec.cr = scale
""",
    "place": """\
t = rec.a
P[rec.vertex, 0], P[rec.vertex, 1], _, _, _, _ = gear_place(P[t, 0], P[t, 1], rec.ccx, rec.ccy, rec.gx, rec.gy,
                                                           rec.gr, rec.gn, rec.gph)
""",
    "step": """\
v = rec.vertex
t = rec.a
P1[v, 0], P1[v, 1], V1[v, 0], V1[v, 1], ax_, ay_ = gear_place(P1[t, 0], P1[t, 1], rec.ccx, rec.ccy, rec.gx, rec.gy,
                                                             rec.gr, rec.gn, rec.gph)
if want_acc:
    A1[v, 0] = ax_
    A1[v, 1] = ay_
""",
    "check": "",
    "sign": "",
    "singular": "",
    "reactions": "",
    # the vectorised first pass: every sample at once, exactly (nothing to flag)
    "vector": """\
gear_vector(rec.vertex, rec.a, rec.ccx, rec.ccy, rec.gx, rec.gy, rec.gr, rec.gn, rec.gph, X, Y, VX, VY)
""",
    "good": "pass  # its vector form flags nothing\n",
}

SCALAR = {
    "init": """\
ggx_{k} = tab[{k}].gx
ggy_{k} = tab[{k}].gy
ggr_{k} = tab[{k}].gr
ggn_{k} = tab[{k}].gn
ggp_{k} = tab[{k}].gph
""",
    "step": """\
# block {k}: geared crank tip {v}, turned {ratio}× the crank (tip {tip})
x{v}, y{v}, vx{v}, vy{v}, _gax, _gay = gear_place(x{tip}, y{tip}, cx, cy, ggx_{k}, ggy_{k}, ggr_{k}, ggn_{k}, ggp_{k})
""",
    "acc": """\
zx{v} = _gax
zy{v} = _gay
""",
    "imports": "from explorer.kinds.gears import gear_place",
}
