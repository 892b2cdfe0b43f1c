"""The forces effect (explorer/kernels/_forces.py) against references written plainly here: the held
model (``[operating] body = "held"``: the frame still, the legs hung from it, the load alone on the
contact foot; the moving body's references are in tests/test_forces_moving.py).

Every numeric check compares the code's motor torque, member forces or metrics with an independent
re-derivation in numpy: the walker's quasi-static virtual work (massless links), the power balance of
a massive Jansen leg (closed-form positions, finite differences), the textbook Newton–Euler matrix of
a four-bar, and the Newton–Euler equilibrium of every member of Klann's leg (accelerations from
finite differences of the solved positions, not the code's own).
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest

import explorer.mechanism as mechanism_pkg
from explorer import STATUS_NAMES, UserError, load_mechanism, simulate, simulate_batch
from explorer.gait import WALKER_METRICS
from explorer.testing import walker_metrics
from explorer.mechanism import Walker, builtin_mechanisms, mechanism_from_dict, parse_toml

BUILTIN = Path(mechanism_pkg.__file__).resolve().parent / "builtin"
WALKERS = ("fourbar", "hoeken", "jansen", "klann", "strider")


def builtin_dict(name: str) -> dict:
    """A built-in mechanism's TOML table, to be modified and rebuilt with mechanism_from_dict."""
    return parse_toml((BUILTIN / f"{name}.toml").read_text(), f"builtin:{name}")


def cross(a, b):
    """z component of a × b for (..., 2) arrays."""
    return a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]


def circle_meet(a, b, da, db, side):
    """The point at distance da from a and db from b, on the left (side +1) or right (−1) of a → b."""
    g = b - a
    d = np.hypot(g[..., 0], g[..., 1])[..., None]
    x = (da * da - db * db + d * d) / (2.0 * d)
    y = np.sqrt(da * da - x * x)
    u = g / d
    perp = np.stack([-u[..., 1], u[..., 0]], axis=-1)
    return a + x * u + side * y * perp


def side_of(a, b, p) -> float:
    """+1 if p is left of a → b, −1 if right."""
    return 1.0 if cross(np.asarray(b) - a, np.asarray(p) - a) >= 0.0 else -1.0


def d1(f, theta, h=1e-3):
    """First θ-derivative by the five-point central difference."""
    return (-f(theta + 2 * h) + 8 * f(theta + h) - 8 * f(theta - h) + f(theta - 2 * h)) / (12 * h)


def d2(f, theta, h=1e-3):
    """Second θ-derivative by the five-point central difference."""
    return (-f(theta + 2 * h) + 16 * f(theta + h) - 30 * f(theta) + 16 * f(theta - h) - f(theta - 2 * h)) / (12 * h * h)


# -- 1. massless walker: the motor torque is the walker's quasi-static torque --------------------------
LOAD, UNIT, G = 70.0, 0.01, 9.81


def massless_cycle(name: str, drag: float, steps: int = 360):
    """A built-in walker with no masses anywhere, carrying LOAD. Gravity is on (the load's weight is
    load·g, so with gravity 0 there would be no force at all); with every member massless it acts on
    the load alone."""
    mech = load_mechanism(name)
    assert mech.link_density is None and all(l.mass is None for l in mech.links) and mech.crank.mass is None
    assert all(b.mass == 0.0 for b in mech.bodies)
    walker = dataclasses.replace(mech.walker, drag=drag)
    cyc = simulate(mech, steps, tolerance=1e-12, velocities=True, forces=True, walker=walker,
                   operating={"unit": UNIT, "rpm": 45.0, "gravity": G, "load": LOAD, "body": "held"})
    assert cyc.ok, cyc.failure
    return mech, walker, cyc


@pytest.mark.parametrize("name", WALKERS)
def test_massless_peak_torque_is_the_walker_quasi_static_peak(name):
    """No masses: the only force is the load's weight W = load·g (and its drag) on the contact foot, so
    the motor torque is the walker metrics' quasi-static torque and its peak is peak_torque·W·r."""
    assert set(WALKERS) <= set(builtin_mechanisms())
    mech, walker, cyc = massless_cycle(name, drag=0.15)
    foot = cyc.path(mech.foot)[None]
    vel = cyc.velocity(mech.foot)[None]
    wm = walker_metrics(np.ascontiguousarray(foot), np.ascontiguousarray(vel), np.zeros(1, dtype=np.int64),
                        np.array([mech.crank.radius]), walker)
    peak = wm[0, WALKER_METRICS.index("peak_torque")]
    assert np.isfinite(peak) and peak > 0
    W = LOAD * G
    expected = peak * W * mech.crank.radius * UNIT
    np.testing.assert_allclose(cyc.force_metrics["motor_torque_peak"], expected, rtol=1e-9)
    np.testing.assert_allclose(np.max(np.abs(cyc.torque)), expected, rtol=1e-9)


