"""The seeds' formulations of the Jansen leg, written plainly for the accuracy bench (not used by explorer).

Seed 001 writes the leg as 8 loop-closure equations in 8 link angles (each closure equates a joint
reached along two chains of links) and solves them by Newton on the full 8 x 8 system, or
"sequentially" as 4 systems of 2 equations in 2 unknowns, in order. Seed 003 compares Gaussian
elimination with Gauss–Seidel iteration (on the normal equations JᵀJ x = Jᵀb, as the seed does) for
the linear solve inside each Newton step. Four solvers, one kernel:

    FULL_GE     seed 001's full 8 x 8 Newton, step by Gaussian elimination with partial pivoting
                (seed 003's ``gauss_elim``);
    FULL_GS     the same Newton, step by Gauss–Seidel on JᵀJ (seed 003's ``gauss_seidel``: at most
                ``gs_sweeps`` sweeps, stopping when no unknown moves by more than the tolerance);
    FULL_GS_J   Gauss–Seidel on J itself, with no preconditioning (the seed warns it "may take very
                long to converge, if at all": J has a zero on its diagonal, so it cannot even start);
    SEQUENTIAL  seed 001's 4 systems of 2 in 2, in order (θ1, θ2), (θ3, θ4), (θ6, θ7), (θ5, θ8).

Angles (radians from +x), with the vertex names of the built-in leg: A = crank tip "1", P = pivot "2",
B = "3", C = "4", D = "6", E = "5", foot F = "7":

    θ1 A→B (link 1-3)   θ2 P→B (2-3)   θ3 B→C (3-4)   θ4 P→C (2-4)
    θ5 C→E (4-5)        θ6 A→D (1-6)   θ7 P→D (2-6)   θ8 D→E (5-6)

    loop a (B twice):  A + l13 u(θ1)                          = P + l23 u(θ2)
    loop b (C twice):  A + l13 u(θ1) + l34 u(θ3)              = P + l24 u(θ4)
    loop c (D twice):  A + l16 u(θ6)                          = P + l26 u(θ7)
    loop d (E twice):  A + l13 u(θ1) + l34 u(θ3) + l45 u(θ5)  = P + l26 u(θ7) + l56 u(θ8)

The foot hangs off the rigid triangle D-E-F: F = D + l67 u(θ8 ± c), c the angle at D from the cosine
rule (seed 001's eq. 21). As in the seeds, the tolerance bounds every closure residual |f_i| in length
units, each crank angle starts from the previous solution (no predictor), the first from the nominal
design's angles at θ = 0, and nothing checks branches: a jump shows up only as position error.
Velocities (for the gait's stance speed) come from one Gaussian-elimination solve J θ' = −∂f/∂θ_crank
with the converged Jacobian, whatever the row's Newton solver.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from ..kernels import parallel_rows, simulate
from ..kernels import lu_solve

FULL_GE = 0
FULL_GS = 1
FULL_GS_J = 2
SEQUENTIAL = 3

#: Solver name -> code, in table order.
SOLVERS = {"seed001-full-GE": FULL_GE, "seed001-sequential": SEQUENTIAL, "seed003-GS(JtJ)": FULL_GS,
           "seed003-GS(J)": FULL_GS_J}

#: What each row is, for the table and the CSV.
DESCRIPTIONS = {
    "seed001-full-GE": "8 link angles, Newton on the full 8x8 system, Gaussian elimination (partial pivoting)",
    "seed001-sequential": "8 link angles as 4 systems of 2x2 solved in order (seed 001's 'sequential')",
    "seed003-GS(JtJ)": "8 link angles, full Newton, step by Gauss-Seidel on J^T J (seed 003)",
    "seed003-GS(J)": "8 link angles, full Newton, step by Gauss-Seidel on J, no preconditioning",
}

#: Structural facts a row's note states.
NOTES = {"seed003-GS(J)": "J[4,4] = ∂f5/∂θ5 = 0 always: Gauss-Seidel cannot start"}

#: Links in the order the kernel reads them: l13, l23, l34, l24, l45, l16, l26, l56, l57, l67.
LINK_ORDER = (("1", "3"), ("2", "3"), ("3", "4"), ("2", "4"), ("4", "5"), ("1", "6"), ("2", "6"), ("5", "6"),
              ("5", "7"), ("6", "7"))
#: The vertices of the angle formulation: A, P, B, C, D, E, F.
VERTICES = ("1", "2", "3", "4", "6", "5", "7")

STATUS_OK = 0
STATUS_ASSEMBLY = 1  # the foot triangle 5-6-7 cannot close (cosine rule out of range)
STATUS_NOCONV = 3


def jansen_layout(mech):
    """(link index array (10,) in LINK_ORDER, pivot (2,)) for ``mech``, or None if it is not the Jansen leg
    topology (vertices 1…7, crank tip 1, one fixed pivot 2, the ten links of seed 000)."""
    if mech.crank.tip != "1" or set(mech.fixed) != {"2"} or set(mech.vertices) != set("1234567"):
        return None
    where = {frozenset((l.a, l.b)): i for i, l in enumerate(mech.links)}
    if set(where) != {frozenset(p) for p in LINK_ORDER}:
        return None
    li = np.array([where[frozenset(p)] for p in LINK_ORDER], dtype=np.int64)
    return li, np.array(mech.fixed["2"], dtype=np.float64)


def nominal_angles(P):
    """The 8 angles and the foot's signed triangle angle c of a configuration P {name: (x, y)}."""
    def ang(a, b):
        return math.atan2(P[b][1] - P[a][1], P[b][0] - P[a][0])

    th = np.array([ang("1", "3"), ang("2", "3"), ang("3", "4"), ang("2", "4"), ang("4", "5"), ang("1", "6"),
                   ang("2", "6"), ang("6", "5")])
    e = np.subtract(P["5"], P["6"])
    f = np.subtract(P["7"], P["6"])
    c_sign = 1.0 if e[0] * f[1] - e[1] * f[0] >= 0.0 else -1.0
    return th, c_sign


