"""Slow, plain-numpy references for the walker metrics and the screen's foot-path checks (tests only).

Written from the definitions in the walker issue, independently of explorer.gait: every leg's foot
is evaluated directly at its own crank angle from a closed form (no interpolation, no sample
shifting), the ground is ``np.min`` over the legs, the contact leg ``np.argmin`` (first of equals),
and every statistic is a numpy one-liner. Self-crossings are counted by brute force over all pairs.
"""

from __future__ import annotations

import math

import numpy as np

NAMES = ("travel", "bob", "body_speed_ripple", "peak_torque", "torque_ripple", "clearance", "slip",
         "contact_fraction")


def legs_at(foot, S: int, phases, mirrored, cx: float = 0.0):
    """Every leg's foot at θ_k = 2πk/S: y (L, S), dx/dθ (L, S), dy/dθ (L, S).

    foot(theta) -> (positions (n, 2), velocities (n, 2)) at any crank angles (a closed form).
    A plain leg j reads the foot at θ + φ_j; a mirrored leg reads it at α = π − θ − φ_j and reflects
    it about x = cx, so its x-velocity is +dx/dα (reflection and running backwards cancel) and its
    y-velocity −dy/dα.
    """
    theta = 2.0 * np.pi * np.arange(S) / S
    Y, VX, VY = [], [], []
    for phi, mir in zip(phases, mirrored):
        if mir:
            p, v = foot(np.pi - theta - phi)
            Y.append(p[:, 1])
            VX.append(v[:, 0])
            VY.append(-v[:, 1])
        else:
            p, v = foot(theta + phi)
            Y.append(p[:, 1])
            VX.append(v[:, 0])
            VY.append(v[:, 1])
    return np.array(Y), np.array(VX), np.array(VY)


def naive_walker(Y, VX, VY, crank: float, drag: float = 0.0, contact: float = 0.01, fine=None) -> dict[str, float]:
    """The walker metrics of legs sampled at θ_k = 2πk/S (arrays (L, S) from :func:`legs_at`).

    fine : None, or the legs' heights (L, S, R) at R points evenly spaced inside each sample interval
    (θ_k + 2π/S·r/R, r = 0 … R−1, from the closed form): a leg that comes within the contact band at one
    of them, between two samples it is off the ground at, taps the ground there; the nearer of the two
    samples (the lower height above the ground) then counts as down for the swing (the clearance).
    """
    L, S = Y.shape
    d = 2.0 * np.pi / S
    k = np.arange(S)
    g = Y.min(axis=0)
    # the first leg among equals; feet within 1e-9 are equal (the closed form evaluates a mirrored
    # leg at π − θ − φ, which lands on the same angle as a plain leg's θ + φ up to rounding)
    c = np.argmax(Y <= g[None, :] + 1e-9, axis=0)
    vxc, vyc = VX[c, k], VY[c, k]
    out = {"bob": float(g.max() - g.min())}
    total = d * vxc.sum()
    out["travel"] = abs(float(total))
    speed = np.abs(vxc)
    out["body_speed_ripple"] = float(speed.std() / speed.mean()) if speed.mean() > 0 else math.nan
    u = -np.sign(total)                        # the direction the body walks
    force = np.stack([np.full(S, u * drag), np.ones(S)], axis=1)   # ground on the contact foot, per W
    tau = -(force * np.stack([vxc, vyc], axis=1)).sum(axis=1)
    out["peak_torque"] = float(np.abs(tau).max() / crank)
    out["torque_ripple"] = float((tau.max() - tau.min()) / crank)
    touching = Y <= g[None, :] + contact * crank
    out["contact_fraction"] = float(touching.mean(axis=1).min())
    spread = [VX[touching[:, i], i].max() - VX[touching[:, i], i].min() for i in range(S)]
    out["slip"] = float(d * np.sum(spread) / out["travel"]) if out["travel"] > 0 else math.nan
    down = touching.copy()
    if fine is not None:
        gf = fine.min(axis=0)                                   # (S, R) the ground between the samples
        for j in range(L):
            for i in range(S):
                i1 = (i + 1) % S
                if touching[j, i] or touching[j, i1]:
                    continue
                if (fine[j, i, 1:] - gf[i, 1:] <= contact * crank).any():
                    down[j, i if Y[j, i] - g[i] <= Y[j, i1] - g[i1] else i1] = True
    heights = []
    for j in range(L):
        off = ~down[j]
        if not off.any():
            heights.append(0.0)
            continue
        # every cyclic run of samples off the ground, by brute force from every start; the longest wins
        best = None
        for s in range(S):
            if not off[s] or off[(s - 1) % S]:
                continue
            n = 0
            while n < S and off[(s + n) % S]:
                n += 1
            if best is None or n > best[1]:
                best = (s, n)
        s, n = best
        q = n // 4
        idx = (s + np.arange(q, n - q)) % S
        heights.append(float((Y[j, idx] - g[idx]).min()))
    out["clearance"] = float(min(heights))
    return out


def circle_walker_truth(R: float, crank: float, contact: float) -> dict[str, float]:
    """Exact walker metrics of two legs half a turn apart on the foot path p(θ) = R (cos θ, sin θ).

    The ground is g = −R|sin θ|; the contact foot moves at dx/dθ = R|sin θ| (so the body travels 4R
    per turn); the crank torque per weight is −dy_c/dθ = ∓R cos θ; the second leg touches where
    2R sin θ ≤ δ = contact·crank, i.e. within a = asin(δ/2R) of θ = 0 and π, where the two feet
    slide against each other at 2R|sin θ|.
    """
    a = math.asin(min(1.0, contact * crank / (2.0 * R)))
    return {
        "travel": 4.0 * R,
        "bob": R,
        "body_speed_ripple": math.sqrt(math.pi ** 2 / 8.0 - 1.0),
        "peak_torque": R / crank,
        "torque_ripple": 2.0 * R / crank,
        "contact_fraction": 0.5 + a / math.pi,
        "slip": 8.0 * R * (1.0 - math.cos(a)) / (4.0 * R),
        # the swing is θ ∈ (a, π − a); its middle half starts a quarter in, where the foot is lowest
        "clearance": 2.0 * R * math.sin(a + (math.pi - 2.0 * a) / 4.0),
    }


def crossings_brute(path: np.ndarray) -> int:
    """Proper crossings between non-adjacent segments of the closed polyline through ``path`` (S, 2)."""
    S = len(path)
    seg = [(path[i], path[(i + 1) % S]) for i in range(S)]

    def orient(p, q, r):
        return (q[0] - p[0]) * (r[1] - p[1]) - (q[1] - p[1]) * (r[0] - p[0])

    n = 0
    for i in range(S):
        for j in range(i + 2, S):
            if i == 0 and j == S - 1:
                continue
            (a, b), (c, d) = seg[i], seg[j]
            if orient(a, b, c) * orient(a, b, d) < 0 and orient(c, d, a) * orient(c, d, b) < 0:
                n += 1
    return n
