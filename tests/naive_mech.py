"""Plain-numpy references for the four-bar, the two-link arm and the path drivers (seed 004).

Nothing here imports explorer: every formula is written out from the textbook / seed 004 so the
tests compare explorer's Newton solutions against an independent closed form.

* Four-bar: the Freudenstein half-angle solution of seed 004 (both assembly modes, σ = ±1),
  with seed 004's notation: ground r1 at angle θ1 (crank centre O at the origin to the rocker
  pivot), input (crank) r2 at θ2, coupler r3 at θ3, follower (rocker) r4 at θ4, and the loop
  closure r1·e^{iθ1} + r4·e^{iθ4} = r2·e^{iθ2} + r3·e^{iθ3}.
* Two-link (RR) arm: analytic inverse kinematics for both elbow signs.
* Timing laws: linear s = τ and seed 004's quintic rest-to-rest s = 10τ³ − 15τ⁴ + 6τ⁵.
* Grashof: a brute-force classification by which links can rotate fully relative to which (sampled
  loop-closure feasibility), not the (p + q) − (s + l) rule.
"""

from __future__ import annotations

import math
import tomllib
from pathlib import Path

import numpy as np

BUILTIN = Path(__file__).resolve().parent.parent / "explorer" / "mechanism" / "builtin"


def builtin_dict(name: str) -> dict:
    """The parsed TOML table of built-in mechanism ``name`` (to derive variants with other guesses)."""
    return tomllib.loads((BUILTIN / f"{name}.toml").read_text(encoding="utf-8"))


def central_difference(f, t, h=1e-5):
    """(f(t + h) − f(t − h)) / 2h for an array-valued f of an array t (first axis = t)."""
    t = np.asarray(t, dtype=np.float64)
    return (f(t + h) - f(t - h)) / (2.0 * h)


def wrap(a):
    """Angles wrapped to (−π, π]."""
    return np.angle(np.exp(1j * np.asarray(a)))


# -- timing laws -------------------------------------------------------------------------------------
def timing(law: str, T: float, t):
    """(s, ds/dt, d²s/dt²) of the timing law over duration T at times t (seed 004's quintic)."""
    tau = np.asarray(t, dtype=np.float64) / T
    if law == "linear":
        return tau, np.full_like(tau, 1.0 / T), np.zeros_like(tau)
    assert law == "quintic"
    s = 10 * tau ** 3 - 15 * tau ** 4 + 6 * tau ** 5
    ds = (30 * tau ** 2 - 60 * tau ** 3 + 30 * tau ** 4) / T
    dds = (60 * tau - 180 * tau ** 2 + 120 * tau ** 3) / T ** 2
    return s, ds, dds


def quintic_from_seed(T: float, q0: float, q1: float):
    """Seed 004's quintic q(t) = a t⁵ + b t⁴ + c t³ + d t² + e t + f from its 6×6 boundary system
    (position q0, q1; zero velocity and acceleration at t = 0 and T), returned as a callable."""
    M = np.array([[0, 0, 0, 0, 0, 1],
                  [T ** 5, T ** 4, T ** 3, T ** 2, T, 1],
                  [0, 0, 0, 0, 1, 0],
                  [5 * T ** 4, 4 * T ** 3, 3 * T ** 2, 2 * T, 1, 0],
                  [0, 0, 0, 2, 0, 0],
                  [20 * T ** 3, 12 * T ** 2, 6 * T, 2, 0, 0]], dtype=np.float64)
    coef = np.linalg.solve(M, np.array([q0, q1, 0, 0, 0, 0], dtype=np.float64))
    return lambda t: np.polyval(coef, np.asarray(t, dtype=np.float64))


# -- four-bar: Freudenstein half-angle closed form (seed 004) ----------------------------------------
def freudenstein(theta2, r1, theta1, r2, r3, r4, sigma):
    """(θ3, θ4) of the four-bar at input angles θ2 for assembly mode σ = ±1; NaN where it cannot close.

    A cos θ4 + B sin θ4 + C = 0 with t = tan(θ4/2) gives θ4 = 2·atan2(−B + σ√(A² + B² − C²), C − A),
    except where that is 0/0 (C = A: the quadratic in t turns linear): there θ4 = 2·atan(−(A + C)/2B).
    """
    theta2 = np.asarray(theta2, dtype=np.float64)
    A = 2 * r1 * r4 * np.cos(theta1) - 2 * r2 * r4 * np.cos(theta2)
    B = 2 * r1 * r4 * np.sin(theta1) - 2 * r2 * r4 * np.sin(theta2)
    C = r1 ** 2 + r2 ** 2 + r4 ** 2 - r3 ** 2 - 2 * r1 * r2 * (np.cos(theta1) * np.cos(theta2)
                                                               + np.sin(theta1) * np.sin(theta2))
    disc = B ** 2 - C ** 2 + A ** 2
    with np.errstate(invalid="ignore"):
        num = -B + sigma * np.sqrt(disc)
        theta4 = 2 * np.arctan2(num, C - A)
    # C = A: the quadratic in t = tan(θ4/2) turns linear, 2B t + (A + C) = 0; its other root is t = ∞
    # (θ4 = π, which the other mode's formula gives). The mode whose formula is then 0/0 has the finite
    # root (atan2(0, 0) would say θ4 = 0).
    scale = np.abs(A) + np.abs(B) + np.abs(C)
    degenerate = (np.abs(C - A) <= 1e-12 * scale) & (np.abs(num) <= 1e-12 * scale)
    theta4 = np.where(degenerate, 2 * np.arctan2(-(A + C), 2 * B), theta4)
    theta4 = np.where(disc >= 0, theta4, np.nan)
    theta3 = np.arctan2(r1 * np.sin(theta1) + r4 * np.sin(theta4) - r2 * np.sin(theta2),
                        r1 * np.cos(theta1) + r4 * np.cos(theta4) - r2 * np.cos(theta2))
    return theta3, theta4