def quasi_static_torque(path, vel, walker, W, unit):
    """τ_k = −F·p'_c(θ_k) by hand: leg j's foot is the sampled foot at k + φ_j (plain) or the mirror
    image of the foot at S/2 − φ_j − k, driven backwards (mirrored: y' negated); contact = lowest
    foot (ties to the lower leg); F = (u·drag·W, W), u = −sign(Σ x'_c) (phases on the sample grid)."""
    S = path.shape[0]
    k = np.arange(S)
    Y, VX, VY = [], [], []
    for phi, mir in zip(walker.phases, walker.mirrored):
        shift = phi * S / (2 * np.pi)
        assert abs(shift - round(shift)) < 1e-9  # on the grid: no interpolation in this reference
        shift = int(round(shift))
        if mir:
            idx = (S // 2 - shift - k) % S
            Y.append(path[idx, 1]), VX.append(vel[idx, 0]), VY.append(-vel[idx, 1])
        else:
            idx = (k + shift) % S
            Y.append(path[idx, 1]), VX.append(vel[idx, 0]), VY.append(vel[idx, 1])
    Y, VX, VY = map(np.array, (Y, VX, VY))
    c = np.argmin(Y, axis=0)  # the first minimum: ties to the lower leg
    vx, vy = VX[c, k], VY[c, k]
    u = -np.sign(vx.sum())
    return -(u * walker.drag * W * vx + W * vy) * unit


@pytest.mark.parametrize("name", ["jansen", "fourbar"])
def test_massless_torque_series_is_minus_load_dot_contact_foot_velocity(name):
    mech, walker, cyc = massless_cycle(name, drag=0.3)
    if name == "jansen":
        assert walker.legs == 4 and walker.mirrored == (False, True, False, True)
    ref = quasi_static_torque(cyc.path(mech.foot), cyc.velocity(mech.foot), walker, LOAD * G, UNIT)
    scale = np.max(np.abs(ref))
    assert scale > 1.0  # N·m: a real load
    np.testing.assert_allclose(cyc.torque, ref, rtol=0, atol=1e-9 * scale)


# -- 2. power balance of a massive Jansen leg ------------------------------------------------------------
JANSEN_FIXED = np.array([-38.0, -7.8])
JANSEN_R = 15.0
#: (vertex, parent a, parent b, |a v|, |b v|) in plan order
JANSEN_DYADS = [("3", "1", "2", 50.0, 41.5), ("4", "3", "2", 55.8, 40.1), ("6", "2", "1", 39.3, 61.9),
                ("5", "4", "6", 39.4, 36.7), ("7", "5", "6", 65.7, 49.0)]
JANSEN_GUESS = {"3": (-50.0, 50.0), "4": (-100.0, 0.0), "5": (-100.0, -50.0), "6": (-50.0, -50.0),
                "7": (-50.0, -100.0)}


def jansen_sides() -> dict:
    """Each dyad's side at θ = 0, taken from jansen.toml's guess, as assembly does."""
    P = {"1": np.array([JANSEN_R, 0.0]), "2": JANSEN_FIXED}
    sides = {}
    for v, a, b, da, db in JANSEN_DYADS:
        sides[v] = side_of(P[a], P[b], JANSEN_GUESS[v])
        P[v] = circle_meet(P[a], P[b], da, db, sides[v])
    return sides


def jansen_positions(theta, sides) -> dict:
    """{vertex: (S, 2)} the closed form at crank angles theta (S,), model units."""
    theta = np.asarray(theta, dtype=np.float64)
    P = {"1": JANSEN_R * np.stack([np.cos(theta), np.sin(theta)], axis=-1),
         "2": np.broadcast_to(JANSEN_FIXED, theta.shape + (2,))}
    for v, a, b, da, db in JANSEN_DYADS:
        P[v] = circle_meet(P[a], P[b], da, db, sides[v])
    return P


JANSEN_LINK_MASS = [0.11, 0.23, 0.17, 0.29, 0.13, 0.31, 0.19, 0.07, 0.41, 0.37]  # kg, file order
JANSEN_CRANK_MASS = 0.25


def jansen_with_masses() -> dict:
    d = builtin_dict("jansen")
    for lk, m in zip(d["links"], JANSEN_LINK_MASS):
        lk["mass"] = m
    d["crank"]["mass"] = JANSEN_CRANK_MASS
    return d


@pytest.mark.parametrize("gravity", [0.0, 9.81])
def test_power_balance_of_a_massive_jansen_leg(gravity):
    """τω = d(kinetic energy)/dt + rate of gain of potential energy, at every sample: with ω constant,
    Σ_links (m a_G·v_G + I_G ω_l α_l) + Σ m g v_G,y + the crank's m_c g v_Gc,y (its kinetic energy is
    constant). Positions by closed form, derivatives by five-point central differences in θ."""
    mech = mechanism_from_dict(jansen_with_masses())
    assert len(mech.links) == len(JANSEN_LINK_MASS)
    S, unit = 360, 0.01
    theta = 2 * np.pi * np.arange(S) / S
    sides = jansen_sides()
    P0 = jansen_positions(theta, sides)
    links = [(lk.a, lk.b, lk.length, m) for lk, m in zip(mech.links, JANSEN_LINK_MASS)]
    for a, b, L, _ in links:  # the closed form is the mechanism: every link keeps its length
        np.testing.assert_allclose(np.linalg.norm(P0[b] - P0[a], axis=1), L, rtol=1e-12)
    cfg = {}  # per link: centre velocity / acceleration and angular rate / acceleration per radian of crank
    for a, b, L, m in links:
        G = lambda t, a=a, b=b: 0.5 * (jansen_positions(t, sides)[a] + jansen_positions(t, sides)[b])  # noqa: E731
        E = lambda t, a=a, b=b: jansen_positions(t, sides)[b] - jansen_positions(t, sides)[a]  # noqa: E731
        e, de, dde = E(theta), d1(E, theta), d2(E, theta)
        cfg[(a, b)] = (d1(G, theta), d2(G, theta), cross(e, de) / L ** 2, cross(e, dde) / L ** 2)
    vGc = 0.5 * JANSEN_R * np.stack([-np.sin(theta), np.cos(theta)], axis=-1)  # crank centre of mass, per radian
    for rpm in (10.0, 40.0, 120.0):
        w = rpm * 2 * np.pi / 60
        cyc = simulate(mech, S, tolerance=1e-12, forces=True, walker=Walker(legs=1),
                       operating={"unit": unit, "rpm": rpm, "gravity": gravity, "load": 0.0, "body": "held"})
        assert cyc.ok, cyc.failure
        power = np.zeros(S)
        for a, b, L, m in links:
            vG, aG, om, al = cfg[(a, b)]
            vG, aG, om, al = vG * unit * w, aG * unit * w * w, om * w, al * w * w
            I = m * (L * unit) ** 2 / 12.0
            power += m * np.sum(aG * vG, axis=1) + I * om * al + m * gravity * vG[:, 1]
        power += JANSEN_CRANK_MASS * gravity * vGc[:, 1] * unit * w
        scale = np.max(np.abs(power))
        assert scale > 0
        np.testing.assert_allclose(cyc.torque * w, power, rtol=0, atol=1e-6 * scale,
                                   err_msg=f"rpm {rpm}, gravity {gravity}")


# -- 3. a four-bar by the Newton–Euler matrix method ----------------------------------------------------
FB = dict(r=10.0, B0=np.array([30.0, 0.0]), AB=30.0, rocker=25.0, m2=0.2, m3=0.5, m4=0.3,
          G3=np.array([12.0, 5.0]), I3=0.004, unit=0.01, rpm=120.0, g=9.81)


def fourbar_dict() -> dict:
    return {
        "name": "norton", "foot": "B",
        "crank": {"center": [0.0, 0.0], "radius": FB["r"], "tip": "A", "mass": FB["m2"]},
        "fixed": {"B0": FB["B0"].tolist()},
        "guess": {"B": [25.0, -24.0]},
        "links": [{"name": "rocker", "a": "B0", "b": "B", "length": FB["rocker"], "mass": FB["m4"]}],
        "bodies": [{"name": "coupler", "joints": {"A": [0.0, 0.0], "B": [FB["AB"], 0.0]}, "mass": FB["m3"],
                    "centroid": FB["G3"].tolist(), "inertia": FB["I3"]}],
    }


def norton_reference(theta):
    """T12 (S,) and F12, F32, F43, F14 (S, 2) of the four-bar of :func:`fourbar_dict` at crank angles
    theta, in SI units, by the Newton–Euler matrix method. The method (not any numbers) is that of
    Norton, Design of Machinery, §11.5: three free bodies (crank 2, coupler 3, rocker 4), unknowns F12,
    F32, F43, F14 (x, y) and T12, Fij the force of body i on body j; for each body ΣF = m a_G and
    ΣM_G = I_G α (weights included), a 9×9 linear system per crank angle. Kinematics by closed form
    (circle–circle) and five-point central differences in θ."""
    unit, g = FB["unit"], FB["g"]
    w = FB["rpm"] * 2 * np.pi / 60
    B0 = FB["B0"]
    side = side_of(np.array([FB["r"], 0.0]), B0, (25.0, -24.0))  # the guess's side at θ = 0

    def A(t):
        return FB["r"] * np.stack([np.cos(t), np.sin(t)], axis=-1)

    def B(t):
        return circle_meet(A(t), np.broadcast_to(B0, np.shape(t) + (2,)), FB["AB"], FB["rocker"], side)

    def G3(t):  # the coupler's centroid: its frame has A at the origin and B on the x axis
        e = (B(t) - A(t)) / FB["AB"]
        n = np.stack([-e[..., 1], e[..., 0]], axis=-1)
        return A(t) + FB["G3"][0] * e + FB["G3"][1] * n

    def G4(t):
        return 0.5 * (B(t) + B0)

    def e3(t):
        return B(t) - A(t)

    def e4(t):
        return B(t) - B0

    m2, m3, m4 = FB["m2"], FB["m3"], FB["m4"]
    I3 = FB["I3"]
    I4 = m4 * (FB["rocker"] * unit) ** 2 / 12
    S = len(theta)
    # SI kinematics (constant ω: the crank's α2 = 0); angular accelerations from the direction vectors
    pA, pB, pB0 = A(theta) * unit, B(theta) * unit, B0 * unit
    pG2 = 0.5 * pA
    pG3, pG4 = G3(theta) * unit, G4(theta) * unit
    aG2 = d2(A, theta) * 0.5 * unit * w * w
    aG3 = d2(G3, theta) * unit * w * w
    aG4 = d2(G4, theta) * unit * w * w
    al3 = cross(e3(theta), d2(e3, theta)) / FB["AB"] ** 2 * w * w
    al4 = cross(e4(theta), d2(e4, theta)) / FB["rocker"] ** 2 * w * w

    R12, R32 = -pG2, pA - pG2  # crank: O2 (the origin) and A from G2
    R23, R43 = pA - pG3, pB - pG3  # coupler: A and B from G3
    R14, R34 = pB0 - pG4, pB - pG4  # rocker: B0 and B from G4
    M = np.zeros((S, 9, 9))
    rhs = np.zeros((S, 9))
    # unknowns: F12x F12y F32x F32y F43x F43y F14x F14y T12
    # body 2: F12 + F32 + m2 g⃗ = m2 aG2; R12×F12 + R32×F32 + T12 = I2 α2 = 0
    M[:, 0, 0] = M[:, 0, 2] = 1
    M[:, 1, 1] = M[:, 1, 3] = 1
    M[:, 2, 0], M[:, 2, 1] = -R12[:, 1], R12[:, 0]
    M[:, 2, 2], M[:, 2, 3] = -R32[:, 1], R32[:, 0]
    M[:, 2, 8] = 1
    rhs[:, 0], rhs[:, 1] = m2 * aG2[:, 0], m2 * aG2[:, 1] + m2 * g
    # body 3: −F32 + F43 + m3 g⃗ = m3 aG3; R23×(−F32) + R43×F43 = I3 α3
    M[:, 3, 2], M[:, 3, 4] = -1, 1
    M[:, 4, 3], M[:, 4, 5] = -1, 1
    M[:, 5, 2], M[:, 5, 3] = R23[:, 1], -R23[:, 0]
    M[:, 5, 4], M[:, 5, 5] = -R43[:, 1], R43[:, 0]
    rhs[:, 3], rhs[:, 4], rhs[:, 5] = m3 * aG3[:, 0], m3 * aG3[:, 1] + m3 * g, I3 * al3
    # body 4: F14 − F43 + m4 g⃗ = m4 aG4; R14×F14 + R34×(−F43) = I4 α4
    M[:, 6, 6], M[:, 6, 4] = 1, -1
    M[:, 7, 7], M[:, 7, 5] = 1, -1
    M[:, 8, 6], M[:, 8, 7] = -R14[:, 1], R14[:, 0]
    M[:, 8, 4], M[:, 8, 5] = R34[:, 1], -R34[:, 0]
    rhs[:, 6], rhs[:, 7], rhs[:, 8] = m4 * aG4[:, 0], m4 * aG4[:, 1] + m4 * g, I4 * al4
    x = np.linalg.solve(M, rhs[..., None])[..., 0]
    return dict(T12=x[:, 8], F12=x[:, 0:2], F32=x[:, 2:4], F43=x[:, 4:6], F14=x[:, 6:8], B=B(theta))


def close(got, ref, what, rel=1e-6):
    scale = np.max(np.abs(ref))
    assert scale > 1e-3, what
    np.testing.assert_allclose(got, ref, rtol=0, atol=rel * scale, err_msg=what)


def norton_cycle(steps=360):
    mech = mechanism_from_dict(fourbar_dict())
    return simulate(mech, steps, tolerance=1e-12, forces=True, walker=Walker(legs=1),
                    operating={"unit": FB["unit"], "rpm": FB["rpm"], "gravity": FB["g"], "load": 0.0, "body": "held"})


def test_fourbar_against_the_newton_euler_matrix_method():
    """Motor torque and member forces of a crank–coupler body–rocker four-bar with masses against
    :func:`norton_reference` (Norton's matrix method, written here)."""
    S = 360
    cyc = norton_cycle(S)
    assert cyc.ok, cyc.failure
    keys = set(cyc.member_forces)
    for k in [("frame", "B0"), ("rocker", "B"), ("rocker", "B0"), ("coupler", "A"), ("coupler", "B"), ("crank", "A")]:
        assert k in keys, sorted(keys)
    ref = norton_reference(2 * np.pi * np.arange(S) / S)
    np.testing.assert_allclose(cyc.path("B"), ref["B"], atol=1e-9)
    close(cyc.torque, ref["T12"], "T12 (motor torque)")
    close(cyc.member_forces[("frame", "B0")], ref["F14"], "F14 (frame on the rocker at B0)")
    close(cyc.member_forces[("rocker", "B")], ref["F43"], "F43 (rocker on the coupler at B)")
    close(cyc.member_forces[("coupler", "A")], ref["F32"], "F32 (coupler on the crank at A)")
    # the crank puts −F32 on pin A (the pin is in equilibrium between the crank and the coupler)
    close(-cyc.member_forces[("crank", "A")], ref["F32"], "crank on pin A = −F32")


def _poison_heap(S, K):
    """Fill, then free, heap blocks the sizes of the forces kernel's scratch arrays (per sample, three
    right-hand sides: torque, frame force, K incidence forces) with NaN, so that a kernel which reads
    scratch memory it never wrote shows it (instead of doing so only by chance)."""
    junk = [np.full(n, np.nan) for n in (S * 3, S * 3 * 2, S * 3 * K * 2, S * 3 * K * 2 + 16) for _ in range(4)]
    del junk


def test_no_load_reads_no_unwritten_memory():
    """With no load (weight 0) only the inertia-and-weight right-hand side is needed; the result must not
    depend on scratch memory left unwritten (0 × NaN is NaN): ok, finite, and Norton's torque, however
    often it is run."""
    S = 360
    ref = norton_reference(2 * np.pi * np.arange(S) / S)
    for trial in range(3):
        _poison_heap(S, 7)
        cyc = norton_cycle(S)
        assert cyc.ok, (trial, cyc.failure)
        assert all(np.all(np.isfinite(f)) for f in cyc.member_forces.values()), trial
        close(cyc.torque, ref["T12"], f"T12, trial {trial}")
        close(cyc.member_forces[("frame", "B0")], ref["F14"], f"F14, trial {trial}")


# -- 4. Klann: every member in equilibrium at every sample ----------------------------------------------
KLANN_BODIES = {"connecting_rod": (0.45, [6.0, 0.6], 0.0021), "leg": (0.8, [1.2, -1.4], 0.0065)}
KLANN_OP = {"unit": 0.02, "rpm": 75.0, "gravity": 9.81, "load": 6.0, "body": "held"}
KLANN_DENSITY = 1.7


def test_klann_every_member_and_pin_in_equilibrium():
    """Σ over a member's pins of the pins' forces on it (−member_forces) plus its weight = m a_G, and
    their moment about G = I_G α, for every link and body of Klann's leg at 3,600 samples; a_G and α
    by periodic central differences of the cycle's solved positions. And every pin is in equilibrium:
    the forces its members put on it sum to zero."""
    d = builtin_dict("klann")
    d["mass"] = {"link_density": KLANN_DENSITY}
    for b in d["bodies"]:
        b["mass"], b["centroid"], b["inertia"] = KLANN_BODIES[b["name"]]
    mech = mechanism_from_dict(d)
    S = 3600
    unit, g = KLANN_OP["unit"], KLANN_OP["gravity"]
    w = KLANN_OP["rpm"] * 2 * np.pi / 60
    cyc = simulate(mech, S, tolerance=1e-12, forces=True, walker=Walker(legs=1), operating=KLANN_OP)
    assert cyc.ok, cyc.failure
    mf = cyc.member_forces
    largest = max(np.max(np.abs(f)) for f in mf.values())
    assert largest > 1.0
    tol = 1e-5 * largest
    dt = 2 * np.pi / S

    def dd(x):  # periodic second difference in θ, per second² (constant ω)
        return (np.roll(x, -1, axis=0) - 2 * x + np.roll(x, 1, axis=0)) / dt ** 2 * w * w

    def members_of(name):
        return [v for (m, v) in mf if m == name]

    gvec = np.array([0.0, -g])
    checked = 0
    for lk in mech.links:
        pa, pb = cyc.path(lk.a), cyc.path(lk.b)
        m = KLANN_DENSITY * lk.length * unit
        I = m * (lk.length * unit) ** 2 / 12
        Gp = 0.5 * (pa + pb)
        phi = np.unwrap(np.arctan2(*(pb - pa).T[::-1]))
        assert sorted(members_of(lk.name)) == sorted([lk.a, lk.b])
        on = {v: -mf[(lk.name, v)] for v in (lk.a, lk.b)}
        F = on[lk.a] + on[lk.b] + m * gvec
        np.testing.assert_allclose(F, m * dd(Gp) * unit, rtol=0, atol=tol, err_msg=f"link {lk.name}: force balance")
        Mo = sum(cross((cyc.path(v) - Gp) * unit, f) for v, f in on.items())
        np.testing.assert_allclose(Mo, I * dd(phi), rtol=0, atol=tol * lk.length * unit,
                                   err_msg=f"link {lk.name}: moment balance")
        checked += 1
    for b in mech.bodies:
        mass, centroid, inertia = KLANN_BODIES[b.name]
        pts = {j: np.array(p) for j, p in zip(b.joints, b.points)}
        j0, j1 = b.joints[0], b.joints[1]
        body_dir = pts[j1] - pts[j0]
        world_dir = cyc.path(j1) - cyc.path(j0)
        rot = (world_dir[:, 0] + 1j * world_dir[:, 1]) / complex(*body_dir)
        assert np.allclose(np.abs(rot), 1.0, atol=1e-9)
        c = np.asarray(centroid) - pts[j0]
        Gc = (cyc.path(j0)[:, 0] + 1j * cyc.path(j0)[:, 1]) + rot * complex(*c)
        Gp = np.stack([Gc.real, Gc.imag], axis=1)
        for j in b.joints:  # the body is rigid in the cycle: its joints where its frame puts them
            pj = (cyc.path(j0)[:, 0] + 1j * cyc.path(j0)[:, 1]) + rot * complex(*(pts[j] - pts[j0]))
            np.testing.assert_allclose(cyc.path(j), np.stack([pj.real, pj.imag], axis=1), atol=1e-9)
        phi = np.unwrap(np.angle(rot))
        assert sorted(members_of(b.name)) == sorted(b.joints)
        on = {v: -mf[(b.name, v)] for v in b.joints}
        F = sum(on.values()) + mass * gvec
        np.testing.assert_allclose(F, mass * dd(Gp) * unit, rtol=0, atol=tol, err_msg=f"body {b.name}: force balance")
        Mo = sum(cross((cyc.path(v) - Gp) * unit, f) for v, f in on.items())
        span = max(np.hypot(*(pts[a] - pts[c])) for a in pts for c in pts) * unit
        np.testing.assert_allclose(Mo, inertia * dd(phi), rtol=0, atol=tol * span,
                                   err_msg=f"body {b.name}: moment balance")
        checked += 1
    assert checked == 4
    # every pin: the forces of its members (links, bodies, crank, frame, ground) sum to zero
    for v in mech.vertices:
        total = sum(f for (m, u), f in mf.items() if u == v)
        np.testing.assert_allclose(total, 0.0, atol=1e-9 * largest, err_msg=f"pin {v}")
    # the ground carries the load on the foot (one leg: always in contact)
    np.testing.assert_allclose(mf[("ground", mech.foot)], np.tile([0.0, KLANN_OP["load"] * g], (S, 1)),
                               atol=1e-9 * largest)


# -- 5. honest failures in a batch ----------------------------------------------------------------------
def test_batch_with_forces_fails_honestly():
    d = builtin_dict("jansen")
    d["mass"] = {"link_density": 1.2}
    d["crank"]["mass"] = 0.3
    mech = mechanism_from_dict(d)
    rng = np.random.default_rng(20240607)
    N, S = 300, 120
    lengths = mech.lengths[None, :] * rng.uniform(0.95, 1.05, (N, len(mech.links)))
    crank = mech.crank.radius * rng.uniform(0.95, 1.05, N)
    lengths[0, 0] = np.nan  # invalid
    lengths[1, 0] = 5.0  # link 1–3 far too short to reach vertex 2's circle: cannot be assembled
    b = simulate_batch(mech, lengths, crank, S, forces=True, force_joints=["7", "2", "1"],
                       operating={"unit": 0.01, "rpm": 50.0, "gravity": 9.81, "load": 40.0})
    st = b.status.astype(int)
    assert set(st.tolist()) <= set(STATUS_NAMES)
    ok = st == 0
    assert ok.sum() >= N // 2 and (~ok).sum() >= 2
    assert st[0] == 4 and st[1] != 0
    assert b.torque.shape == (N, S)
    assert np.all(np.isfinite(b.torque[ok]))
    assert np.all(np.isnan(b.torque[~ok]))
    for j, f in b.forces.items():
        assert f.shape == (N, S, 2)
        assert np.all(np.isfinite(f[ok])), j
        assert np.all(np.isnan(f[~ok])), j
    assert "cost_of_transport" in b.force_metrics and "motor_torque_peak" in b.force_metrics
    for name, col in b.force_metrics.items():
        assert col.shape == (N,)
        assert np.all(np.isfinite(col[ok])), name
        assert np.all(np.isnan(col[~ok])), name
    # the metrics are the definitions applied to the torque series
    t = b.torque[ok]
    np.testing.assert_allclose(b.force_metrics["motor_torque_peak"][ok], np.abs(t).max(axis=1), rtol=1e-12)
    np.testing.assert_allclose(b.force_metrics["motor_torque_rms"][ok], np.sqrt((t ** 2).mean(axis=1)), rtol=1e-12)
    np.testing.assert_allclose(b.force_metrics["energy_per_turn"][ok],
                               np.clip(t, 0, None).sum(axis=1) * 2 * np.pi / S, rtol=1e-12)
    # and a row the batch calls ok is the variant simulated alone (same torque)
    i = int(np.flatnonzero(ok)[0])
    di = builtin_dict("jansen")
    di["mass"], di["crank"]["mass"], di["crank"]["radius"] = {"link_density": 1.2}, 0.3, float(crank[i])
    for lk, L in zip(di["links"], lengths[i]):
        lk["length"] = float(L)
    one = simulate(mechanism_from_dict(di), S, forces=True,
                   operating={"unit": 0.01, "rpm": 50.0, "gravity": 9.81, "load": 40.0})
    assert one.ok
    np.testing.assert_allclose(b.torque[i], one.torque, rtol=1e-9, atol=1e-9 * np.abs(one.torque).max())


def test_forces_read_the_sweeps_own_rates():
    """The forces effect runs in the sweep's kernel and reads its rates: with forces on, the positions,
    velocities and accelerations are the plain sweep's bit for bit; and the code generated per topology
    gives every force output of the table-driven kernel bit for bit."""

    mech = load_mechanism(Path(__file__).parents[1] / "studies" / "mechanisms" / "jansen-plywood.toml")
    rng = np.random.default_rng(38)
    N, S = 40, 90
    lengths = mech.lengths[None, :] * rng.uniform(0.97, 1.03, (N, len(mech.links)))
    crank = mech.crank.radius * rng.uniform(0.97, 1.03, N)
    kw = dict(vertices="all", accelerations=True)
    plain = simulate_batch(mech, lengths, crank, S, **kw)
    walker = Walker(legs=4, mirrored=(False, True, False, True), drag=0.1)
    for body in ("moving", "held"):
        fkw = dict(kw, forces=True, operating={"body": body}, walker=walker, force_joints=["2", "7"])
        forced = simulate_batch(mech, lengths, crank, S, kernel="generated", **fkw)
        assert (forced.status == plain.status).all() and (plain.status == 0).sum() >= N // 2
        for group in ("paths", "velocities", "accelerations"):
            for v in mech.vertices:
                np.testing.assert_array_equal(getattr(forced, group)[v], getattr(plain, group)[v], err_msg=group)
        table = simulate_batch(mech, lengths, crank, S, kernel="general", **fkw)  # the table-driven kernel
        np.testing.assert_array_equal(table.torque, forced.torque)
        for j in ("2", "7"):
            np.testing.assert_array_equal(table.forces[j], forced.forces[j])
        for k, col in forced.force_metrics.items():
            np.testing.assert_array_equal(table.force_metrics[k], col, err_msg=k)


# -- 6. bad input ---------------------------------------------------------------------------------------
def _raises(fn, *needles):
    with pytest.raises(UserError) as err:
        fn()
    msg = str(err.value)
    assert "\n" not in msg, msg
    for n in needles:
        assert n in msg, (n, msg)


def test_bad_mass_inputs_name_key_and_value():
    d = builtin_dict("fourbar")
    d["links"][1]["mass"] = -0.5
    _raises(lambda: mechanism_from_dict(d), "links[1].mass", "-0.5")

    d = fourbar_dict()
    d["bodies"][0]["inertia"] = float("nan")
    _raises(lambda: mechanism_from_dict(d), "bodies[0].inertia", "nan")
    d = fourbar_dict()
    d["bodies"][0]["inertia"] = float("inf")
    _raises(lambda: mechanism_from_dict(d), "bodies[0].inertia", "inf")

    d = fourbar_dict()
    d["bodies"][0]["centroid"] = [500.0, -800.0]
    _raises(lambda: mechanism_from_dict(d), "bodies[0].centroid", "500", "-800")

    d = builtin_dict("jansen")
    d["mass"] = {"link_density": -2.0}
    _raises(lambda: mechanism_from_dict(d), "mass.link_density", "-2.0")
    d = builtin_dict("jansen")
    d["crank"]["mass"] = float("-inf")
    _raises(lambda: mechanism_from_dict(d), "crank.mass", "-inf")


def test_bad_operating_inputs_name_key_and_value():
    mech = load_mechanism("fourbar")
    run = lambda **op: (lambda: simulate(mech, 36, forces=True, operating=op))  # noqa: E731
    _raises(run(unit=0.01, rpm=0), "operating.rpm", "0")
    _raises(run(unit=0.01, rpm=float("nan")), "operating.rpm", "nan")
    _raises(run(unit=0.01, rpm=60, gravity=-9.81), "operating.gravity", "-9.81")
    _raises(run(rpm=60), "operating.unit")
    _raises(run(unit=0.01), "operating.rpm")
    _raises(run(unit=0.01, rpm=60, load=-1.0), "operating.load", "-1.0")
    _raises(lambda: simulate_batch(mech, mech.lengths[None], None, 36, forces=True, operating={"unit": 0.01}),
            "operating.rpm")
    # in a mechanism's own [operating] table
    d = builtin_dict("fourbar")
    d["operating"] = {"unit": 0.01, "rpm": 0.0}
    _raises(lambda: mechanism_from_dict(d), "operating.rpm", "0.0")
    d["operating"] = {"unit": 0.01, "rpm": 60.0, "gravity": -1.5}
    _raises(lambda: mechanism_from_dict(d), "operating.gravity", "-1.5")


def test_load_on_a_path_driven_mechanism_is_refused():
    d = builtin_dict("arm")
    assert "driver" in d and "crank" not in d
    d["operating"] = {"unit": 0.1, "rpm": 30.0, "load": 12.5}
    _raises(lambda: mechanism_from_dict(d), "operating.load", "12.5")
    d["operating"] = {"unit": 0.1, "rpm": 30.0}
    arm = mechanism_from_dict(d)  # without a load the table is accepted, but forces need a crank
    _raises(lambda: simulate(arm, 20, forces=True), "driver")
