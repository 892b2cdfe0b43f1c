"""simulate / simulate_batch checked against independent plain-numpy references (tests/naive.py).

References: sequential circle-circle intersections (closed form), a textbook dense Newton solve and
seed 000's eq. 29-30 velocity solve in numpy, central finite differences, and the published nominal
figures of tests/reference/ (a copy of the project's shared reference). Nothing is compared with explorer's own earlier output.
"""

from __future__ import annotations

import numpy as np
import pytest

import naive
from naive import REFERENCE_FOOT
from explorer import STATUS_NAMES, make_plan, simulate, simulate_batch


def jansen_reference(thetas):
    pos, ok, _ = naive.jansen_closed_form(naive.JANSEN_LENGTHS, naive.JANSEN_CRANK, thetas)
    assert ok.all()
    return pos


def to_naive_order(mech, arr):
    """Reorder the vertex axis (axis 1) of (S, nv, 2) into naive.JANSEN_VERTICES order."""
    return arr[:, [mech.vertex_index(v) for v in naive.JANSEN_VERTICES]]


def link_errors(mech, positions):
    ends = [(mech.vertex_index(l.a), mech.vertex_index(l.b)) for l in mech.links]
    return naive.link_length_errors(positions, ends, mech.lengths)


# -- the nominal Jansen leg -----------------------------------------------------------------------------
def test_builtin_jansen_is_seed_000(jansen):
    """The built-in file carries exactly the seed's numbers (the references below hard-code them)."""
    assert tuple((l.a, l.b) for l in jansen.links) == naive.JANSEN_LINKS
    assert tuple(jansen.lengths) == naive.JANSEN_LENGTHS
    assert jansen.crank.radius == naive.JANSEN_CRANK and tuple(jansen.crank.center) == naive.JANSEN_CENTER
    assert tuple(jansen.fixed["2"]) == naive.JANSEN_FIXED2
    assert dict(jansen.guess) == naive.JANSEN_GUESS
    assert jansen.crank.tip == "1" and jansen.foot == "7"


def test_nominal_matches_closed_form(jansen, jansen_cycle, thetas360):
    c = jansen_cycle
    assert c.ok and c.failure is None
    np.testing.assert_allclose(c.theta, thetas360, rtol=0, atol=1e-15)
    ref = jansen_reference(thetas360)
    np.testing.assert_allclose(c.path("7"), ref[:, 6], rtol=0, atol=1e-9)
    np.testing.assert_allclose(to_naive_order(jansen, c.positions), ref, rtol=0, atol=1e-9)


def test_nominal_link_lengths_hold(jansen, jansen_cycle, thetas360):
    P = jansen_cycle.positions
    assert np.isfinite(P).all()
    assert link_errors(jansen, P).max() <= 1e-9
    tip = np.stack([15.0 * np.cos(thetas360), 15.0 * np.sin(thetas360)], axis=1)
    np.testing.assert_allclose(jansen_cycle.path("1"), tip, rtol=0, atol=1e-12)
    assert np.all(jansen_cycle.path("2") == np.array([-38.0, -7.8]))


def test_nominal_published_figures(jansen_cycle):
    """Sanity cross-check with the published nominal figures (given to 4 decimals)."""
    foot = jansen_cycle.path("7")
    assert foot[:, 0].min() == pytest.approx(-71.5215, abs=1e-4)
    assert foot[:, 0].max() == pytest.approx(-3.6133, abs=1e-4)
    assert foot[:, 1].min() == pytest.approx(-91.8339, abs=1e-4)
    assert foot[:, 1].max() == pytest.approx(-69.3769, abs=1e-4)
    assert np.ptp(foot[:, 0]) == pytest.approx(67.908, abs=1e-3)
    assert np.ptp(foot[:, 1]) == pytest.approx(22.457, abs=1e-3)
    np.testing.assert_allclose(foot[0], [-43.1601, -91.7569], atol=1e-4)


def test_nominal_matches_shared_reference_csv(jansen_cycle):
    ref = np.loadtxt(REFERENCE_FOOT, delimiter=",", skiprows=1)
    assert ref.shape == (360, 3)
    np.testing.assert_allclose(jansen_cycle.theta, ref[:, 0], rtol=0, atol=1e-11)
    np.testing.assert_allclose(jansen_cycle.path("7"), ref[:, 1:], rtol=0, atol=1e-9)


