"""The built-in walking legs hoeken, klann and strider (rigid bodies) against plain-numpy closed forms.

tests/naive_legs.py places every joint by explicit circle–circle intersections and rigid-body
rotations; here it is checked against itself (lengths and shapes hold over the turn), against the
.toml files (same numbers, same branch), and explorer's solver is checked against it: positions to
1e-9 and velocities to 1e-6 of the mechanism's size, at every one of 360 crank angles.
"""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest
from naive_legs import LEGS, central_difference, hoeken_positions

from explorer import simulate
from explorer.mechanism import builtin_mechanisms, load_mechanism

NAMES = tuple(LEGS)
STEPS = 360
THETA = 2.0 * np.pi * np.arange(STEPS) / STEPS
#: each built-in's default walker (legs, phases in degrees or None for evenly spaced, mirrored flags)
WALKERS = {
    "hoeken": (6, None, (False,) * 6),
    "klann": (8, None, (False,) * 8),
    "strider": (8, (0, 0, 90, 90, 180, 180, 270, 270), (False, True) * 4),
}


def _size(links, bodies) -> float:
    spans = [L for _, _, L in links]
    for shape in bodies.values():
        spans += [math.dist(p, q) for p, q in itertools.combinations(shape.values(), 2)]
    return max(spans)


def _area(pts, j, k, m) -> float:
    """Twice the signed area of the triangle j, k, m of a body's joints {name: (x, y)}."""
    return (pts[k][0] - pts[j][0]) * (pts[m][1] - pts[j][1]) - (pts[k][1] - pts[j][1]) * (pts[m][0] - pts[j][0])


# -- the references on their own ---------------------------------------------------------------------------
@pytest.mark.parametrize("name", NAMES)
def test_reference_keeps_every_length_and_shape(name):
    """Crank, every link and every pair of joints on a body keep their length over the turn (1e-12)."""
    f, center, radius, tip, links, bodies = LEGS[name]
    theta = np.concatenate([np.linspace(0.0, 2.0 * np.pi, 1441), np.random.default_rng(7).uniform(-10, 10, 200)])
    p = f(theta)
    tol = 1e-12 * _size(links, bodies)
    assert np.all(np.isfinite(np.stack(list(p.values()))))
    assert np.max(np.abs(np.hypot(*(p[tip] - center).T) - radius)) < tol
    for a, b, length in links:
        assert np.max(np.abs(np.hypot(*(p[a] - p[b]).T) - length)) < tol, (a, b)
    for body, shape in bodies.items():
        for (a, sa), (b, sb) in itertools.combinations(shape.items(), 2):
            assert np.max(np.abs(np.hypot(*(p[a] - p[b]).T) - math.dist(sa, sb))) < tol, (body, a, b)
        for (a, sa), (b, sb), (c, sc) in itertools.combinations(shape.items(), 3):  # and it never mirrors
            want = (sb[0] - sa[0]) * (sc[1] - sa[1]) - (sb[1] - sa[1]) * (sc[0] - sa[0])
            got = ((p[b][:, 0] - p[a][:, 0]) * (p[c][:, 1] - p[a][:, 1])
                   - (p[b][:, 1] - p[a][:, 1]) * (p[c][:, 0] - p[a][:, 0]))
            assert np.max(np.abs(got - want)) < tol * _size(links, bodies), (body, a, b, c)


def test_strider_feet_are_mirror_images():
    """Foot 8 at θ is foot 4 at π − θ reflected about the crank's vertical (the walker's mirrored leg)."""
    p, q = LEGS["strider"][0](THETA), LEGS["strider"][0](np.pi - THETA)
    assert np.max(np.abs(p["8"] - q["4"] * [-1.0, 1.0])) < 1e-12 * 20


# -- the .toml files carry the same legs ---------------------------------------------------------------------
@pytest.mark.parametrize("name", NAMES)
def test_builtin_file_matches_reference(name):
    """Same vertices, crank, ground pivots, link lengths and body shapes; the guess lies on the reference's
    branch (within 5 % of the mechanism's size of the closed form at θ = 0)."""
    f, center, radius, tip, links, bodies = LEGS[name]
    mech = load_mechanism(name)
    assert name in builtin_mechanisms()
    p0 = {v: xy[0] for v, xy in f(np.array([0.0])).items()}
    assert set(mech.vertices) == set(p0)
    assert mech.crank.tip == tip and mech.crank.radius == radius and tuple(mech.crank.center) == tuple(center)
    for v, xy in mech.fixed.items():
        assert np.allclose(xy, p0[v], rtol=0, atol=1e-12), v
    size = _size(links, bodies)
    assert mech.size == pytest.approx(size, rel=1e-12)
    want = {frozenset((a, b)): length for a, b, length in links}
    assert {frozenset((l.a, l.b)): l.length for l in mech.links} == want
    assert {b.name for b in mech.bodies} == set(bodies)
    for b in mech.bodies:
        shape = bodies[b.name]
        assert set(b.joints) == set(shape)
        pts = dict(zip(b.joints, b.points))
        for j, k in itertools.combinations(b.joints, 2):
            assert math.dist(pts[j], pts[k]) == pytest.approx(math.dist(shape[j], shape[k]), rel=1e-12), (j, k)
        for j, k, m in itertools.combinations(b.joints, 3):  # same handedness: a body never mirrors
            assert _area(pts, j, k, m) == pytest.approx(_area(shape, j, k, m), rel=1e-9, abs=1e-12 * size ** 2)
    for v, xy in mech.guess.items():
        assert math.dist(xy, p0[v]) < 0.05 * size, v


