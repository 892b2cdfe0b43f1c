"""The forces effect on a coupled (GENERAL) block: the Assur triad of data/triad.toml with masses.

Reference: the power balance, written plainly here. The motor's power τω equals the rate of change
of every link's kinetic energy plus the rate at which it gains potential energy:
τω = Σ_links (m a_G·v_G + I_G ω_l α_l + m g v_G,y) + m_c g v_Gc,y (the crank turns steadily), with every
velocity and acceleration taken by periodic central finite differences of the solved positions
(not from the code's own velocities or accelerations).
"""

import math

import numpy as np
import pytest

import explorer
from explorer.mechanism import Walker, mechanism_from_dict, parse_toml
from naive import TRIAD

MASSES = {"leg-A": 0.3, "leg-G1": 0.25, "leg-G2": 0.2, "T1-T2": 0.4, "T2-T3": 0.35, "T3-T1": 0.45}


def _triad_with_masses():
    d = parse_toml(TRIAD.read_text(), str(TRIAD))
    for lk in d["links"]:
        lk["mass"] = MASSES[lk.get("name", f"{lk['a']}-{lk['b']}")]
    d["crank"]["mass"] = 0.15
    return mechanism_from_dict(d, "triad-with-masses")


def _diff(x, h):
    """Periodic central first and second differences along axis 0, spacing h."""
    xp, xm = np.roll(x, -1, axis=0), np.roll(x, 1, axis=0)
    return (xp - xm) / (2 * h), (xp - 2 * x + xm) / (h * h)


@pytest.mark.parametrize("rpm, gravity", [(20.0, 9.81), (90.0, 0.0), (90.0, 9.81)])
def test_triad_power_balance(rpm, gravity):
    mech = _triad_with_masses()
    unit = 0.05
    S = 3600
    c = explorer.simulate(mech, S, forces=True, walker=Walker(legs=1),
                          operating={"unit": unit, "rpm": rpm, "gravity": gravity, "body": "held"})
    assert c.ok, c.failure
    w = rpm * 2 * math.pi / 60
    h = 2 * math.pi / S
    P = c.positions * unit  # metres
    power = np.zeros(S)
    for lk in mech.links:
        a, b = P[:, mech.vertex_index(lk.a)], P[:, mech.vertex_index(lk.b)]
        m = MASSES[lk.name]
        G = (a + b) / 2
        vG, aG = _diff(G, h)
        vG, aG = vG * w, aG * w * w
        d = b - a
        phi = np.unwrap(np.arctan2(d[:, 1], d[:, 0]))
        # the angle is not periodic across 2π windings: difference its unwrapped increments
        dphi = np.angle(np.exp(1j * (np.roll(phi, -1) - np.roll(phi, 1)))) / (2 * h)
        ddphi = np.angle(np.exp(1j * (np.roll(phi, -1) - phi))) - np.angle(np.exp(1j * (phi - np.roll(phi, 1))))
        om, al = dphi * w, ddphi / (h * h) * w * w
        L = np.hypot(d[:, 0], d[:, 1]).mean()
        I = m * L * L / 12
        power += m * np.sum(aG * vG, axis=1) + I * om * al + m * gravity * vG[:, 1]
    tip = P[:, mech.vertex_index(mech.crank.tip)]
    Gc = (tip + np.array(mech.crank.center) * unit) / 2
    vGc, _ = _diff(Gc, h)
    power += 0.15 * gravity * vGc[:, 1] * w
    scale = np.max(np.abs(power))
    assert scale > 0.01  # the case carries real power
    np.testing.assert_allclose(c.torque * w, power, rtol=0, atol=2e-5 * scale)


def test_triad_massless_has_no_torque_and_balanced_pins():
    """Without masses, gravity or load nothing loads the triad: zero torque and zero reactions."""
    d = parse_toml(TRIAD.read_text(), str(TRIAD))
    mech = mechanism_from_dict(d, "triad")
    c = explorer.simulate(mech, 360, forces=True, walker=Walker(legs=1), operating={"unit": 0.05, "rpm": 60})
    assert c.ok
    np.testing.assert_array_equal(c.torque, 0.0)
    assert c.force_metrics["pin_force_max"] == 0.0


