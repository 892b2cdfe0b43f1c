"""The geared pair (``[[gears]]``, the GEARS block kind): a second grounded crank whose angle is ``ratio``
× the driving crank's plus ``phase``. The built-in geared five-bar and variants of it (other ratios,
phases, radii and centres) against the plain-numpy closed form written here: positions to 1e-10,
velocities and accelerations against central differences of that closed form (never the code's own
output); the plan, the file's errors, the round trip through TOML, and the forces' refusal."""

from __future__ import annotations

import math

import numpy as np
import pytest

from explorer import UserError, load_mechanism, simulate, simulate_batch
from explorer.kernels import plan_for
from explorer.kinds import DYAD, BlockKind
from explorer.mechanism import mechanism_from_dict, mechanism_toml, parse_toml

GEARS = int(BlockKind.GEARS)


def five_bar(theta, a=1.0, ca=(0.0, 0.0), cb=(4.0, 0.0), rb=1.5, ratio=-1, phase=0.0, l1=4.0, l2=4.0, side=-1.0):
    """The geared five-bar's joints at crank angles theta (radians, (S,)): A = ca + a (cos θ, sin θ),
    B = cb + rb (cos ψ, sin ψ) with ψ = ratio·θ + phase (degrees), and P at l1 from A and l2 from B,
    on the side ``side`` of the line A → B (−1: its right, the foot below the frame). (S, 3, 2) in the
    order A, P, B (the mechanism's vertices)."""
    theta = np.asarray(theta, dtype=float)
    A = np.stack([ca[0] + a * np.cos(theta), ca[1] + a * np.sin(theta)], axis=-1)
    psi = ratio * theta + math.radians(phase)
    B = np.stack([cb[0] + rb * np.cos(psi), cb[1] + rb * np.sin(psi)], axis=-1)
    d = np.linalg.norm(B - A, axis=-1)
    u = (B - A) / d[:, None]
    n = np.stack([-u[:, 1], u[:, 0]], axis=-1)  # u turned a quarter anticlockwise: the left
    along = (l1 * l1 - l2 * l2 + d * d) / (2 * d)
    h = np.sqrt(l1 * l1 - along * along)
    P = A + along[:, None] * u + side * h[:, None] * n
    return np.stack([A, P, B], axis=1)


def rates(f, theta, h=1e-4):
    """Central differences of f (θ → (S, 3, 2)): the first and second derivatives per radian."""
    fp, f0, fm = f(theta + h), f(theta), f(theta - h)
    return (fp - fm) / (2 * h), (fp - 2 * f0 + fm) / (h * h)


def test_plan_places_the_geared_tip_exactly_then_the_foot_by_a_dyad():
    mech = load_mechanism("geared5bar")
    plan = plan_for(mech)
    assert [b.kind for b in plan.blocks] == [GEARS, DYAD]
    assert [mech.vertices[v] for v in plan.blocks[0].vertices] == ["B"]
    assert [mech.vertices[v] for v in plan.blocks[1].vertices] == ["P"]
    assert set(mech.parameters()) >= {"gear", "gear.x", "gear.y", "A-P", "B-P", "crank"}
    assert mech.parameter_kind("gear") == "length" and mech.parameter_kind("gear.x") == "coordinate"


@pytest.mark.parametrize("method", ["block", "dense", "closed"])
def test_geared5bar_matches_the_closed_form(method):
    mech = load_mechanism("geared5bar")
    acc = method != "closed"
    cyc = simulate(mech, steps=360, method=method, accelerations=acc)
    assert cyc.ok
    ref = five_bar(cyc.theta)
    assert np.max(np.abs(cyc.positions - ref)) <= 1e-10
    assert np.isclose(cyc.positions[0, 1], [3.25, -math.sqrt(16 - 2.25 ** 2)]).all()  # the foot below
    if acc:
        dref, ddref = rates(five_bar, cyc.theta)
        assert np.max(np.abs(cyc.velocities - dref)) <= 1e-7
        assert np.max(np.abs(cyc.accelerations - ddref)) <= 1e-5
        # the geared tip's rates are exact: −rb (−sin ψ, cos ψ)·1, rb (cos ψ, sin ψ)·(−1)² ... with ψ = −θ
        B = mech.vertex_index("B")
        psi = -cyc.theta
        np.testing.assert_allclose(cyc.velocities[:, B], np.stack([1.5 * np.sin(psi), -1.5 * np.cos(psi)], -1),
                                   atol=1e-12)
        np.testing.assert_allclose(cyc.accelerations[:, B], np.stack([-1.5 * np.cos(psi), -1.5 * np.sin(psi)], -1),
                                   atol=1e-12)



def test_geared5bar_by_the_vectorised_pass():
    """method "vector": the geared tip and the five-bar's dyad over every sample at once, no Newton."""
    mech = load_mechanism("geared5bar")
    cyc = simulate(mech, steps=360, method="vector")
    assert cyc.ok and cyc.iterations == 0
    np.testing.assert_allclose(cyc.positions, five_bar(cyc.theta), rtol=0, atol=1e-10)
    dref, _ = rates(five_bar, cyc.theta)
    assert np.max(np.abs(cyc.velocities - dref)) <= 1e-7

GEARED = """
name = "g"
foot = "P"
[crank]
center = [0.0, 0.0]
radius = 1.0
tip = "A"
[[gears]]
name = "gear"
center = [4.0, 0.5]
radius = 0.8
tip = "B"
ratio = {ratio}
phase = {phase}
[guess]
P = [2.0, -3.5]
[[links]]
a = "A"
b = "P"
length = 4.0
[[links]]
a = "B"
b = "P"
length = 4.5
"""


