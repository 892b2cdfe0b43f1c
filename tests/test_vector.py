"""The vectorised closed-form first pass (method "auto" / "vector", ``explorer.kernels._vector``).

Checked against the Newton sweep's results (status, failure angle and block, positions within the
tolerance promise, velocities) on every built-in, and against an independent plain-numpy closed form
with finite-difference velocities (tests/naive.py) on the Jansen leg; and that it really ran (designs
solved with no Newton iteration), that what it flags goes through Newton, and that it refuses what it
cannot do.
"""

from __future__ import annotations

import numpy as np
import pytest

import explorer
from explorer import UserError, simulate, simulate_batch
from explorer.kernels import vector_applies
from explorer.testing import kernels_sweep_template as _sweep_template
from explorer.mechanism import builtin_mechanisms
from naive import JANSEN_VERTICES, jansen_closed_form

TOL = 1e-11


def _variants(mech, n, spread, seed=7):
    rng = np.random.default_rng(seed)
    L = mech.lengths * (1 + rng.uniform(-spread, spread, (n, len(mech.links))))
    r = None if mech.crank is None else mech.crank.radius * (1 + rng.uniform(-spread, spread, n))
    return L, r


def _compare(mech, L, r, steps, tol=TOL):
    """auto against block Newton: the same verdicts and reports, positions within the promise."""
    kw = dict(vertices="all", velocities=True, tolerance=tol)
    a = simulate_batch(mech, L, r, steps, method="auto", **kw)
    b = simulate_batch(mech, L, r, steps, method="block", **kw)
    np.testing.assert_array_equal(a.status, b.status)
    bad = b.status != 0
    np.testing.assert_array_equal(a.fail_block, b.fail_block)
    # Newton's reports in both: where the pass left a design off, the sweep resumes there, and its
    # refinement reaches the failure by other halvings, so the angle is the same point of the refinement's
    # grid (Δθ / 2**REFINE_LEVELS) up to rounding
    grid = (b.theta[1] - b.theta[0]) / 2 ** _sweep_template.REFINE_LEVELS
    np.testing.assert_allclose(a.fail_theta[bad], b.fail_theta[bad], rtol=0, atol=grid / 4)
    np.testing.assert_allclose(a.fail_theta_end[bad], b.fail_theta_end[bad], rtol=0, atol=grid / 4)
    every = np.maximum(L.max(axis=1), 0 if r is None else r)
    for v in mech.vertices:  # a failed design's reachable samples: the same, within the promise
        np.testing.assert_array_equal(np.isnan(a.paths[v][bad]), np.isnan(b.paths[v][bad]))
        err = np.nan_to_num(np.abs(a.paths[v][bad] - b.paths[v][bad])).max(axis=(1, 2), initial=0.0)
        assert (err <= 2 * tol * every[bad]).all(), (v, err.max())
    ok = ~bad
    longest = every[ok]
    for v in mech.vertices:
        err = np.abs(a.paths[v][ok] - b.paths[v][ok]).max(axis=(1, 2))
        # each within tol x longest of the exact root: the two within twice that
        assert (err <= 2 * tol * longest).all(), (v, err.max())
        assert np.isfinite(a.velocities[v][ok]).all()
        dv = np.abs(a.velocities[v][ok] - b.velocities[v][ok]).max(axis=(1, 2))
        scale = np.abs(b.velocities[v][ok]).max(axis=(1, 2)) + longest
        assert (dv <= 1e-7 * scale).all(), (v, dv.max())
    return a, b


@pytest.mark.parametrize("name", builtin_mechanisms())
def test_every_builtin_agrees_with_newton(name):
    mech = explorer.load_mechanism(name)
    L, r = _variants(mech, 60, 0.04)
    L[0] = mech.lengths
    if r is not None:
        r[0] = mech.crank.radius
    a, b = _compare(mech, L, r, 120)
    # where the pass applies it solves the designs with no Newton iteration (it is not a silent fallback)
    if vector_applies(mech):
        assert (a.iterations[a.status == 0] == 0).mean() >= 0.5
    else:
        np.testing.assert_array_equal(a.iterations, b.iterations)


