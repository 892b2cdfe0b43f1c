"""The six-bar built-ins of the curve atlas, watt6 (Watt I) and stephenson6 (Stephenson III), against
closed forms written here from the numbers their files state (tests/naive_legs.py's circle
intersection and rigid-body placement): every joint over a turn to 1e-10, velocities against central
differences of the closed form, and the chain each is (which links are ternary, which share a joint)."""

from __future__ import annotations

import numpy as np
import pytest

from naive_legs import circle_intersection, crank_tip, place_body
from explorer import load_mechanism, simulate


def watt6(theta):
    """Watt I: crank 1 about A0 (0, 0); B from A (coupler A-B 2.6) and B0 (3, 0) (rocker B0-B 1.5), left of
    A → B0; the coupler (A, B, C) and the rocker (B0, B, E) rigid; D from C (3.9) and E (link5 3.0), left of
    C → E; the foot P on the body (C, D, P)."""
    A = crank_tip(theta, (0.0, 0.0), 1.0)
    B0 = np.broadcast_to([3.0, 0.0], A.shape)
    B = circle_intersection(A, 2.6, B0, 1.5, +1)
    C = place_body({"A": (0, 0), "B": (2.6, 0), "C": (1.4, 2.8)}, "A", "B", A, B)["C"]
    E = place_body({"B0": (0, 0), "B": (1.5, 0), "E": (3.3, 0)}, "B0", "B", B0, B)["E"]
    D = circle_intersection(C, 3.9, E, 3.0, +1)
    P = place_body({"C": (0, 0), "D": (3.9, 0), "P": (2.3, 1.5)}, "C", "D", C, D)["P"]
    return {"A": A, "B": B, "C": C, "E": E, "D": D, "P": P}


def stephenson6(theta):
    """Stephenson III: crank 1 about (0, 0); B from A (coupler A-B 4.2) and B0 (3, 0) (rocker 3.8), left of
    A → B0; C on the coupler (A, B, C); D from C (2.1) and D0 (-0.5, 4) (rocker2 2.1), left of C → D0;
    the foot P on the body (C, D, P)."""
    A = crank_tip(theta, (0.0, 0.0), 1.0)
    B0 = np.broadcast_to([3.0, 0.0], A.shape)
    D0 = np.broadcast_to([-0.5, 4.0], A.shape)
    B = circle_intersection(A, 4.2, B0, 3.8, +1)
    C = place_body({"A": (0, 0), "B": (4.2, 0), "C": (1.8, 1.5)}, "A", "B", A, B)["C"]
    D = circle_intersection(C, 2.1, D0, 2.1, +1)
    P = place_body({"C": (0, 0), "D": (2.1, 0), "P": (1.1, -0.2)}, "C", "D", C, D)["P"]
    return {"A": A, "B": B, "C": C, "D": D, "P": P}


CLOSED = {"watt6": watt6, "stephenson6": stephenson6}


@pytest.mark.parametrize("name", ["watt6", "stephenson6"])
def test_sixbar_matches_its_closed_form(name):
    mech = load_mechanism(name)
    cyc = simulate(mech, 360, velocities=True, tolerance=1e-12)
    assert cyc.ok
    ref = CLOSED[name](cyc.theta)
    for v, P in ref.items():
        assert np.max(np.abs(cyc.path(v) - P)) < 1e-10, v
    h = 1e-6
    dP = (CLOSED[name](cyc.theta + h)["P"] - CLOSED[name](cyc.theta - h)["P"]) / (2 * h)
    assert np.max(np.abs(cyc.velocity("P") - dP)) < 1e-6


@pytest.mark.parametrize("name, chain", [("watt6", "watt"), ("stephenson6", "stephenson")])
def test_sixbar_chain(name, chain):
    """Six links (the ground, the crank, links and bodies), seven joints; two ternary links that share a
    joint (Watt) or do not (Stephenson)."""
    m = load_mechanism(name)
    members = [{"A0", m.crank.tip}] + [{l.a, l.b} for l in m.links] + [set(b.joints) - {"P"} for b in m.bodies]
    ground = {"A0"} | set(m.fixed)
    members.append(ground)
    assert len(members) == 6
    joints = set().union(*members)
    assert len(joints) == 7
    ternary = [s for s in members if len(s) == 3]
    assert len(ternary) == 2
    shared = ternary[0] & ternary[1]
    assert bool(shared) == (chain == "watt")
