"""The four-bar against seed 004's Freudenstein half-angle closed form, both assembly modes.

References are in ``naive_mech`` (plain numpy, no explorer): the closed form θ4 = 2·atan2(−B ± √(A² +
B² − C²), C − A), the coupler point from the rigid coupler triangle, and the analytic limit angles of
a non-Grashof loop (where |A − B0| reaches coupler + rocker or |coupler − rocker|).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import naive_mech as nm
from explorer import simulate, simulate_batch
from explorer.mechanism import mechanism_from_dict

TWO_PI = 2.0 * np.pi
STEPS = 360
#: the kernel locates a failure to within Δθ / 65536 (≈ 2.7e-7 rad at 360 steps)
LIMIT_ATOL = 1e-6


def builtin_mode(sigma: int, point_side: int = +1):
    """The built-in four-bar with its B guess on the side of assembly mode σ (σ = +1: the file's own
    guess, coupler below the ground line; σ = −1: mirrored) and the coupler point P on ``point_side``
    of A→B (−1: the file's rigid coupler triangle, hanging below like a leg; +1: its mirror image)."""
    d = nm.builtin_dict("fourbar")
    ref = nm.fourbar_closed_form(np.zeros(1), 10.0, 30.0, 25.0, (30.0, 0.0), sigma, (25.0, 20.0, point_side))
    # keep the file's rough guesses, only moved to the other side where asked
    bx, by = d["guess"]["B"]
    d["guess"]["B"] = [bx, math.copysign(by, ref["B"][0, 1])]
    d["guess"]["P"] = [round(float(c)) for c in ref["P"][0]]
    return mechanism_from_dict(d, f"fourbar(sigma={sigma}, P side {point_side})")


def check_against_closed_form(cycle, crank, coupler, rocker, ground, sigma, point, atol=1e-9):
    ref = nm.fourbar_closed_form(cycle.theta, crank, coupler, rocker, ground, sigma, point)
    assert np.isfinite(ref["B"]).all()
    for v, xy in ref.items():
        np.testing.assert_allclose(cycle.path(v), xy, rtol=0, atol=atol, err_msg=f"vertex {v}")
    np.testing.assert_array_equal(cycle.path("B0"), np.tile(ground, (len(cycle.theta), 1)))
    return ref


# -- the built-in four-bar ---------------------------------------------------------------------------------
def test_builtin_fourbar_numbers(fourbar):
    assert fourbar.crank.center == (0.0, 0.0) and fourbar.crank.radius == 10.0 and fourbar.crank.tip == "A"
    assert dict(fourbar.fixed) == {"B0": (30.0, 0.0)}
    assert {l.name: (l.a, l.b, l.length) for l in fourbar.links} == {
        "coupler": ("A", "B", 30.0), "rocker": ("B0", "B", 25.0), "A-P": ("A", "P", 25.0), "B-P": ("B", "P", 20.0)}
    # the file's guess is assembly mode σ = +1 of seed 004's formula (B below the ground line)
    # (the guess is rough: it only has to be nearer to that mode's joint than to the other's)
    dist = {sigma: np.hypot(*(nm.fourbar_closed_form(np.zeros(1), 10.0, 30.0, 25.0, (30.0, 0.0), sigma)["B"][0]
                              - fourbar.guess["B"])) for sigma in (-1, +1)}
    assert dist[+1] < 5.0 < 40.0 < dist[-1]
    # and its coupler point hangs below the coupler, below the crank axle, like a leg's foot
    c = simulate(fourbar, 72, tolerance=1e-12)
    check_against_closed_form(c, 10.0, 30.0, 25.0, (30.0, 0.0), +1, (25.0, 20.0, -1))
    assert c.path("P")[:, 1].max() < 0.0


VARIANTS = [
    ({}, None),
    ({"coupler": 28.0, "rocker": 27.0}, 11.0),
    ({"coupler": 33.0, "rocker": 22.0, "A-P": 22.0, "B-P": 18.0}, 8.0),
]


@pytest.mark.parametrize("method", ["block", "dense", "closed", "auto"])
@pytest.mark.parametrize("sigma,point_side", [(-1, +1), (+1, +1), (+1, -1)])
@pytest.mark.parametrize("variant", range(len(VARIANTS)))
def test_builtin_and_variants_match_freudenstein(sigma, point_side, variant, method):
    lengths, crank = VARIANTS[variant]
    mech = builtin_mode(sigma, point_side).with_lengths(lengths, crank=crank)
    L = {l.name: l.length for l in mech.links}
    c = simulate(mech, STEPS, tolerance=1e-12, method=method, velocities=method != "closed")
    assert c.ok, c.failure
    np.testing.assert_allclose(c.theta, TWO_PI * np.arange(STEPS) / STEPS, rtol=0, atol=1e-15)
    check_against_closed_form(c, mech.crank.radius, L["coupler"], L["rocker"], (30.0, 0.0), sigma,
                              (L["A-P"], L["B-P"], point_side))


def test_file_guess_is_one_mode_and_mirror_the_other(fourbar):
    """The two modes are different motions (not the same one relabelled): B mirrored at θ = 0 only."""
    down = simulate(fourbar, 72, tolerance=1e-12)
    up = simulate(builtin_mode(-1, +1), 72, tolerance=1e-12)
    assert up.ok and down.ok
    np.testing.assert_allclose(down.path("B")[0] * [1, -1], up.path("B")[0], atol=1e-12)
    assert np.abs(up.path("B") - down.path("B")).max() > 10.0
    # the file's mode keeps B below the line A0-B0 at θ = 0 and is the same as σ = +1 everywhere
    check_against_closed_form(down, 10.0, 30.0, 25.0, (30.0, 0.0), +1, (25.0, 20.0, -1))


# -- other four-bars, written as mechanism tables -----------------------------------------------------------
FOURBARS = {
    # ground tilted (pivot at angle 36.87° like seed 004's θ1 ≠ 0), crank-rocker
    "tilted": (8.0, 35.0, 20.0, (24.0, 18.0), (20.0, 28.0, -1)),
    # ground shortest: a double-crank (drag link) turns fully too
    "drag-link": (20.0, 28.0, 24.0, (12.0 * math.cos(2.0), 12.0 * math.sin(2.0)), (15.0, 20.0, +1)),
    # a nearly change-point crank-rocker: small transmission angles
    "tight": (10.0, 30.0, 20.5, (30.0, 0.0), None),
}


@pytest.mark.parametrize("method", ["block", "dense", "closed", "auto"])
@pytest.mark.parametrize("sigma", [-1, +1])
@pytest.mark.parametrize("name", sorted(FOURBARS))
def test_other_fourbars_match_freudenstein(name, sigma, method):
    crank, coupler, rocker, ground, point = FOURBARS[name]
    assert nm.grashof_brute(crank, coupler, rocker, math.hypot(*ground)) in ("crank-rocker", "double-crank")
    mech = mechanism_from_dict(nm.fourbar_dict(crank, coupler, rocker, ground, sigma, point), name)
    c = simulate(mech, STEPS, tolerance=1e-12, method=method, velocities=method != "closed")
    assert c.ok, c.failure
    check_against_closed_form(c, crank, coupler, rocker, ground, sigma, point)


@pytest.mark.parametrize("sigma", [-1, +1])
def test_velocities_and_accelerations_match_closed_form_derivatives(sigma):
    crank, coupler, rocker, ground, point = FOURBARS["tilted"]
    mech = mechanism_from_dict(nm.fourbar_dict(crank, coupler, rocker, ground, sigma, point), "tilted")
    c = simulate(mech, 180, tolerance=1e-12, accelerations=True)
    assert c.ok
    for v in ("A", "B", "P"):
        f = lambda t: nm.fourbar_closed_form(t, crank, coupler, rocker, ground, sigma, point)[v]  # noqa: E731
        fd = nm.central_difference(f, c.theta, h=1e-5)
        np.testing.assert_allclose(c.velocity(v), fd, rtol=0, atol=1e-6 * np.abs(fd).max(), err_msg=v)
        fd2 = (f(c.theta + 1e-4) - 2 * f(c.theta) + f(c.theta - 1e-4)) / 1e-8
        acc = c.accelerations[:, mech.vertex_index(v)]
        np.testing.assert_allclose(acc, fd2, rtol=0, atol=1e-5 * np.abs(fd2).max(), err_msg=v)


# -- non-Grashof four-bars: an assembly failure with the reachable range, NaN outside ---------------------------
R210 = math.radians(210.0)
NON_GRASHOF = {
    # the built-in with its crank lengthened to 40: s + l = 25 + 40 > p + q = 30 + 30
    "long-crank": (40.0, 30.0, 25.0, (30.0, 0.0), (25.0, 20.0, +1)),
    # crank 22, coupler 20: s + l = 20 + 30 > p + q = 22 + 25
    "short-coupler": (22.0, 20.0, 25.0, (30.0, 0.0), (25.0, 20.0, +1)),
    # seed 004's own four-bar (ground 4 at θ1, input 2, coupler 3, follower 6, coupler point 4 at
    # 30° from the coupler), turned by 180° (θ1 = 210°) so that θ = 0 is in its reachable range
    "seed-004": (2.0, 3.0, 6.0, (4.0 * math.cos(R210), 4.0 * math.sin(R210)),
                 (4.0, math.sqrt(3.0 ** 2 + 4.0 ** 2 - 2 * 3.0 * 4.0 * math.cos(math.radians(30.0))), +1)),
    # ground pivot behind the crank centre: the reachable range ends where |A − B0| = |coupler − rocker|
    "inner-limit": (10.0, 44.0, 20.0, (-30.0, 0.0), None),
}


def reachable_range(crank, coupler, rocker, ground):
    """The analytic limits (forward from θ = 0, and backward as an angle in (0, 2π))."""
    lims = nm.fourbar_limit_angles(crank, coupler, rocker, ground)
    assert len(lims) >= 2
    return lims[0], lims[-1]


@pytest.mark.parametrize("method", ["block", "dense", "auto"])
@pytest.mark.parametrize("sigma", [-1, +1])
@pytest.mark.parametrize("name", sorted(NON_GRASHOF))
def test_non_grashof_reports_assembly_and_reachable_range(name, sigma, method):
    crank, coupler, rocker, ground, point = NON_GRASHOF[name]
    assert nm.grashof_margin(crank, coupler, rocker, math.hypot(*ground)) < 0  # independent verdict
    mech = mechanism_from_dict(nm.fourbar_dict(crank, coupler, rocker, ground, sigma, point), name)
    c = simulate(mech, STEPS, tolerance=1e-12, method=method)
    assert not c.ok
    f = c.failure
    assert f.kind == "assembly", f
    assert f.vertex == "B"
    fwd, back = reachable_range(crank, coupler, rocker, ground)
    assert f.theta == pytest.approx(fwd, abs=LIMIT_ATOL)
    assert f.theta_end is not None and f.theta_end == pytest.approx(back, abs=LIMIT_ATOL)
    # the failure is reported past the limit, not before it (the closed form still closes before it)
    assert f.theta >= fwd - 1e-9 and f.theta_end <= back + 1e-9
    assert "\n" not in f.message
    # reachable samples: [theta_end − 2π, theta] around θ = 0 (θ_k ≥ theta_end stand for θ_k − 2π)
    inside = (c.theta < f.theta) | (c.theta > f.theta_end)
    assert inside[0] and not inside.all() and inside.sum() > 10
    assert np.isfinite(c.positions[inside]).all()
    assert np.isnan(c.positions[~inside]).all()
    assert np.isfinite(c.velocities[inside]).all() and np.isnan(c.velocities[~inside]).all()
    ref = nm.fourbar_closed_form(c.theta, crank, coupler, rocker, ground, sigma, point)
    # the closed form agrees on the reachable set: it has no solution exactly on the NaN samples
    assert np.array_equal(np.isfinite(ref["B"][:, 0]), inside)
    for v, xy in ref.items():
        np.testing.assert_allclose(c.path(v)[inside], xy[inside], rtol=0, atol=1e-9, err_msg=v)


def test_closed_method_reports_the_reachable_range():
    crank, coupler, rocker, ground, point = NON_GRASHOF["long-crank"]
    mech = mechanism_from_dict(nm.fourbar_dict(crank, coupler, rocker, ground, -1, point), "long-crank")
    c = simulate(mech, STEPS, method="closed", velocities=False)
    assert c.failure is not None and c.failure.kind == "assembly"
    ref = nm.fourbar_closed_form(c.theta, crank, coupler, rocker, ground, -1, point)
    reach = np.isfinite(ref["B"][:, 0])
    for v, xy in ref.items():  # the closed form's own reachable samples, both sides of θ = 0
        np.testing.assert_allclose(c.path(v)[reach], xy[reach], rtol=0, atol=1e-9, err_msg=v)
    assert np.isnan(c.positions[~reach]).all()
    fwd, back = reachable_range(crank, coupler, rocker, ground)
    assert c.failure.theta == pytest.approx(fwd, abs=LIMIT_ATOL)
    assert c.failure.theta_end is not None and c.failure.theta_end == pytest.approx(back, abs=LIMIT_ATOL)


@pytest.mark.slow
def test_non_grashof_batch_reports_the_same_range(fourbar):
    """simulate_batch on the built-in topology: Grashof rows ok and equal to the closed form,
    triple-rocker rows fail with kind assembly and the analytic reachable range.

    (The crank tips stay left of the rocker pivot at θ = 0, so every row's mode σ = +1 is the
    nominal's branch; a variant whose crank tip starts beyond B0 is the other orientation of the
    triangle A-B0-B, which the batch flags "branch" by contract.)
    """
    rows = [(10.0, 30.0, 25.0), (22.0, 20.0, 25.0), (12.0, 30.0, 25.0), (25.0, 22.0, 20.0)]
    crank = np.array([r[0] for r in rows])
    L = np.tile(fourbar.lengths, (len(rows), 1))
    L[:, fourbar.link_index("coupler")] = [r[1] for r in rows]
    L[:, fourbar.link_index("rocker")] = [r[2] for r in rows]
    b = simulate_batch(fourbar, L, crank, STEPS, vertices=["B"], tolerance=1e-12)
    expect_ok = [nm.grashof_margin(*r, 30.0) > 0 for r in rows]
    assert expect_ok == [True, False, True, False]
    assert list(b.status) == [0 if ok else 1 for ok in expect_ok]
    for i, (r, ok) in enumerate(zip(rows, expect_ok)):
        ref = nm.fourbar_closed_form(b.theta, *r, (30.0, 0.0), +1)["B"]
        reach = np.isfinite(ref[:, 0])
        np.testing.assert_allclose(b.paths["B"][i][reach], ref[reach], rtol=0, atol=1e-9)
        assert np.isnan(b.paths["B"][i][~reach]).all()
        if ok:
            assert reach.all() and np.isnan(b.fail_theta[i]) and np.isnan(b.fail_theta_end[i])
        else:
            fwd, back = reachable_range(*r, (30.0, 0.0))
            assert b.fail_theta[i] == pytest.approx(fwd, abs=LIMIT_ATOL)
            assert b.fail_theta_end[i] == pytest.approx(back, abs=LIMIT_ATOL)


@pytest.mark.parametrize("steps", [12, 37])
def test_non_grashof_limits_found_with_coarse_steps(steps):
    """With few samples the limits are still located to within Δθ / 65536 of the analytic angles."""
    crank, coupler, rocker, ground, point = NON_GRASHOF["seed-004"]
    mech = mechanism_from_dict(nm.fourbar_dict(crank, coupler, rocker, ground, +1, point), "seed-004")
    c = simulate(mech, steps, tolerance=1e-12)
    fwd, back = reachable_range(crank, coupler, rocker, ground)
    tol = 2.0 * (TWO_PI / steps) / 65536
    assert c.failure.kind == "assembly"
    assert fwd - 1e-9 <= c.failure.theta <= fwd + tol
    assert back - tol <= c.failure.theta_end <= back + 1e-9
    inside = (c.theta < c.failure.theta) | (c.theta > c.failure.theta_end)
    assert np.isfinite(c.positions[inside]).all() and np.isnan(c.positions[~inside]).all()


def test_not_assemblable_at_theta_zero_fails_there():
    """Seed 004's four-bar as printed (θ1 = 30°) cannot close at θ = 0 (|A − B0| = 2.48 < 6 − 3): the
    cycle starts there, so it is an assembly failure at θ = 0 with every sample NaN, never a crash."""
    ground = (4.0 * math.cos(math.radians(30.0)), 4.0 * math.sin(math.radians(30.0)))
    assert not np.isfinite(nm.fourbar_closed_form(np.zeros(1), 2.0, 3.0, 6.0, ground, +1)["B"]).any()
    mech = mechanism_from_dict(nm.fourbar_dict(2.0, 3.0, 6.0, ground, +1, assembles=False), "seed-004-as-printed")
    for method in ("block", "dense"):
        c = simulate(mech, 36, method=method)
        assert not c.ok and c.failure.kind == "assembly" and c.failure.theta == 0.0 and c.failure.vertex == "B"
        assert np.isnan(c.positions).all()