def test_nominal_velocities_match_finite_differences(jansen, jansen_cycle, thetas360):
    fd = naive.central_difference(jansen_reference, thetas360, h=1e-5)
    V = to_naive_order(jansen, jansen_cycle.velocities)
    assert np.isfinite(V).all()
    for j, v in enumerate(naive.JANSEN_VERTICES):
        scale = np.abs(fd[:, j]).max()
        if v == "2":
            assert np.all(V[:, j] == 0.0)
            continue
        np.testing.assert_allclose(V[:, j], fd[:, j], rtol=1e-6, atol=1e-6 * scale, err_msg=f"vertex {v}")
    # the foot velocity is the path's tangent: never (numerically) zero on this leg
    assert np.hypot(*jansen_cycle.velocity("7").T).min() > 1.0


def test_nominal_velocities_match_seed_eq30(jansen, jansen_cycle, thetas360):
    """dV/dθ = M⁻¹B (seed 000, eqs. 29-30) solved densely in numpy at every sample."""
    for k in range(0, 360, 7):
        ref = naive.newton_velocity(jansen, jansen_cycle.positions[k], thetas360[k])
        np.testing.assert_allclose(jansen_cycle.velocities[k], ref, rtol=0, atol=1e-9)


@pytest.mark.parametrize("method", ["block", "dense", "auto"])
def test_nominal_accelerations_match_finite_differences(jansen, method, thetas360):
    c = simulate(jansen, 360, tolerance=1e-12, method=method, accelerations=True)
    assert c.ok
    h = 1e-3  # five-point stencil: truncation ~h⁴, rounding ~1e-7 here
    f = jansen_reference
    th = thetas360
    fd2 = (-f(th + 2 * h) + 16 * f(th + h) - 30 * f(th) + 16 * f(th - h) - f(th - 2 * h)) / (12 * h * h)
    A = to_naive_order(jansen, c.accelerations)
    np.testing.assert_allclose(A, fd2, rtol=1e-6, atol=1e-6 * np.abs(fd2).max())


def test_block_and_dense_agree(jansen, jansen_cycle):
    d = simulate(jansen, 360, tolerance=1e-12, method="dense")
    assert d.ok and jansen_cycle.ok
    np.testing.assert_allclose(d.positions, jansen_cycle.positions, rtol=0, atol=1e-9)
    np.testing.assert_allclose(d.velocities, jansen_cycle.velocities, rtol=0, atol=1e-9)


@pytest.mark.parametrize("steps", [3, 7, 25])
@pytest.mark.parametrize("method", ["block", "dense", "auto"])
def test_coarse_steps_stay_on_branch(jansen, method, steps):
    """Steps of up to 120° must be refined internally, not jump branches."""
    th = 2 * np.pi * np.arange(steps) / steps
    c = simulate(jansen, steps, tolerance=1e-12, method=method)
    assert c.ok
    np.testing.assert_allclose(to_naive_order(jansen, c.positions), jansen_reference(th), rtol=0, atol=1e-9)
    fd = naive.central_difference(jansen_reference, th)
    np.testing.assert_allclose(to_naive_order(jansen, c.velocities), fd, rtol=1e-6, atol=1e-6 * np.abs(fd).max())


def test_closed_method_matches_closed_form(jansen, thetas360):
    c = simulate(jansen, 360, method="closed", velocities=False)
    assert c.ok
    np.testing.assert_allclose(to_naive_order(jansen, c.positions), jansen_reference(thetas360), rtol=0, atol=1e-10)


# -- random ±2 % variants -----------------------------------------------------------------------------
# A variant within this distance (model units) of the assembly limit is too close to call: the kernel
# may legitimately see a tangent dyad as either side. Exact margins are in naive.jansen_assembly_margin.
AMBIGUOUS = 1e-4


@pytest.fixture(scope="module")
def variants():
    rng = np.random.default_rng(20250923)
    f = rng.uniform(0.98, 1.02, size=(200, 11))
    lengths = np.array(naive.JANSEN_LENGTHS) * f[:, :10]
    crank = naive.JANSEN_CRANK * f[:, 10]
    return lengths, crank


def test_reference_margin_agrees_with_dense_sampling(variants):
    """Self-check of the reference: the refined margin vs a plain 20000-angle sampled minimum slack,
    on the 20 variants closest to the assembly limit."""
    lengths, crank = variants
    margin = naive.jansen_assembly_margin(lengths, crank)
    near = np.argsort(np.abs(margin))[:20]
    th = 2 * np.pi * np.arange(20000) / 20000
    _, ok, slack = naive.jansen_closed_form(lengths[near], crank[near], th)
    sampled = np.min([np.nanmin(np.where(np.isnan(s), np.inf, s), axis=1) for s in slack.values()], axis=0)
    assert list(margin[near] > 0) == list(ok.all(axis=1))
    live = margin[near] > 0
    # sampling can only overestimate a minimum, and by little at this density
    assert np.all(sampled[live] >= margin[near][live] - 1e-12)
    np.testing.assert_allclose(sampled[live], margin[near][live], atol=1e-5)