@pytest.mark.parametrize("ratio,phase", [(2, 30.0), (-3, -45.0), (1, 90.0)])
def test_other_ratios_and_phases_match_the_closed_form(ratio, phase):
    mech = mechanism_from_dict(parse_toml(GEARED.format(ratio=ratio, phase=phase), "g.toml"), "g.toml")
    cyc = simulate(mech, steps=720, accelerations=True)
    assert cyc.ok

    def f(t):
        return five_bar(t, cb=(4.0, 0.5), rb=0.8, ratio=ratio, phase=phase, l2=4.5)

    assert np.max(np.abs(cyc.positions - f(cyc.theta))) <= 1e-10
    d, dd = rates(f, cyc.theta)
    assert np.max(np.abs(cyc.velocities - d)) <= 1e-6
    assert np.max(np.abs(cyc.accelerations - dd)) <= 1e-4
    # the cycle closes: the geared crank turned a whole number of times
    np.testing.assert_allclose(f(np.array([2 * math.pi]))[0], cyc.positions[0], atol=1e-12)


@pytest.mark.parametrize("kernel", ["auto", "general", "generated"])
def test_batch_variants_move_the_geared_crank(kernel):
    """Per-variant gear radius and centre (design parameters "gear", "gear.x", "gear.y") and link
    lengths, through every kernel; a variant that cannot reach fails, one with a bad radius is invalid."""
    mech = load_mechanism("geared5bar")
    rng = np.random.default_rng(3)
    N = 40
    L = mech.lengths * (1 + rng.uniform(-0.1, 0.1, (N, 2)))
    crank = 1 + rng.uniform(-0.2, 0.2, N)
    geo = {"gear": 1.5 * (1 + rng.uniform(-0.3, 0.3, N)), "gear.x": 4 + rng.uniform(-0.5, 0.5, N),
           "gear.y": rng.uniform(-0.5, 0.5, N)}
    L[5] = [2.0, 2.0]          # too short to reach at any angle: an assembly failure
    geo["gear"][6] = -1.0      # a negative radius: invalid
    b = simulate_batch(mech, L, crank, 180, geometry=geo, vertices="all", accelerations=True, kernel=kernel)
    assert b.status[5] != 0 and b.status[6] != 0 and np.isnan(b.paths["P"][6]).all()
    ok = np.flatnonzero(b.status == 0)
    assert len(ok) >= N - 2
    for i in ok:
        def f(t, i=i):
            return five_bar(t, a=crank[i], cb=(geo["gear.x"][i], geo["gear.y"][i]), rb=geo["gear"][i],
                            l1=L[i, 0], l2=L[i, 1])
        got = np.stack([b.paths[v][i] for v in mech.vertices], axis=1)
        assert np.max(np.abs(got - f(b.theta))) <= 1e-10
        vel = np.stack([b.velocities[v][i] for v in mech.vertices], axis=1)
        acc = np.stack([b.accelerations[v][i] for v in mech.vertices], axis=1)
        d, dd = rates(f, b.theta)
        assert np.max(np.abs(vel - d)) <= 1e-6
        assert np.max(np.abs(acc - dd)) <= 1e-4
    # a study's frame of parameters by name: the gear radius is read from its column, not ignored
    # (the outputs above: the generated kernel compiled for them serves this call too)
    by_name = simulate_batch(mech, {"A-P": L[:, 0], "B-P": L[:, 1], "crank": crank, **geo}, steps=180, kernel=kernel,
                             vertices="all", accelerations=True)
    np.testing.assert_array_equal(by_name.paths["P"], b.paths["P"])


def test_round_trip_through_toml_keeps_the_gears():
    mech = load_mechanism("geared5bar")
    text = mechanism_toml(mech)
    again = mechanism_from_dict(parse_toml(text, "again.toml"), "again.toml")
    assert again.gears == mech.gears
    np.testing.assert_array_equal(simulate(again, 36).positions, simulate(mech, 36).positions)
    moved = mech.with_parameters({"gear": 1.2, "gear.x": 4.5})
    assert moved.gears[0].radius == 1.2 and moved.gears[0].center == (4.5, 0.0)
    cyc = simulate(moved, 90)
    assert np.max(np.abs(cyc.positions - five_bar(cyc.theta, cb=(4.5, 0.0), rb=1.2))) <= 1e-10


@pytest.mark.parametrize("edit,key", [
    ('ratio = 0', "gears[0].ratio"),
    ('ratio = 1.5', "gears[0].ratio"),
    ('radius = -1.0', "gears[0].radius"),
    ('tip = "A"', "gears[0].tip"),
    ('phase = "x"', "gears[0].phase"),
    ('spin = 2', "gears[0]"),
])
def test_bad_gears_are_one_line_errors_naming_the_key(edit, key):
    lines = GEARED.format(ratio=2, phase=0.0).splitlines()
    field = edit.split(" = ")[0]
    at = lines.index("[[gears]]")
    if any(ln.startswith(field + " ") for ln in lines[at:at + 7]):
        lines = [edit if (i > at and i < at + 7 and ln.startswith(field + " ")) else ln for i, ln in enumerate(lines)]
    else:
        lines.insert(at + 1, edit)
    with pytest.raises(UserError) as err:
        mechanism_from_dict(parse_toml("\n".join(lines), "g.toml"), "g.toml")
    msg = str(err.value)
    assert "\n" not in msg and "g.toml" in msg and key in msg


def test_forces_refuse_the_geared_pair_with_a_reason():
    mech = load_mechanism("geared5bar")
    with pytest.raises(UserError, match="geared crank"):
        simulate(mech, 36, forces=True)
