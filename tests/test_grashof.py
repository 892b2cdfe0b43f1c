"""Grashof classification of crank-driven four-bar loops, against a brute-force rotatability rule.

The reference (``naive_mech.grashof_brute``) does not use the (p + q) − (s + l) rule: it samples
the relative angle of each pair of adjacent links and asks whether the loop still closes, so
"crank-rocker" means "the crank turns fully against the ground and the rocker does not", etc.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import HealthCheck, assume, event, example, given, settings
from hypothesis import strategies as st

import naive_mech as nm
from explorer import Grashof, UserError, grashof, load_mechanism, simulate, simulate_batch
from explorer.mechanism import mechanism_from_dict
from explorer.plan import classify, grashof_batch

KINDS = {"crank-rocker", "double-crank", "rocker-crank", "double-rocker", "triple-rocker", "change-point"}


def bare_fourbar(crank, coupler, rocker, ground, sigma=-1, assembles=True):
    """A four-bar table with the rocker pivot at (ground, 0), assembled in mode σ at θ = 0."""
    return mechanism_from_dict(nm.fourbar_dict(crank, coupler, rocker, (ground, 0.0), sigma, assembles=assembles),
                               "bare")


def test_builtin_fourbar_is_crank_rocker(fourbar):
    g = grashof(fourbar)
    assert isinstance(g, Grashof)
    assert g.kind == "crank-rocker"
    assert g.margin == 15.0
    assert g.vertex == "B"
    assert g.lengths == (10.0, 30.0, 25.0, 30.0)
    assert nm.grashof_brute(*g.lengths) == "crank-rocker"
    assert grashof(fourbar, vertex="B") == g


def test_jansen_limiting_loop_is_vertex_6(jansen):
    g = grashof(jansen)
    # crank tip 1, loop joint 6 (links 1-6 = 61.9, 2-6 = 39.3), ground |(−38, −7.8)| from the crank centre
    ground = math.hypot(-38.0, -7.8)
    assert g.vertex == "6"
    assert g.lengths == pytest.approx((15.0, 61.9, 39.3, ground), abs=1e-12)
    assert g.margin == pytest.approx((39.3 + ground) - (15.0 + 61.9), abs=1e-12)
    assert g.margin == pytest.approx(1.19, abs=0.005)
    assert g.kind == "crank-rocker" == nm.grashof_brute(*g.lengths)
    # the other loop, closing at vertex 3 (links 1-3 = 50, 2-3 = 41.5), has the larger margin
    g3 = grashof(jansen, vertex="3")
    assert g3.vertex == "3" and g3.kind == "crank-rocker"
    assert g3.margin == pytest.approx((41.5 + ground) - (15.0 + 50.0), abs=1e-12)
    assert g3.margin > g.margin


# crank, coupler, rocker, ground -> expected class (by construction; the brute force confirms it)
CLASSES = {
    "crank-rocker": (10.0, 30.0, 25.0, 30.0),  # crank shortest
    "double-crank": (40.0, 45.0, 42.0, 30.0),  # ground shortest
    "rocker-crank": (20.0, 30.0, 12.0, 30.0),  # rocker shortest
    "double-rocker": (25.0, 10.0, 28.0, 30.0),  # coupler shortest
    "triple-rocker": (40.0, 30.0, 25.0, 30.0),  # s + l > p + q
    "change-point": (25.0, 30.0, 25.0, 30.0),  # s + l = p + q
}


@pytest.mark.parametrize("kind", sorted(CLASSES))
def test_each_class_by_choice_of_lengths(fourbar, kind):
    crank, coupler, rocker, ground = CLASSES[kind]
    margin = nm.grashof_margin(crank, coupler, rocker, ground)
    if kind == "change-point":
        assert margin == 0.0
    else:
        assert nm.grashof_brute(crank, coupler, rocker, ground) == kind
    # the built-in (ground 30) through with_lengths, and a bare four-bar table
    mechs = [bare_fourbar(crank, coupler, rocker, ground, assembles=False)]
    if ground == 30.0:
        mechs.append(fourbar.with_lengths({"coupler": coupler, "rocker": rocker}, crank=crank))
    for mech in mechs:
        g = grashof(mech)
        assert g.kind == kind
        assert g.margin == pytest.approx(margin, abs=1e-12)
        assert g.lengths == pytest.approx((crank, coupler, rocker, ground), abs=1e-12)
    kinds, margins = classify(crank, coupler, rocker, ground)
    assert kinds[()] == kind and margins[()] == pytest.approx(margin, abs=1e-12)


def test_classify_is_vectorised():
    rows = np.array(list(CLASSES.values()))
    kinds, margins = classify(*rows.T)
    assert list(kinds) == list(CLASSES)
    np.testing.assert_allclose(margins, [nm.grashof_margin(*r) for r in rows], rtol=0, atol=1e-12)


def test_change_point_is_reported_up_to_rounding():
    # 0.1 + 0.2 ≠ 0.3 in floating point; a change point written with such numbers is still one
    kinds, margins = classify(0.1, 0.2, 0.3, 0.4)
    assert abs(margins[()]) < 1e-15 and kinds[()] == "change-point"


def test_mechanism_without_a_crank_loop_raises():
    with pytest.raises(UserError, match="arm"):
        grashof(load_mechanism("arm"))
    with pytest.raises(UserError, match="four-bar"):
        grashof(load_mechanism("fourbar"), vertex="P")  # P is on the coupler, not a loop joint


def test_grashof_batch_agrees_with_grashof(fourbar, jansen):
    rng = np.random.default_rng(8)
    for mech, n in ((fourbar, 24), (jansen, 16)):
        L = mech.lengths * rng.uniform(0.6, 1.4, (n, len(mech.links)))
        crank = mech.crank.radius * rng.uniform(0.5, 3.0, n)
        kinds, margins = grashof_batch(mech, L, crank)
        assert kinds.shape == margins.shape == (n,)
        seen = set()
        for i in range(n):
            g = grashof(mech.with_lengths(dict(zip(mech.link_names, L[i])), crank=crank[i]))
            assert kinds[i] == g.kind
            assert margins[i] == pytest.approx(g.margin, abs=1e-12)
            seen.add(g.kind)
        assert len(seen) >= 2  # the batch crosses the Grashof limit


# -- property: Grashof verdict vs brute force, and vs what the solver does over a full turn -----------------
lengths = st.floats(5.0, 50.0, allow_nan=False, allow_infinity=False)


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow, HealthCheck.filter_too_much])
@given(crank=lengths, coupler=lengths, rocker=lengths, ground=lengths)
def test_classification_matches_brute_force(crank, coupler, rocker, ground):
    margin = nm.grashof_margin(crank, coupler, rocker, ground)
    assume(abs(margin) > 1e-3 * max(crank, coupler, rocker, ground))
    kinds, margins = classify(crank, coupler, rocker, ground)
    assert margins[()] == pytest.approx(margin, abs=1e-12)
    assert kinds[()] == nm.grashof_brute(crank, coupler, rocker, ground)


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow, HealthCheck.filter_too_much])
@given(crank=st.floats(4.0, 35.0), coupler=st.floats(10.0, 45.0), rocker=st.floats(10.0, 45.0),
       ground=st.floats(15.0, 40.0), sigma=st.sampled_from([-1, 1]))
# found by hypothesis: θ4 = π exactly at a sample (the reference's half-angle formula is 0/0 there), and a
# sample on the fold itself (the joint fixed only to sqrt(rounding) there, for every method)
@pytest.mark.slow
@example(crank=10.0, coupler=10.0, rocker=30.0, ground=40.0, sigma=-1)
@example(crank=9.0, coupler=10.0, rocker=31.0, ground=40.0, sigma=-1)
def test_crank_rockers_turn_and_triple_rockers_fail(crank, coupler, rocker, ground, sigma):
    """Every Grashof crank-rocker (or double-crank) solves ok over the full turn, matching the closed
    form; every triple-rocker (or other class whose crank cannot turn) fails with kind "assembly" at
    the analytic limits, matching the closed form where it is reachable."""
    margin = nm.grashof_margin(crank, coupler, rocker, ground)
    lim = 0.02 * max(crank, coupler, rocker, ground)  # keep away from change points (folds everywhere)
    assume(abs(margin) > lim)
    # the design must assemble at θ = 0 (|A − B0| = |ground − crank|), with room
    d0 = abs(ground - crank)
    assume(abs(coupler - rocker) + lim < d0 < coupler + rocker - lim)
    mech = bare_fourbar(crank, coupler, rocker, ground, sigma)
    kind = grashof(mech).kind
    assert kind == nm.grashof_brute(crank, coupler, rocker, ground)
    event(kind)
    c = simulate(mech, 120, tolerance=1e-12, velocities=False)
    ref = nm.fourbar_closed_form(c.theta, crank, coupler, rocker, (ground, 0.0), sigma)["B"]
    reach = np.isfinite(ref[:, 0])
    # within ~1e-6 of a fold the joint is fixed only to ~sqrt(rounding) of the lengths, for both
    near_fold = nm.fold_margin(c.theta, crank, coupler, rocker, (ground, 0.0)) < 1e-6
    atol = np.where(near_fold, 1e-5 * ground, 1e-8 * ground)[:, None]
    assert (np.abs(c.path("B") - ref)[reach] <= np.broadcast_to(atol, ref.shape)[reach]).all()
    if kind in ("crank-rocker", "double-crank"):  # the crank turns fully against the ground
        assert c.ok, c.failure
    else:
        assert not c.ok and c.failure.kind == "assembly", c.failure
        limits = nm.fourbar_limit_angles(crank, coupler, rocker, (ground, 0.0))
        fwd, back = limits[0], limits[-1]
        assert c.failure.theta == pytest.approx(fwd, abs=1e-5)
        assert c.failure.theta_end == pytest.approx(back, abs=1e-5)
        assert np.isnan(c.path("B")[~reach]).all()


@pytest.mark.slow
def test_random_batch_crank_rockers_ok_triple_rockers_assembly(fourbar):
    """A random batch on the built-in topology (ground 30): status ok exactly for the variants whose
    crank turns fully by the brute-force rule, "assembly" (1) for the others, at the analytic limits."""
    rng = np.random.default_rng(2024)
    rows = []
    while len(rows) < 40:
        crank, coupler, rocker = rng.uniform(4.0, 28.0), rng.uniform(10.0, 45.0), rng.uniform(10.0, 45.0)
        lim = 0.02 * max(crank, coupler, rocker, 30.0)
        d0 = 30.0 - crank  # |A − B0| at θ = 0: the crank tip stays left of B0, so every row is mode σ = +1
        if abs(nm.grashof_margin(crank, coupler, rocker, 30.0)) > lim and abs(coupler - rocker) + lim < d0 < coupler + rocker - lim:
            rows.append((crank, coupler, rocker))
    rows = np.array(rows)
    L = np.tile(fourbar.lengths, (len(rows), 1))
    L[:, fourbar.link_index("coupler")] = rows[:, 1]
    L[:, fourbar.link_index("rocker")] = rows[:, 2]
    b = simulate_batch(fourbar, L, rows[:, 0], 120, vertices=["B"], tolerance=1e-12, velocities=False)
    kinds, _ = grashof_batch(fourbar, L, rows[:, 0])
    turns = np.array([nm.grashof_brute(*r, 30.0) in ("crank-rocker", "double-crank") for r in rows])
    assert 5 <= turns.sum() <= len(rows) - 5
    assert list(kinds == "triple-rocker") == [nm.grashof_brute(*r, 30.0) == "triple-rocker" for r in rows]
    assert list(b.status) == [0 if t else 1 for t in turns]
    for i, r in enumerate(rows):
        ref = nm.fourbar_closed_form(b.theta, *r, (30.0, 0.0), +1)["B"]  # the built-in's mode
        reach = np.isfinite(ref[:, 0])
        np.testing.assert_allclose(b.paths["B"][i][reach], ref[reach], rtol=0, atol=1e-8)
        assert np.isnan(b.paths["B"][i][~reach]).all()
        if not turns[i]:
            limits = nm.fourbar_limit_angles(*r, (30.0, 0.0))
            assert b.fail_theta[i] == pytest.approx(limits[0], abs=1e-5)
            assert b.fail_theta_end[i] == pytest.approx(limits[-1], abs=1e-5)