def test_jansen_against_a_plain_numpy_closed_form_and_finite_differences():
    mech = explorer.load_mechanism("jansen")
    L, r = _variants(mech, 300, 0.03, seed=11)
    S = 360
    b = simulate_batch(mech, L, r, S, method="vector", vertices="all", velocities=True)
    solved = (b.status == 0) & (b.iterations == 0)
    assert solved.sum() > 200
    theta = 2 * np.pi * np.arange(S) / S
    ref, ok, _ = jansen_closed_form(L, r, theta)
    assert ok[solved].all()
    longest = np.maximum(L.max(axis=1), r)
    for j, v in enumerate(JANSEN_VERTICES):
        err = np.abs(b.paths[v][solved] - ref[solved][:, :, j]).max(axis=(1, 2))
        assert (err <= TOL * longest[solved]).all(), (v, err.max())
    # velocities: central differences of the numpy closed form, d/dθ per radian
    h = 1e-6
    plus, _, _ = jansen_closed_form(L[solved], r[solved], theta + h)
    minus, _, _ = jansen_closed_form(L[solved], r[solved], theta - h)
    fd = (plus - minus) / (2 * h)
    for j, v in enumerate(JANSEN_VERTICES):
        np.testing.assert_allclose(b.velocities[v][solved], fd[:, :, j], rtol=0, atol=1e-6 * longest.max())


def test_failures_are_newtons_reports():
    """±6 %: many designs cannot assemble; every one of them went through Newton (iterations > 0 or a
    failure at the start), and auto reports exactly what block Newton reports."""
    mech = explorer.load_mechanism("jansen")
    L, r = _variants(mech, 200, 0.06, seed=3)
    a, b = _compare(mech, L, r, 90)
    assert (a.status != 0).sum() > 20
    assert (a.status[a.iterations == 0] == 0).sum() > 20


def test_single_design_and_path_driver():
    for name in ("jansen", "slidercrank"):
        mech = explorer.load_mechanism(name)
        c = simulate(mech, 90, method="auto")
        n = simulate(mech, 90, method="block")
        assert c.ok == n.ok
        np.testing.assert_allclose(c.positions, n.positions, rtol=0, atol=2 * TOL * mech.lengths.max())
        np.testing.assert_allclose(c.velocities, n.velocities, rtol=0, atol=1e-7 * mech.lengths.max())


def test_auto_falls_back_where_the_pass_does_not_apply_and_vector_refuses():
    mech = explorer.load_mechanism("jansen")
    L, r = _variants(mech, 8, 0.02)
    acc = simulate_batch(mech, L, r, 36, method="auto", accelerations=True)
    ref = simulate_batch(mech, L, r, 36, method="block", accelerations=True)
    np.testing.assert_array_equal(acc.paths["7"], ref.paths["7"])  # Newton ran: the same bits
    assert (acc.iterations > 0).all()
    with pytest.raises(UserError, match="method 'vector'"):
        simulate_batch(mech, L, r, 36, method="vector", accelerations=True)


def test_flagged_near_a_fold_goes_to_newton():
    """A design whose dyad passes within the fold margin: the pass flags it, Newton solves it."""
    from explorer.kinds.dyad import VECTOR_FOLD, dyad_vector

    S = 64
    X = np.zeros((3, S))
    Y = np.zeros((3, S))
    VX = np.zeros((3, S))
    VY = np.zeros((3, S))
    X[1] = 2.0 - 1e-5 * (1 + np.cos(2 * np.pi * np.arange(S) / S))  # parents' distance almost 2 = da + db
    VX[1] = 1e-5 * np.sin(2 * np.pi * np.arange(S) / S) * 2 * np.pi / S
    Q, M = np.empty(S), np.empty(S)
    h = 2 * np.pi / S
    assert dyad_vector(2, 0, 1, 1.0, 1.0, 4.0, 0.0, 1.0, True, 1.0, X, Y, VX, VY, Q, M, h, True)
    X[1] = 1.0  # far from the fold (the angle at the vertex is 120°): not flagged
    VX[1] = 0.0
    assert not dyad_vector(2, 0, 1, 1.0, 1.0, 4.0, 0.0, 1.0, True, 1.0, X, Y, VX, VY, Q, M, h, True)
    np.testing.assert_allclose(X[2], 0.5)
    np.testing.assert_allclose(Y[2], np.sqrt(0.75))
    assert VECTOR_FOLD > 0


