"""A plain-numpy Newton–Euler model of a walker whose body moves with its contact foot (tests only).

Nothing here imports explorer. The legs are free rigid members (bars, or bodies with a centroid and an
inertia) joined by massless pins; every leg hangs from the walker's body (its ground pivots and crank
bearing), which does not turn (pitch held) and moves with the planted contact foot; the ground pushes
on that foot only. Per crank sample one linear system holds every equation of the whole machine:

* each member: Σ (its pins' forces on it) + m·g⃗ = m·a_G and Σ (r_pin − r_G) × F = I_G·α;
* each crank (a bar from the bearing to the tip, turned by the motor's torque τ_j at constant ω):
  B + T + m_c·g⃗ = m_c·a_G and (c − G) × B + (tip − G) × T + τ_j = 0;
* each pin: the forces its members put on it, the frame's (at a ground pivot) and the ground's (on
  the contact foot) sum to zero;
* the body (mass m_b): −Σ (the frame's forces on the pins) − Σ B_j + m_b·g⃗ + drag = m_b·a_b;

unknowns: every pin's force on every member, each crank's bearing force, tip force and torque, the
frame's force on each ground pivot of each leg and the ground's force on the contact foot. The
accelerations are world ones: a = a_b + ω²·d²p/dθ² with a_b = −ω²·d²p_c/dθ², p_c the contact foot
(the lowest; feet level within rounding tie, to the first leg), and every θ-derivative a five-point central difference of a
closed form. A mirrored leg is the mirror image (about the crank centre's vertical) of the leg at
π − θ − φ_j: its crank turns with the others.
"""

from __future__ import annotations

import numpy as np


def cross(u, w):
    """z-component of u × w for arrays (..., 2)."""
    return u[..., 0] * w[..., 1] - u[..., 1] * w[..., 0]


def rot90(u):
    return np.stack([-u[..., 1], u[..., 0]], axis=-1)


def leg_kinematics(positions, S: int, phase: float, mirrored: bool, cx: float, h: float = 1e-3) -> dict:
    """{vertex: (P, V, A)} of one leg at θ_k = 2πk/S, each (S, 2), model units, per radian and per
    radian² of crank. positions(θ) -> {vertex: (n, 2)}: the base leg's closed form."""
    theta = 2.0 * np.pi * np.arange(S) / S

    def at(t):
        if not mirrored:
            return positions(t + phase)
        out = {}
        for v, p in positions(np.pi - t - phase).items():
            p = np.array(p, dtype=np.float64)
            p[..., 0] = 2.0 * cx - p[..., 0]
            out[v] = p
        return out

    p0, pp, pm, p2, m2 = at(theta), at(theta + h), at(theta - h), at(theta + 2 * h), at(theta - 2 * h)
    out = {}
    for v in p0:
        vel = (-p2[v] + 8 * pp[v] - 8 * pm[v] + m2[v]) / (12 * h)
        acc = (-p2[v] + 16 * pp[v] - 30 * p0[v] + 16 * pm[v] - m2[v]) / (12 * h * h)
        out[v] = (p0[v], vel, acc)
    return out