def test_variants_match_closed_form_or_fail_assembly(jansen, variants, thetas360):
    lengths, crank = variants
    b = simulate_batch(jansen, lengths, crank, 360, vertices=list(naive.JANSEN_VERTICES), tolerance=1e-12)
    margin = naive.jansen_assembly_margin(lengths, crank)
    assembles = margin > AMBIGUOUS
    cannot = margin < -AMBIGUOUS
    # the sample must exercise both outcomes and leave (almost) nothing undecided
    assert 5 <= cannot.sum() <= 60, cannot.sum()
    assert (~assembles & ~cannot).sum() <= 3

    ref, ok, _ = naive.jansen_closed_form(lengths, crank, thetas360)
    ref_v = naive.central_difference(lambda t: naive.jansen_closed_form(lengths, crank, t)[0], thetas360, h=1e-5)
    plan = make_plan(jansen)
    for i in range(len(crank)):
        status = STATUS_NAMES[int(b.status[i])]
        paths = np.stack([b.paths[v][i] for v in naive.JANSEN_VERTICES], axis=1)
        if assembles[i]:
            assert ok[i].all()
            assert status == "ok", f"variant {i} (margin {margin[i]:.3g}) came back {status}"
            assert np.isnan(b.fail_theta[i]) and b.fail_block[i] == -1
            np.testing.assert_allclose(paths, ref[i], rtol=0, atol=1e-8, err_msg=f"variant {i}")
            vel = np.stack([b.velocities[v][i] for v in naive.JANSEN_VERTICES], axis=1)
            np.testing.assert_allclose(vel, ref_v[i], rtol=1e-6, atol=1e-6 * np.abs(ref_v[i]).max(),
                                       err_msg=f"variant {i}")
        elif cannot[i]:
            assert status == "assembly", f"variant {i} (margin {margin[i]:.3g}) came back {status}"
            th = float(b.fail_theta[i])
            assert 0.0 <= th < 2.0 * np.pi
            vertex = jansen.vertices[plan.blocks[int(b.fail_block[i])].vertices[0]]
            check_failure_angle(lengths[i], crank[i], th, vertex)
            end = float(b.fail_theta_end[i])
            check_range_end(lengths[i], crank[i], end)
            gone = unreachable(thetas360, th, end)
            assert np.isnan(paths[gone]).all()
            np.testing.assert_allclose(paths[~gone], ref[i][~gone], rtol=0, atol=1e-7, err_msg=f"variant {i}")


def test_dense_batch_agrees_with_closed_form(jansen, variants, thetas360):
    """The dense method classifies the first 40 variants the same way, with the same paths."""
    lengths, crank = variants[0][:40], variants[1][:40]
    b = simulate_batch(jansen, lengths, crank, 360, tolerance=1e-12, method="dense")
    margin = naive.jansen_assembly_margin(lengths, crank)
    ref, _, _ = naive.jansen_closed_form(lengths, crank, thetas360)
    assert (margin < -AMBIGUOUS).sum() >= 2  # this slice holds failing variants too
    for i in range(40):
        if margin[i] > AMBIGUOUS:
            assert b.status[i] == 0, (i, STATUS_NAMES[int(b.status[i])])
            np.testing.assert_allclose(b.paths["7"][i], ref[i, :, 6], rtol=0, atol=1e-8)
        elif margin[i] < -AMBIGUOUS:
            assert STATUS_NAMES[int(b.status[i])] == "assembly", i
            assert 0.0 <= b.fail_theta[i] < 2.0 * np.pi


def test_closed_method_batch(jansen, variants, thetas360):
    """method "closed" only sees the samples: it must fail exactly where the sampled closed form fails."""
    lengths, crank = variants
    b = simulate_batch(jansen, lengths, crank, 360, method="closed", velocities=False)
    ref, ok, _ = naive.jansen_closed_form(lengths, crank, thetas360)
    sampled_ok = ok.all(axis=1)
    assert 5 <= (~sampled_ok).sum()
    assert list(b.status == 0) == list(sampled_ok)
    assert np.all(b.status[~sampled_ok] == 1)
    np.testing.assert_allclose(b.paths["7"][sampled_ok], ref[sampled_ok][:, :, 6], rtol=0, atol=1e-10)