@njit(cache=True)
def _residual(x, ax, ay, px, py, l, f):
    """The 8 closure residuals f (8,) at angles x, crank tip (ax, ay), pivot (px, py), lengths l (10,)."""
    l13, l23, l34, l24, l45, l16, l26, l56 = l[0], l[1], l[2], l[3], l[4], l[5], l[6], l[7]
    bx = ax + l13 * math.cos(x[0])
    by = ay + l13 * math.sin(x[0])
    f[0] = bx - (px + l23 * math.cos(x[1]))
    f[1] = by - (py + l23 * math.sin(x[1]))
    cx = bx + l34 * math.cos(x[2])
    cy = by + l34 * math.sin(x[2])
    f[2] = cx - (px + l24 * math.cos(x[3]))
    f[3] = cy - (py + l24 * math.sin(x[3]))
    dx = px + l26 * math.cos(x[6])
    dy = py + l26 * math.sin(x[6])
    f[4] = ax + l16 * math.cos(x[5]) - dx
    f[5] = ay + l16 * math.sin(x[5]) - dy
    f[6] = cx + l45 * math.cos(x[4]) - (dx + l56 * math.cos(x[7]))
    f[7] = cy + l45 * math.sin(x[4]) - (dy + l56 * math.sin(x[7]))


@njit(cache=True)
def _jacobian(x, l, J):
    """J (8, 8) = ∂f/∂θ of :func:`_residual`."""
    for i in range(8):
        for j in range(8):
            J[i, j] = 0.0
    s = np.empty(8)
    c = np.empty(8)
    for j in range(8):
        s[j] = math.sin(x[j])
        c[j] = math.cos(x[j])
    l13, l23, l34, l24, l45, l16, l26, l56 = l[0], l[1], l[2], l[3], l[4], l[5], l[6], l[7]
    # loop a
    J[0, 0] = -l13 * s[0]
    J[1, 0] = l13 * c[0]
    J[0, 1] = l23 * s[1]
    J[1, 1] = -l23 * c[1]
    # loop b
    J[2, 0] = -l13 * s[0]
    J[3, 0] = l13 * c[0]
    J[2, 2] = -l34 * s[2]
    J[3, 2] = l34 * c[2]
    J[2, 3] = l24 * s[3]
    J[3, 3] = -l24 * c[3]
    # loop c
    J[4, 5] = -l16 * s[5]
    J[5, 5] = l16 * c[5]
    J[4, 6] = l26 * s[6]
    J[5, 6] = -l26 * c[6]
    # loop d
    J[6, 0] = -l13 * s[0]
    J[7, 0] = l13 * c[0]
    J[6, 2] = -l34 * s[2]
    J[7, 2] = l34 * c[2]
    J[6, 4] = -l45 * s[4]
    J[7, 4] = l45 * c[4]
    J[6, 6] = l26 * s[6]
    J[7, 6] = -l26 * c[6]
    J[6, 7] = l56 * s[7]
    J[7, 7] = -l56 * c[7]