def test_a_design_that_cannot_assemble_is_resumed_and_reported_as_by_newton():
    """The four-bar's rocker joint B hangs from the crank tip A and the pivot B0 by the coupler and the
    rocker: where the tip is further from the pivot than coupler + rocker the linkage cannot assemble.
    With coupler + rocker a little under the tip's furthest distance, the range of θ it cannot turn
    through has a closed form (written here in numpy): |A − B0|² = r² + |p|² − 2 r |p| cos(θ − α), α the
    pivot's direction, exceeds (coupler + rocker)² for |θ − α − π| < π − arccos C. method "auto" leaves
    these designs to Newton, which resumes where the first pass left off (far fewer iterations than the
    whole sweep) and reports what block Newton reports: status, block, and both ends of the range, at
    the closed form's angles to within the refinement's step Δθ / 2**16."""
    mech = explorer.load_mechanism("fourbar")
    names = list(mech.link_names)
    n = 6
    L = np.tile(mech.lengths, (n, 1))
    L[:, names.index("coupler")] = 25.0
    L[:, names.index("rocker")] = np.linspace(14.2, 14.8, n)
    r = np.full(n, mech.crank.radius)
    steps = 360
    a = simulate_batch(mech, L, r, steps, method="auto", vertices="all", velocities=True)
    b = simulate_batch(mech, L, r, steps, method="block", vertices="all", velocities=True)
    # the closed form of the unreachable range
    cx, cy = mech.crank.center
    px, py = np.subtract(mech.fixed["B0"], (cx, cy))
    p = np.hypot(px, py)
    alpha = np.arctan2(py, px) % (2 * np.pi)
    s = L[:, names.index("coupler")] + L[:, names.index("rocker")]
    C = (r ** 2 + p ** 2 - s ** 2) / (2 * r * p)
    assert (np.abs(C) < 1).all()  # every design fails over part of the turn, and no design everywhere
    start, end = alpha + np.arccos(C), alpha + 2 * np.pi - np.arccos(C)
    assert (start > 0).all() and (end < 2 * np.pi).all()
    grid = 2 * np.pi / steps / 2 ** _sweep_template.REFINE_LEVELS
    for res in (a, b):
        assert (res.status == 1).all()  # "assembly"
        block = res.fail_block[0]
        assert (res.fail_block == block).all()
        assert mech.vertices[explorer.kernels.plan_for(mech).blocks[block].vertices[0]] == "B"
        # the first angle that fails going forward lies past the range's start by less than a refinement
        # step, and the first going backward before its end
        assert ((res.fail_theta - start >= 0) & (res.fail_theta - start <= 1.5 * grid)).all(), res.fail_theta - start
        assert ((end - res.fail_theta_end >= 0) & (end - res.fail_theta_end <= 1.5 * grid)).all()
        inside = (res.theta[None, :] > start[:, None]) & (res.theta[None, :] < end[:, None])
        np.testing.assert_array_equal(np.isnan(res.paths["B"][..., 0]), inside)
    np.testing.assert_allclose(a.fail_theta, b.fail_theta, rtol=0, atol=grid / 4)
    np.testing.assert_allclose(a.fail_theta_end, b.fail_theta_end, rtol=0, atol=grid / 4)
    for v in mech.vertices:
        np.testing.assert_allclose(a.paths[v], b.paths[v], rtol=0, atol=2 * TOL * L.max())
    assert a.iterations.sum() < 0.3 * b.iterations.sum(), (a.iterations, b.iterations)


def test_a_resumed_configuration_that_does_not_solve_falls_back_to_the_whole_sweep(monkeypatch):
    """Where Newton cannot solve the configuration it is to resume from (here spoiled to NaN on its way
    to the sweep), the sweep goes the whole way from sample 0: the flagged designs' results are then
    block Newton's bit for bit, and their iterations more than block Newton's (the failed resumes')."""
    from explorer.testing import kernels_simulate

    newton = kernels_simulate._newton

    def spoiled(topo, kdrv, sg, des, *args):
        assert (des.restart_at[:, 0] > 0).all()  # every flagged design here has a run to resume after
        des.restart_pos[:] = np.nan
        return newton(topo, kdrv, sg, des, *args)

    monkeypatch.setattr(kernels_simulate, "_newton", spoiled)
    mech = explorer.load_mechanism("fourbar")
    L = np.tile(mech.lengths, (3, 1))
    L[:, list(mech.link_names).index("coupler")] = 25.0
    L[:, list(mech.link_names).index("rocker")] = [14.2, 14.5, 14.8]
    kw = dict(vertices="all", velocities=True)
    a = simulate_batch(mech, L, None, 120, method="auto", **kw)
    monkeypatch.setattr(kernels_simulate, "_newton", newton)
    b = simulate_batch(mech, L, None, 120, method="block", **kw)
    assert (b.status == 1).all()
    for x, y in ((a.status, b.status), (a.fail_block, b.fail_block), (a.fail_theta, b.fail_theta),
                 (a.fail_theta_end, b.fail_theta_end), *((a.paths[v], b.paths[v]) for v in mech.vertices),
                 *((a.velocities[v], b.velocities[v]) for v in mech.vertices)):
        np.testing.assert_array_equal(x, y)
    assert (a.iterations > b.iterations).all()