@pytest.mark.parametrize("name", NAMES)
def test_builtin_walker_loads(name):
    legs, phases, mirrored = WALKERS[name]
    w = load_mechanism(name).walker
    assert w is not None and w.legs == legs
    assert w.mirrored == mirrored
    if phases is not None:
        assert np.allclose(np.degrees(w.phases), phases)


# -- the Hoeken leg's straight stretch (from the closed form alone) -------------------------------------------
def test_hoeken_foot_is_flat_along_y_minus_4_for_half_a_turn():
    """Over θ ∈ [90°, 270°] the foot stays within 0.0098 of y = −4 while x sweeps 4 (0 → 4).

    The closed form gives, on a 10⁶-point grid of that half turn: y from −4.00975 to −4 (exactly −4 at
    θ = 180°, where B = (−1, 0), C = (0.5, −2), P = (2, −4)), and x from 0 to 4 exactly (θ = 90°: B =
    (0, 1), P = (0, y); θ = 270° its mirror image). So the deviation is 0.245 % of the 4-unit stroke.
    Widening the band to 0.01 keeps the foot in it from θ = 75.4° to 284.6°: 209° of crank. The other
    part of the turn the foot dips to y = −2√6 = −4.899 (θ = 0): the straight stretch is the upper edge of
    the foot path, the one nearest the frame.
    """
    theta = np.linspace(0.5 * np.pi, 1.5 * np.pi, 1_000_001)
    P = hoeken_positions(theta)["P"]
    dev = np.abs(P[:, 1] + 4.0)
    assert dev.max() < 0.0098 and dev.max() > 0.0097           # the band is real, and this is its size
    assert P[:, 0].min() == pytest.approx(0.0, abs=1e-12) and P[:, 0].max() == pytest.approx(4.0, abs=1e-12)
    assert hoeken_positions(np.array([np.pi]))["P"][0] == pytest.approx([2.0, -4.0], abs=1e-12)
    whole = hoeken_positions(np.linspace(0.0, 2.0 * np.pi, 100_001))["P"]
    inside = np.abs(whole[:, 1] + 4.0) <= 0.01
    assert 0.57 < inside.mean() < 0.59                          # 209° of 360° within 0.01 of y = −4
    assert whole[:, 1].max() <= -4.0 + 1e-12                    # nothing above the line: it is the top edge
    assert whole[:, 1].min() == pytest.approx(-2.0 * math.sqrt(6.0), abs=1e-9)


# -- explorer's solver against the references ---------------------------------------------------------------
@pytest.fixture(scope="module")
def cycles():
    return {name: simulate(load_mechanism(name), steps=STEPS, velocities=True) for name in NAMES}


@pytest.mark.parametrize("name", NAMES)
def test_simulate_matches_closed_form(name, cycles):
    cycle = cycles[name]
    mech = cycle.mechanism
    assert cycle.ok, cycle.failure
    ref = LEGS[name][0](THETA)
    for v in mech.vertices:
        err = np.max(np.abs(cycle.path(v) - ref[v]))
        assert err < 1e-9 * mech.size, (v, err)


@pytest.mark.parametrize("name", NAMES)
def test_velocities_match_finite_differences(name, cycles):
    cycle = cycles[name]
    mech = cycle.mechanism
    assert cycle.ok, cycle.failure
    fd = central_difference(LEGS[name][0], THETA, h=1e-6)
    for v in mech.vertices:
        err = np.max(np.abs(cycle.velocity(v) - fd[v]))
        assert err < 1e-6 * mech.size, (v, err)


def test_simulated_hoeken_foot_is_flat(cycles):
    """The solver's foot path shows the same straight stretch: samples 90 … 270 (θ = 90° … 270°)."""
    y = cycles["hoeken"].path("P")[90:271, 1]
    assert np.max(np.abs(y + 4.0)) < 0.0098


@pytest.mark.slow
@pytest.mark.parametrize("leg", ["hoeken", "klann"])
def test_shipped_pivot_studies_run_end_to_end(leg, tmp_path):
    """studies/<leg>-pivots.toml (every parameter varied, bodies included) runs, on 40 of its variants:
    the frame carries each body joint and pivot as a column, and an ok variant's stored foot is the
    re-solved design those columns describe (simulate of mech.with_parameters(row))."""
    import tomllib
    from pathlib import Path

    import explorer

    d = tomllib.loads((Path(__file__).parent.parent / "studies" / f"{leg}-pivots.toml").read_text())
    assert d["perturb"]["parameters"] == "all"
    d["study"]["variants"] = 40
    out = tmp_path / f"{leg}.h5"
    explorer.run_study(d, output=out, progress=False)
    with explorer.open_results(out) as r:
        df = r.frame()
        mech = r.mechanism
        coords = [n for n in mech.parameters() if mech.parameter_kind(n) == "coordinate"]
        assert set(coords) <= set(df.columns)
        ok = df.index[df["status"] == "ok"]
        assert len(ok) >= 30
        row = df.loc[ok[1]]
        variant = mech.with_parameters({n: row[n] for n in mech.parameters()})
        cyc = explorer.simulate(variant, d["study"]["steps"])
        stored = r.path(int(row["variant"]), mech.foot)
        assert np.max(np.abs(cyc.path(mech.foot) - stored)) < 1e-9 * mech.size