def walker_newton_euler(legs: list, mirrored: list, members: list, crank: dict, fixed: list, foot: str, op: dict,
                        drag: float, contact=None):
    """The whole walker at every sample.

    legs : [leg_kinematics(...)] one per leg; mirrored : [bool] per leg. members : [(name, joints,
    mass kg, (u, w), I_G kg·m²)]: the centroid G = a + u·(b − a) + w·R90·(b − a) from the first two
    joints a, b (a bar: (0.5, 0), m·L²/12); a mirrored leg's is the mirror image, −w. crank : {"center": (x, y), "tip": name, "mass": kg, "radius": model units}, the same
    for every leg (a mirrored leg's bearing is the mirror image, the same point on the crank axis).
    fixed : the ground pivots' names. op : unit (m per model unit), rpm, gravity, load (the body, kg).
    contact : (S,) the leg carrying the walker at each sample (default: the lowest foot's, ties to the
    first).

    Returns a dict: torque (S,) N·m (the motor's, Σ over the legs' cranks, positive along +θ);
    contact (S,) leg index; body_vel, body_acc, ground (S, 2) m/s, m/s², N; member_force {(leg, member, joint):
    (S, 2)} the force of each member (a member's name, "crank", "frame", "ground") on each of its
    pins, N; body_force (S, 2) the legs' force on the body, N.
    """
    unit, g, mb = op["unit"], op["gravity"], op["load"]
    w = op["rpm"] * 2 * np.pi / 60
    L = len(legs)
    S = legs[0][foot][0].shape[0]
    gv = np.array([0.0, -g])
    # the contact leg and the body's kinematics (m/s, m/s²)
    ys = np.array([leg[foot][0][:, 1] for leg in legs])
    if contact is None:  # the lowest foot; feet level to 1e-9 of the leg's size tie, to the first leg
        tol = 1e-9 * np.max(np.abs(ys))
        contact = np.argmax(ys <= ys.min(axis=0) + tol, axis=0)
    k = np.arange(S)
    vf = np.array([leg[foot][1] for leg in legs])[contact, k]
    af = np.array([leg[foot][2] for leg in legs])[contact, k]
    vb = -w * unit * vf
    ab = -w * w * unit * af
    walk = -np.sign(vf[:, 0].sum())  # the walker moves along +x when the planted foot moves along −x
    drag_force = np.stack([-walk * drag * mb * g * np.ones(S), np.zeros(S)], axis=-1)

    # unknowns
    idx = {}

    def var(key):
        idx.setdefault(key, len(idx))
        return idx[key]

    for j in range(L):
        for name, joints, *_ in members:
            for v in joints:
                var((j, name, v))
        var((j, "crank", "B"))
        var((j, "crank", crank["tip"]))
        var((j, "tau"))
        for f in fixed:
            var((j, "frame", f))
    var("G")
    n = 2 * len(idx)  # every unknown a 2-vector, τ_j in its x slot (its y slot pinned to 0 below)
    M = np.zeros((S, n, n))
    rhs = np.zeros((S, n))
    row = [0]

    def eq():
        r = row[0]
        row[0] += 1
        return r

    def col(key, axis=0):
        return 2 * idx[key] + axis

    def put_force(r, key, coef=1.0, axis=0):
        M[:, r, col(key, axis)] += coef

    def put_moment(r, key, arm):
        """+ arm × F(key) into row r (arm (S, 2) metres)."""
        M[:, r, col(key, 0)] += -arm[:, 1]
        M[:, r, col(key, 1)] += arm[:, 0]

    for j, leg in enumerate(legs):
        P = {v: leg[v][0] * unit for v in leg}
        A = {v: ab + leg[v][2] * unit * w * w for v in leg}
        for name, joints, m, (u, ww), I in members:
            ww = -ww if mirrored[j] else ww
            a, b = joints[0], joints[1]
            e = P[b] - P[a]
            G = P[a] + u * e + ww * rot90(e)
            ea = (leg[b][2] - leg[a][2]) * unit * w * w
            aG = A[a] + u * ea + ww * rot90(ea)
            alpha = cross(e, ea) / np.sum(e * e, axis=-1)
            rx, ry, rm = eq(), eq(), eq()
            for v in joints:
                put_force(rx, (j, name, v), 1.0, 0)
                put_force(ry, (j, name, v), 1.0, 1)
                put_moment(rm, (j, name, v), P[v] - G)
            rhs[:, rx] = m * aG[:, 0] - m * gv[0]
            rhs[:, ry] = m * aG[:, 1] - m * gv[1]
            rhs[:, rm] = I * alpha
        # the crank: a bar from the bearing c to the tip, turning at constant ω relative to the body
        c = np.broadcast_to(np.asarray(crank["center"], dtype=np.float64) * unit, (S, 2))
        tip = crank["tip"]
        mc = crank["mass"]
        G = 0.5 * (c + P[tip])
        aG = ab + 0.5 * leg[tip][2] * unit * w * w
        rx, ry, rm = eq(), eq(), eq()
        put_force(rx, (j, "crank", "B"), 1.0, 0)
        put_force(ry, (j, "crank", "B"), 1.0, 1)
        put_force(rx, (j, "crank", tip), 1.0, 0)
        put_force(ry, (j, "crank", tip), 1.0, 1)
        put_moment(rm, (j, "crank", "B"), c - G)
        put_moment(rm, (j, "crank", tip), P[tip] - G)
        M[:, rm, col((j, "tau"))] += 1.0
        rhs[:, rx] = mc * aG[:, 0] - mc * gv[0]
        rhs[:, ry] = mc * aG[:, 1] - mc * gv[1]
        r = eq()  # τ's unused y slot
        M[:, r, col((j, "tau"), 1)] = 1.0
        # every pin: the members' forces on it (minus theirs on the member), the frame's, the ground's
        pins = sorted(set(v for _, joints, *_ in members for v in joints) | {tip} | set(fixed))
        for v in pins:
            rx, ry = eq(), eq()
            for name, joints, *_ in members:
                if v in joints:
                    put_force(rx, (j, name, v), -1.0, 0)
                    put_force(ry, (j, name, v), -1.0, 1)
            if v == tip:
                put_force(rx, (j, "crank", tip), -1.0, 0)
                put_force(ry, (j, "crank", tip), -1.0, 1)
            if v in fixed:
                put_force(rx, (j, "frame", v), 1.0, 0)
                put_force(ry, (j, "frame", v), 1.0, 1)
            if v == foot:
                on = (contact == j).astype(np.float64)
                M[:, rx, col("G", 0)] += on
                M[:, ry, col("G", 1)] += on
    # the body: the legs' forces on it (minus the frame's on the pins, minus the bearings' on the cranks)
    rx, ry = eq(), eq()
    for j in range(L):
        for f in fixed:
            put_force(rx, (j, "frame", f), -1.0, 0)
            put_force(ry, (j, "frame", f), -1.0, 1)
        put_force(rx, (j, "crank", "B"), -1.0, 0)
        put_force(ry, (j, "crank", "B"), -1.0, 1)
    rhs[:, rx] = mb * ab[:, 0] - mb * gv[0] - drag_force[:, 0]
    rhs[:, ry] = mb * ab[:, 1] - mb * gv[1] - drag_force[:, 1]
    assert row[0] == n, (row[0], n)
    # every sample's system at once, block-diagonal and sparse (a batched dense solve runs the BLAS's
    # threads on 200 x 200 matrices: tens of seconds on a loaded machine)
    from scipy.sparse import csc_matrix
    from scipy.sparse.linalg import spsolve
    kk, ii, jj = np.nonzero(M)
    big = csc_matrix((M[kk, ii, jj], (kk * n + ii, kk * n + jj)), shape=(S * n, S * n))
    x = spsolve(big, rhs.reshape(-1)).reshape(S, n)

    def vec(key):
        return x[:, col(key, 0):col(key, 0) + 2]

    out = {"torque": sum(x[:, col((j, "tau"))] for j in range(L)), "contact": contact, "body_acc": ab, "body_vel": vb,
           "ground": vec("G"), "member_force": {}}
    body = np.zeros((S, 2))
    for j in range(L):
        mf = out["member_force"]
        for name, joints, *_ in members:
            for v in joints:
                mf[(j, name, v)] = -vec((j, name, v))
        mf[(j, "crank", crank["tip"])] = -vec((j, "crank", crank["tip"]))
        for f in fixed:
            mf[(j, "frame", f)] = vec((j, "frame", f))
            body -= vec((j, "frame", f))
        mf[(j, "ground", foot)] = vec("G") * (contact == j)[:, None]
        body -= vec((j, "crank", "B"))
    out["body_force"] = body
    return out


def pin_peaks(member_force: dict) -> dict:
    """{joint: the largest force any member puts on it, over the legs and the turn} (N)."""
    out = {}
    for (_, _, v), f in member_force.items():
        out[v] = max(out.get(v, 0.0), float(np.max(np.hypot(f[:, 0], f[:, 1]))))
    return out