def fold_margin(theta2, crank, coupler, rocker, ground):
    """(A² + B² − C²) / (A² + B²) of Freudenstein's equation at each input angle, in [0, 1] where the loop
    closes: 0 at a fold (the two assembly modes meet). Within about 1e-6 of it double precision fixes
    the joint only to about sqrt(1e-16) of the lengths, whatever the method (the closed form too)."""
    gx, gy = ground
    r1, theta1 = math.hypot(gx, gy), math.atan2(gy, gx)
    theta2 = np.asarray(theta2, dtype=np.float64)
    A = 2 * r1 * rocker * np.cos(theta1) - 2 * crank * rocker * np.cos(theta2)
    B = 2 * r1 * rocker * np.sin(theta1) - 2 * crank * rocker * np.sin(theta2)
    C = r1 ** 2 + crank ** 2 + rocker ** 2 - coupler ** 2 - 2 * r1 * crank * np.cos(theta1 - theta2)
    return (A ** 2 + B ** 2 - C ** 2) / (A ** 2 + B ** 2)


def coupler_point(A, B, ap, bp, side):
    """Point P of the rigid coupler triangle A-B-P (|AP| = ap, |BP| = bp) on ``side`` (+1: left of A→B)."""
    g = B - A
    ab = np.hypot(g[..., 0], g[..., 1])
    alpha = np.arccos((ap ** 2 + ab ** 2 - bp ** 2) / (2 * ap * ab))  # interior angle at A
    phi = np.arctan2(g[..., 1], g[..., 0]) + side * alpha
    return A + ap * np.stack([np.cos(phi), np.sin(phi)], axis=-1)


def fourbar_closed_form(theta2, crank, coupler, rocker, ground, sigma, point=None):
    """Positions (dict vertex -> (S, 2)) of A (crank tip), B (coupler–rocker joint) and, with
    point = (ap, bp, side), the coupler point P; crank centre O at the origin, rocker pivot ``ground``."""
    gx, gy = ground
    r1, theta1 = math.hypot(gx, gy), math.atan2(gy, gx)
    theta2 = np.asarray(theta2, dtype=np.float64)
    theta3, theta4 = freudenstein(theta2, r1, theta1, crank, coupler, rocker, sigma)
    A = crank * np.stack([np.cos(theta2), np.sin(theta2)], axis=-1)
    B = A + coupler * np.stack([np.cos(theta3), np.sin(theta3)], axis=-1)
    # the same joint reached round the other side of the loop: O → B0 → B (a self-check of the formula)
    B_other = np.array([gx, gy]) + rocker * np.stack([np.cos(theta4), np.sin(theta4)], axis=-1)
    ok = np.isfinite(theta4)
    size = max(crank, coupler, rocker, r1)
    near_fold = fold_margin(theta2, crank, coupler, rocker, ground) < 1e-6  # sqrt-conditioned there
    atol = np.where(near_fold, 1e-6 * size, 1e-9 * size)[..., None]
    assert (np.abs(B - B_other)[ok] <= np.broadcast_to(atol, B.shape)[ok]).all()
    out = {"A": A, "B": B}
    if point is not None:
        out["P"] = coupler_point(A, B, *point)
    return out


def fourbar_dict(crank, coupler, rocker, ground, sigma, point=None, name="fb", assembles=True):
    """A mechanism table (the TOML shape) of a four-bar whose guess picks assembly mode σ at θ = 0
    (the guess is the closed form at θ = 0, rounded to 0.01: a rough guess on the right side).

    assembles=False allows a four-bar that cannot close at θ = 0 (its guess is then arbitrary).
    """
    ref = fourbar_closed_form(np.array([0.0]), crank, coupler, rocker, ground, sigma, point)
    if not np.isfinite(ref["B"]).all():
        assert not assembles, "this four-bar cannot assemble at θ = 0"
        ref = {"B": np.array([[ground[0], ground[1] + rocker]]), "P": np.array([[0.0, coupler]])}
    guess = {"B": [round(float(c), 2) for c in ref["B"][0]]}
    links = [{"name": "coupler", "a": "A", "b": "B", "length": float(coupler)},
             {"name": "rocker", "a": "B0", "b": "B", "length": float(rocker)}]
    if point is not None:
        guess["P"] = [round(float(c), 2) for c in ref["P"][0]]
        links += [{"name": "A-P", "a": "A", "b": "P", "length": float(point[0])},
                  {"name": "B-P", "a": "B", "b": "P", "length": float(point[1])}]
    return {"name": name, "foot": "P" if point is not None else "B",
            "crank": {"center": [0.0, 0.0], "radius": float(crank), "tip": "A"},
            "fixed": {"B0": [float(ground[0]), float(ground[1])]}, "guess": guess, "links": links}