@njit(cache=True)
def gauss_elim(A, b, x):
    """Solve A x = b (n x n) by Gaussian elimination with partial pivoting (the kernels' LU; A, b
    overwritten). Returns False on a zero pivot or a non-finite result."""
    if lu_solve(A, b, b.shape[0]) == 0.0:
        return False
    for i in range(b.shape[0]):
        x[i] = b[i]
        if not math.isfinite(x[i]):
            return False
    return True


@njit(cache=True)
def gauss_seidel(A, b, x, tol, sweeps):
    """Gauss–Seidel on A x = b from x = 0, until no unknown moves by more than ``tol`` or ``sweeps``
    sweeps. Returns the number of sweeps, or −1 if a diagonal entry is zero or the iterate is not finite."""
    n = b.shape[0]
    for i in range(n):
        x[i] = 0.0
    for it in range(sweeps):
        move = 0.0
        for i in range(n):
            if A[i, i] == 0.0:
                return -1
            s = b[i]
            for j in range(n):
                if j != i:
                    s -= A[i, j] * x[j]
            new = s / A[i, i]
            if not math.isfinite(new):
                return -1
            move = max(move, abs(new - x[i]))
            x[i] = new
        if move < tol:
            return it + 1
    return sweeps


@njit(cache=True)
def _newton_full(mode, x, ax, ay, px, py, l, tol, maxit, sweeps, f, J, M, rhs, dx):
    """Newton on the full 8 x 8 system in place. Returns the iterations, or −1 if it failed."""
    it = 0
    while True:
        _residual(x, ax, ay, px, py, l, f)
        worst = 0.0
        for i in range(8):
            if not math.isfinite(f[i]):
                return -1
            worst = max(worst, abs(f[i]))
        if worst <= tol:
            return it
        if it >= maxit:
            return -1
        _jacobian(x, l, J)
        if mode == FULL_GE:
            for i in range(8):
                rhs[i] = -f[i]
            if not gauss_elim(J, rhs, dx):
                return -1
        elif mode == FULL_GS:  # seed 003: precondition by the normal equations JᵀJ dx = −Jᵀf
            for i in range(8):
                s = 0.0
                for k in range(8):
                    s -= J[k, i] * f[k]
                rhs[i] = s
                for j in range(8):
                    s = 0.0
                    for k in range(8):
                        s += J[k, i] * J[k, j]
                    M[i, j] = s
            if gauss_seidel(M, rhs, dx, tol, sweeps) < 0:
                return -1
        else:
            for i in range(8):
                rhs[i] = -f[i]
            if gauss_seidel(J, rhs, dx, tol, sweeps) < 0:
                return -1
        for i in range(8):
            x[i] += dx[i]
        it += 1


@njit(cache=True)
def _newton_pair(x, i, j, bx, by, la, lb, tol, maxit):
    """Newton on one closure b + la u(θ_i) − lb u(θ_j) = 0 (2 equations) in the unknowns x[i], x[j], the
    rest of the loop folded into the constant b. Returns the iterations, or −1."""
    it = 0
    while True:
        si, ci, sj, cj = math.sin(x[i]), math.cos(x[i]), math.sin(x[j]), math.cos(x[j])
        f0 = bx + la * ci - lb * cj
        f1 = by + la * si - lb * sj
        if not (math.isfinite(f0) and math.isfinite(f1)):
            return -1
        if max(abs(f0), abs(f1)) <= tol:
            return it
        if it >= maxit:
            return -1
        a, b, c, d = -la * si, lb * sj, la * ci, -lb * cj
        det = a * d - b * c
        if det == 0.0 or not math.isfinite(det):
            return -1
        x[i] += (-d * f0 + b * f1) / det
        x[j] += (c * f0 - a * f1) / det
        it += 1