def check_range_end(lengths, crank, theta_end):
    """The closed form assembles everywhere from θ_end (exclusive, up to the kernel's bracket) to 2π,
    and fails at θ_end or just before it: the other end of the unreachable range."""
    after = np.concatenate([np.linspace(theta_end + 1e-6, 2.0 * np.pi, 3600), theta_end + np.geomspace(1e-3, 1e-6, 50)])
    _, ok, _ = naive.jansen_closed_form(lengths, crank, after)
    assert ok.all(), f"closed form fails at θ = {after[~ok][0]!r} after the reported range end {theta_end!r}"
    _, ok, _ = naive.jansen_closed_form(lengths, crank, np.array([theta_end, theta_end - 1e-7, theta_end - 1e-6]))
    assert not ok.all(), f"closed form assembles just before the reported range end θ = {theta_end!r}"


def unreachable(theta, fail, fail_end):
    """Samples inside the unreachable range [fail, fail_end] (the kernel leaves those NaN)."""
    return (theta >= fail) & (theta <= fail_end)


def check_failure_angle(lengths, crank, theta, vertex):
    """The closed form assembles everywhere before θ (up to the kernel's Δθ/65536 bracket) and fails
    at θ or just after it, the first failing dyad being ``vertex``."""
    before = np.concatenate([np.linspace(0.0, theta - 1e-6, 3600), theta - np.geomspace(1e-3, 1e-6, 50)])
    before = before[before >= 0.0]
    _, ok, _ = naive.jansen_closed_form(lengths, crank, before)
    assert ok.all(), f"closed form fails at θ = {before[~ok][0]!r} before the reported {theta!r}"
    after = np.array([theta, theta + 1e-7, theta + 1e-6])
    _, ok, slack = naive.jansen_closed_form(lengths, crank, after)
    assert not ok.all(), f"closed form assembles just after the reported failure θ = {theta!r}"
    j = int(np.argmin(ok))
    failing = {v for v, s in slack.items() if s[j] < 0.0}  # NaN (a parent missing) is not a failure
    assert vertex in failing, (vertex, failing)


# -- honest failures ------------------------------------------------------------------------------------
def test_crank_too_long_fails_assembly(jansen, jansen_cycle):
    long = jansen.with_lengths(crank=16.2)
    assert naive.jansen_assembly_margin(long.lengths, 16.2)[0] < -AMBIGUOUS  # independent verdict
    for method in ("block", "dense"):
        c = simulate(long, 360, method=method)
        assert not c.ok
        f = c.failure
        assert f.kind == "assembly", f
        assert f.vertex in ("5", "6")
        assert 0.0 <= f.theta < 2.0 * np.pi
        assert jansen.vertices[make_plan(jansen).blocks[f.block].vertices[0]] == f.vertex
        assert "\n" not in f.message and f.vertex in f.message
        check_failure_angle(long.lengths, 16.2, f.theta, f.vertex)
        check_range_end(long.lengths, 16.2, f.theta_end)
        gone = unreachable(c.theta, f.theta, f.theta_end)
        assert 0 < gone.sum() < 360 and "cannot turn through" in f.message
        assert np.isnan(c.positions[gone]).all() and np.isfinite(c.positions[~gone]).all()
        assert np.isnan(c.velocities[gone]).all() and np.isfinite(c.velocities[~gone]).all()
    # ok results carry no NaN
    assert jansen_cycle.ok and np.isfinite(jansen_cycle.positions).all()
    assert np.isfinite(jansen_cycle.velocities).all()


def test_batch_reports_invalid_rows(jansen):
    L = np.tile(jansen.lengths, (3, 1))
    L[1, 4] = -1.0
    L[2, 0] = np.nan
    b = simulate_batch(jansen, L, np.array([15.0, 15.0, 15.0]), 36)
    assert [STATUS_NAMES[int(s)] for s in b.status] == ["ok", "invalid", "invalid"]
    assert np.isfinite(b.paths["7"][0]).all() and np.isnan(b.paths["7"][1:]).all()


# -- other mechanisms -------------------------------------------------------------------------------------
def test_fourbar_solves_and_matches_closed_form(fourbar, thetas360):
    c = simulate(fourbar, 360, tolerance=1e-12)
    assert c.ok and np.isfinite(c.positions).all()
    assert link_errors(fourbar, c.positions).max() <= 1e-9
    ref, ok = naive.sequential_dyads(fourbar, thetas360)
    assert ok.all()
    np.testing.assert_allclose(c.positions, ref, rtol=0, atol=1e-9)
    fd = naive.central_difference(lambda t: naive.sequential_dyads(fourbar, t)[0], thetas360)
    np.testing.assert_allclose(c.velocities, fd, rtol=1e-6, atol=1e-6 * np.abs(fd).max())