def fourbar_limit_angles(crank, coupler, rocker, ground):
    """Crank angles in [0, 2π) where the loop cannot close any further.

    The crank tip A, the crank centre O and the rocker pivot B0 form a triangle; the dyad at B closes
    iff |coupler − rocker| ≤ |A − B0| ≤ coupler + rocker, with |A − B0|² = r² + g² − 2rg·cos(θ − θ1).
    The limits are where |A − B0| equals one of the bounds: θ = θ1 ± arccos((r² + g² − d²) / 2rg).
    """
    gx, gy = ground
    g, theta1 = math.hypot(gx, gy), math.atan2(gy, gx)
    out = []
    for d in (coupler + rocker, abs(coupler - rocker)):
        c = (crank ** 2 + g ** 2 - d ** 2) / (2 * crank * g)
        if -1.0 <= c <= 1.0:
            a = math.acos(c)
            out += [(theta1 + a) % (2 * math.pi), (theta1 - a) % (2 * math.pi)]
    return sorted(out)


# -- Grashof by brute force --------------------------------------------------------------------------
def _turns_fully(x, y, u, w, n=7201):
    """Can the angle between adjacent links x and y of a closed four-bar loop take every value?

    Links x and y meet at a joint; the diagonal opposite it, √(x² + y² − 2xy·cos φ), must be bridged
    by the other two links u, w: |u − w| ≤ diagonal ≤ u + w, checked at every sampled φ (0 and π
    included, where the diagonal is extreme).
    """
    phi = np.linspace(0.0, 2.0 * np.pi, n)
    diag = np.sqrt(x * x + y * y - 2 * x * y * np.cos(phi))
    return bool(np.all((diag <= u + w) & (diag >= abs(u - w))))


def grashof_brute(crank, coupler, rocker, ground):
    """Class of the loop O-A-B-B0 (crank, coupler, rocker, ground) from which relative rotations are full.

    crank-rocker: the crank turns fully against the ground, the rocker does not; double-crank: both
    do; rocker-crank: only the rocker does; double-rocker: neither, but the coupler turns fully
    against its neighbours; triple-rocker: no link turns fully against any other.
    """
    crank_full = _turns_fully(crank, ground, coupler, rocker)  # angle at O between ground and crank
    rocker_full = _turns_fully(rocker, ground, crank, coupler)  # angle at B0
    coupler_full = _turns_fully(crank, coupler, rocker, ground)  # angle at A between crank and coupler
    if crank_full and rocker_full:
        return "double-crank"
    if crank_full:
        return "crank-rocker"
    if rocker_full:
        return "rocker-crank"
    if coupler_full:
        return "double-rocker"
    return "triple-rocker"


def grashof_margin(*lengths):
    """(p + q) − (s + l) of four lengths."""
    s, p, q, l = sorted(float(x) for x in lengths)
    return (p + q) - (s + l)


# -- two-link arm ------------------------------------------------------------------------------------
def two_link_ik(x, y, l1, l2, elbow):
    """Joint angles (θ1, θ2) putting the tip of a two-link arm (base at the origin) at (x, y).

    cos θ2 = (x² + y² − l1² − l2²) / (2 l1 l2), θ2 = elbow·arccos(...) (elbow = ±1),
    θ1 = atan2(y, x) − atan2(l2 sin θ2, l1 + l2 cos θ2). NaN out of reach.
    """
    x = np.asarray(x, dtype=np.float64)
    y = np.asarray(y, dtype=np.float64)
    c2 = (x ** 2 + y ** 2 - l1 ** 2 - l2 ** 2) / (2 * l1 * l2)
    reach = (c2 >= -1.0 - 1e-15) & (c2 <= 1.0 + 1e-15)
    with np.errstate(invalid="ignore"):
        theta2 = elbow * np.arccos(np.clip(c2, -1.0, 1.0))
    theta1 = np.arctan2(y, x) - np.arctan2(l2 * np.sin(theta2), l1 + l2 * np.cos(theta2))
    return np.where(reach, theta1, np.nan), np.where(reach, theta2, np.nan)


def two_link_elbow(x, y, l1, l2, elbow):
    """Elbow position (…, 2) from the inverse kinematics."""
    q1, _ = two_link_ik(x, y, l1, l2, elbow)
    return l1 * np.stack([np.cos(q1), np.sin(q1)], axis=-1)