@njit(cache=True)
def _sequential(x, ax, ay, px, py, l, tol, maxit):
    """Seed 001's sequential solve: loops a, b, c, d in order, each a 2 x 2 Newton with the angles found
    before held fixed. Returns the 2 x 2 iterations summed, or −1."""
    l13, l23, l34, l24, l45, l16, l26, l56 = l[0], l[1], l[2], l[3], l[4], l[5], l[6], l[7]
    total = 0
    it = _newton_pair(x, 0, 1, ax - px, ay - py, l13, l23, tol, maxit)  # (θ1, θ2)
    if it < 0:
        return -1
    total += it
    bx = ax + l13 * math.cos(x[0]) - px
    by = ay + l13 * math.sin(x[0]) - py
    it = _newton_pair(x, 2, 3, bx, by, l34, l24, tol, maxit)  # (θ3, θ4)
    if it < 0:
        return -1
    total += it
    it = _newton_pair(x, 5, 6, ax - px, ay - py, l16, l26, tol, maxit)  # (θ6, θ7)
    if it < 0:
        return -1
    total += it
    bx += l34 * math.cos(x[2]) - l26 * math.cos(x[6])
    by += l34 * math.sin(x[2]) - l26 * math.sin(x[6])
    it = _newton_pair(x, 4, 7, bx, by, l45, l56, tol, maxit)  # (θ5, θ8)
    if it < 0:
        return -1
    return total + it


@njit(cache=True)
def seed_cycle(mode, l, radius, cx, cy, px, py, x0, c_sign, cth, sth, tol, maxit, sweeps, want_vel, vidx, out_pos,
               out_vel):
    """One design over the crank cycle (S = len(cth) samples). Writes every joint into out_pos (S, nv, 2)
    (joint j of A, P, B, C, D, E, F at row vidx[j]) and the foot's dF/dθ into out_vel (S, 2) when asked
    (NaN from a failure on). Returns (status, failure angle or NaN, total iterations: full Newton steps,
    or 2 x 2 Newton steps summed over the four systems)."""
    S = cth.shape[0]
    x = x0.copy()
    f = np.empty(8)
    J = np.empty((8, 8))
    M = np.empty((8, 8))
    rhs = np.empty(8)
    dx = np.empty(8)
    l13, l34, l26, l56, l57, l67 = l[0], l[2], l[6], l[7], l[8], l[9]  # the lengths the closed form needs
    out_pos[:, :, :] = np.nan
    if want_vel:
        out_vel[:, :] = np.nan
    cosc = (l56 * l56 + l67 * l67 - l57 * l57) / (2.0 * l56 * l67)
    if not (abs(cosc) <= 1.0):
        return STATUS_ASSEMBLY, 0.0, 0
    c = c_sign * math.acos(cosc)
    total = 0
    for k in range(S):
        ax = cx + radius * cth[k]
        ay = cy + radius * sth[k]
        if mode == SEQUENTIAL:
            it = _sequential(x, ax, ay, px, py, l, tol, maxit)
        else:
            it = _newton_full(mode, x, ax, ay, px, py, l, tol, maxit, sweeps, f, J, M, rhs, dx)
        if it < 0:
            return STATUS_NOCONV, 2.0 * np.pi * k / S, total
        total += it
        # every joint from the angles, A, P, B, C, D, E, F into the rows vidx of out_pos
        bx = ax + l13 * math.cos(x[0])
        by = ay + l13 * math.sin(x[0])
        qx = bx + l34 * math.cos(x[2])
        qy = by + l34 * math.sin(x[2])
        dx_ = px + l26 * math.cos(x[6])
        dy_ = py + l26 * math.sin(x[6])
        xs = (ax, px, bx, qx, dx_, dx_ + l56 * math.cos(x[7]), dx_ + l67 * math.cos(x[7] + c))
        ys = (ay, py, by, qy, dy_, dy_ + l56 * math.sin(x[7]), dy_ + l67 * math.sin(x[7] + c))
        for j in range(7):
            out_pos[k, vidx[j], 0] = xs[j]
            out_pos[k, vidx[j], 1] = ys[j]
        if want_vel:
            # J θ' = −∂f/∂θ_crank; the tip A = centre + r u(θ_crank) enters every loop with a + sign
            _jacobian(x, l, J)
            for i in range(4):
                rhs[2 * i] = radius * sth[k]
                rhs[2 * i + 1] = -radius * cth[k]
            if not gauss_elim(J, rhs, dx):
                return STATUS_NOCONV, 2.0 * np.pi * k / S, total
            out_vel[k, 0] = -l26 * math.sin(x[6]) * dx[6] - l67 * math.sin(x[7] + c) * dx[7]
            out_vel[k, 1] = l26 * math.cos(x[6]) * dx[6] + l67 * math.cos(x[7] + c) * dx[7]
    return STATUS_OK, np.nan, total


