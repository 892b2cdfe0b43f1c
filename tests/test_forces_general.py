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
                          operating={"unit": unit, "rpm": rpm, "gravity": gravity})
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