@pytest.fixture(scope="module")
def triad_cycle(triad):
    return simulate(triad, 360, tolerance=1e-12)


@pytest.fixture(scope="module")
def triad_reference(triad, thetas360):
    """Naive dense-Newton continuation from the file's guess (plain numpy)."""
    start = np.array([triad.guess.get(v, triad.fixed.get(v, (0.0, 0.0))) for v in triad.vertices])
    start[triad.vertex_index(triad.crank.tip)] = np.add(triad.crank.center, (triad.crank.radius, 0.0))
    P0 = naive.newton_solve(triad, 0.0, start)
    return naive.newton_path(triad, thetas360, P0, substeps=3)


def test_triad_solves_with_lengths_holding(triad, triad_cycle, triad_reference):
    c = triad_cycle
    assert c.ok, c.failure
    assert np.isfinite(c.positions).all()
    assert link_errors(triad, c.positions).max() <= 1e-9
    np.testing.assert_allclose(c.positions, triad_reference, rtol=0, atol=1e-9)
    d = simulate(triad, 360, tolerance=1e-12, method="dense")
    assert d.ok
    np.testing.assert_allclose(d.positions, c.positions, rtol=0, atol=1e-9)
    np.testing.assert_allclose(d.velocities, c.velocities, rtol=0, atol=1e-9)


def test_triad_velocities_match_finite_differences(triad, triad_cycle, thetas360):
    c, h = triad_cycle, 1e-5
    V = c.velocities
    scale = np.abs(V).max()
    assert scale > 0.1  # the triad does move
    for k in range(0, 360, 5):
        th, P = thetas360[k], c.positions[k]
        fd = (naive.newton_solve(triad, th + h, P) - naive.newton_solve(triad, th - h, P)) / (2 * h)
        np.testing.assert_allclose(V[k], fd, rtol=1e-6, atol=1e-6 * scale, err_msg=f"θ_{k}")
        np.testing.assert_allclose(V[k], naive.newton_velocity(triad, P, th), rtol=0, atol=1e-9)


def test_triad_batch_variants_match_naive_newton(triad):
    """±3 % variants of the triad through the batch kernel's general block vs naive continuation."""
    rng = np.random.default_rng(7)
    f = rng.uniform(0.97, 1.03, size=(4, 7))
    lengths, crank, steps = triad.lengths * f[:, :6], triad.crank.radius * f[:, 6], 72
    th = 2 * np.pi * np.arange(steps) / steps
    b = simulate_batch(triad, lengths, crank, steps, vertices=list(triad.vertices), tolerance=1e-12)
    assert np.all(b.status == 0)
    for i in range(4):
        var = triad.with_lengths(dict(zip(triad.link_names, lengths[i])), crank=crank[i])
        start = np.array([var.guess.get(v, var.fixed.get(v, (0.0, 0.0))) for v in var.vertices])
        start[var.vertex_index("A")] = np.add(var.crank.center, (crank[i], 0.0))
        ref = naive.newton_path(var, th, naive.newton_solve(var, 0.0, start), substeps=3)
        got = np.stack([b.paths[v][i] for v in var.vertices], axis=1)
        np.testing.assert_allclose(got, ref, rtol=0, atol=1e-9)


def test_batch_of_grounded_vertices_only(jansen, thetas360):
    b = simulate_batch(jansen, jansen.lengths[None, :], [15.0], 360, vertices=["1", "2"])
    assert b.status[0] == 0
    np.testing.assert_allclose(b.paths["1"][0], 15.0 * np.stack([np.cos(thetas360), np.sin(thetas360)], 1),
                               atol=1e-12)
    assert np.all(b.paths["2"][0] == [-38.0, -7.8])


def test_simulate_argument_errors(jansen):
    from explorer import UserError
    for kwargs in ({"steps": 2}, {"tolerance": 0.0}, {"tolerance": float("nan")}, {"method": "magic"}):
        with pytest.raises(UserError):
            simulate(jansen, **kwargs)
    with pytest.raises(UserError):
        simulate_batch(jansen, np.ones((2, 9)), np.ones(2) * 15)
    with pytest.raises(UserError):
        simulate_batch(jansen, np.tile(jansen.lengths, (2, 1)), np.ones(3) * 15)
    with pytest.raises(UserError):
        simulate_batch(jansen, np.tile(jansen.lengths, (2, 1)), np.ones(2) * 15, vertices=["nope"])