@njit(cache=True, nogil=True)
def seed_batch(mode, cx, cy, px, py, x0, c_sign, cth, sth, tol, maxit, sweeps, want_vel, vidx, lengths, radius,
               out_pos, out_vel, status, fail_theta, iters):
    """:func:`seed_cycle` for every row of ``lengths`` (N, 10) in LINK_ORDER, serially; the per-row
    arguments come last (from ``lengths`` on), for :func:`explorer.kernels.parallel_rows`."""
    for i in range(lengths.shape[0]):
        st, th, it = seed_cycle(mode, lengths[i], radius[i], cx, cy, px, py, x0, c_sign, cth, sth, tol, maxit,
                                sweeps, want_vel, vidx, out_pos[i], out_vel[i])
        status[i] = st
        fail_theta[i] = th
        iters[i] = it


def solve_seed(solver, mech, lengths, crank, steps, *, tolerance=1e-10, max_iterations=50, gs_sweeps=100,
               velocities=False):
    """Run one seed solver on N variants of the Jansen leg ``mech``.

    solver : a key of SOLVERS; lengths (N, n_links) in mech.links order; crank (N,).
    Returns (positions (N, S, n_vertices, 2) in mech.vertices order, foot velocities (N, S, 2) or None,
    status (N,) 0 ok / 1 foot triangle cannot close / 3 no convergence, failure angle (N,) rad,
    iterations (N,)).
    """
    layout = jansen_layout(mech)
    if layout is None:
        raise ValueError("the seed formulations are written for the Jansen leg only")
    li, pivot = layout
    lengths = np.ascontiguousarray(np.asarray(lengths, dtype=np.float64)[:, li])
    crank = np.ascontiguousarray(np.asarray(crank, dtype=np.float64).reshape(-1))
    # the nominal configuration at θ = 0 gives the first guess, as the seeds measured theirs
    P0 = simulate(mech, 3, method="closed", velocities=False).positions[0]
    x0, c_sign = nominal_angles({v: P0[mech.vertex_index(v)] for v in mech.vertices})
    theta = 2.0 * np.pi * np.arange(steps) / steps
    N = lengths.shape[0]
    pos = np.empty((N, steps, len(mech.vertices), 2))
    vidx = np.array([mech.vertex_index(v) for v in VERTICES], dtype=np.int64)
    vel = np.empty((N, steps if velocities else 0, 2))
    status = np.empty(N, dtype=np.int8)
    fth = np.empty(N)
    its = np.empty(N, dtype=np.int64)
    cx, cy = mech.crank.center
    parallel_rows(seed_batch, (SOLVERS[solver], float(cx), float(cy), float(pivot[0]), float(pivot[1]), x0, c_sign,
                               np.cos(theta), np.sin(theta), float(tolerance), int(max_iterations), int(gs_sweeps),
                               bool(velocities), vidx), (lengths, crank, pos, vel, status, fth, its))
    return pos, (vel if velocities else None), status, fth, its