def test_a_machine_that_does_not_travel_has_no_finite_cost_of_transport():
    """One leg: its foot carries the load all turn and its path is closed, so the body's travel per turn
    is the integral of a periodic foot's dx/dθ over a period, exactly 0. What a sum of samples holds
    then is rounding, which divided the energy into a cost of transport of 1e16: it must read inf (the
    worst under "min"), with the energy itself finite and positive (the triad with masses does work)."""
    mech = _triad_with_masses()
    c = explorer.simulate(mech, 360, forces=True, walker=Walker(legs=1),
                          operating={"unit": 0.05, "rpm": 30, "gravity": 9.81, "body": "held"})
    assert c.ok, c.failure
    foot = c.path(mech.foot)
    # the premise, by brute force: the foot's sampled x returns to where it started (a closed path)
    assert abs(foot[-1, 0] + (foot[1, 0] - foot[0, 0]) - foot[0, 0]) < 1e-2 * np.ptp(foot[:, 0])
    e = c.force_metrics["energy_per_turn"]
    assert np.isfinite(e) and e > 0
    assert c.force_metrics["cost_of_transport"] == np.inf


@pytest.mark.parametrize("name", ["jansen", "klann"])
def test_forces_path_velocities_and_accelerations_match_finite_differences(name):
    """With forces on, a batch's velocities and accelerations come from the forces' own block solves:
    they are the θ-derivatives of the positions (fourth-order periodic central differences at 3,600
    steps: truncation ~h⁴, rounding ~1e-16/h² of the positions)."""
    mech = explorer.load_mechanism(name)
    rng = np.random.default_rng(7)
    L = mech.lengths * (1 + rng.uniform(-0.01, 0.01, (6, len(mech.links))))
    S = 3600
    b = explorer.simulate_batch(mech, L, None, S, vertices="all", velocities=True, accelerations=True, forces=True,
                                operating={"unit": 0.01, "rpm": 30})
    ok = b.status == 0
    assert ok.sum() >= 4
    h = 2 * math.pi / S
    for v in mech.vertices:
        P, V, A = b.paths[v][ok], b.velocities[v][ok], b.accelerations[v][ok]
        x = np.moveaxis(P, 1, 0)  # fourth-order periodic central differences
        p1, m1, p2, m2 = (np.roll(x, -1, 0), np.roll(x, 1, 0), np.roll(x, -2, 0), np.roll(x, 2, 0))
        dP = (-p2 + 8 * p1 - 8 * m1 + m2) / (12 * h)
        ddP = (-p2 + 16 * p1 - 30 * x + 16 * m1 - m2) / (12 * h * h)
        r = mech.crank.radius  # the tip's speed per radian and acceleration per radian²: the scale
        np.testing.assert_allclose(V, np.moveaxis(dP, 0, 1), rtol=0, atol=1e-6 * r)
        np.testing.assert_allclose(A, np.moveaxis(ddP, 0, 1), rtol=0, atol=1e-4 * r)


def test_a_machine_that_does_not_travel_reads_zero_travel_in_the_walker_metrics_too():
    """The walker metrics share the forces' rule (one home: kernels' contact_stroke): one leg's closed
    foot path travels exactly 0 per turn, and the slip per unit of travel is NaN (it read 1e16 and more
    when the travel was the rounding left in a sum). Reference: the contact foot is the only foot, so
    the net stroke is Σ_k dx/dθ(θ_k), compared here with the total stroke Σ_k |dx/dθ| in plain numpy."""
    from explorer.gait import compute_metrics
    mech = _triad_with_masses()
    c = explorer.simulate(mech, 360, walker=Walker(legs=1))
    assert c.ok, c.failure
    vx = c.velocity(mech.foot)[:, 0]
    assert abs(vx.sum()) <= 1e-9 * np.abs(vx).sum()  # the premise, in numpy: only rounding is left
    p, v = c.path(mech.foot)[None], c.velocity(mech.foot)[None]
    out = compute_metrics(p, v, np.zeros(1, dtype=np.int64), ["travel", "slip", "body_speed_ripple"],
                          mechanism=mech, walker=Walker(legs=1))
    assert out["travel"][0] == 0.0
    assert np.isnan(out["slip"][0])
    # the body speed's ripple still reads the stroke (not the net): finite, as the numpy form gives
    s = np.abs(vx)
    assert out["body_speed_ripple"][0] == pytest.approx(np.sqrt(np.mean((s - s.mean()) ** 2)) / s.mean(), rel=1e-9)
