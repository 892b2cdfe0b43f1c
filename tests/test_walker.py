"""The walker scene's metrics against independent references written plainly in the tests.

* an analytic walker: a circular foot path with two legs half a turn apart, every metric in closed
  form (``naive_walker.circle_walker_truth``);
* the Jansen leg: explorer's foot path and Jacobian velocities through the kernel, against the
  plain-numpy walker over the closed-form leg (sequential circle intersections, ``naive.py``) read
  at each leg's own crank angle, with velocities by central differences;
* a tied contact (two feet equally low), translation invariance and scaling of the whole mechanism.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import explorer
import naive
import naive_walker as nw
from explorer.errors import UserError
from explorer.gait import WALKER_METRICS, compute_metrics
from explorer.mechanism import Walker, mechanism_from_dict

DIMENSIONLESS = ("body_speed_ripple", "peak_torque", "torque_ripple", "slip", "contact_fraction")
LENGTHS = ("travel", "bob", "clearance")


def _circle(R):
    def foot(theta):
        theta = np.asarray(theta, dtype=float)
        p = R * np.stack([np.cos(theta), np.sin(theta)], axis=1)
        v = R * np.stack([-np.sin(theta), np.cos(theta)], axis=1)
        return p, v
    return foot


def _kernel(path, vel, crank, walker):
    out = compute_metrics(path[None], vel[None], [0], list(WALKER_METRICS), crank=[crank], walker=walker)
    return {k: float(v[0]) for k, v in out.items()}


# -- an analytic walker -------------------------------------------------------------------------------
@pytest.mark.parametrize("phases,mirrored", [
    ((0.0, 180.0), (False, False)),
    ((17.3, 197.3), (False, False)),      # off the sample grid: read by Hermite interpolation
    ((0.0, 180.0), (False, True)),        # a circle is its own mirror image: the same walker
])
def test_circle_walker_matches_closed_form(phases, mirrored):
    R, crank, contact, S = 2.0, 1.5, 0.05, 7200
    foot = _circle(R)
    p, v = foot(2 * np.pi * np.arange(S) / S)
    w = Walker(2, tuple(math.radians(x) for x in phases), mirrored, 0.0, contact)
    got = _kernel(p, v, crank, w)
    truth = nw.circle_walker_truth(R, crank, contact)
    # sums over S samples of functions with kinks (|sin θ|, the contact switch): O(1/S) at worst
    for k in ("travel", "bob", "body_speed_ripple", "peak_torque", "torque_ripple"):
        assert got[k] == pytest.approx(truth[k], rel=1e-5), k
    for k in ("contact_fraction", "clearance", "slip"):
        assert got[k] == pytest.approx(truth[k], rel=5e-3, abs=2 * np.pi / S), k


def test_circle_walker_drag_adds_torque():
    """With drag D = μW along the ground the torque gains μ·|dx_c/dθ| (work against the drag)."""
    R, crank, S, mu = 1.0, 1.0, 3600, 0.3
    p, v = _circle(R)(2 * np.pi * np.arange(S) / S)
    w0 = Walker(2, drag=0.0)
    w1 = Walker(2, drag=mu)
    Y, VX, VY = nw.legs_at(_circle(R), S, w1.phases, w1.mirrored)
    ref = nw.naive_walker(Y, VX, VY, crank, drag=mu, contact=w1.contact)
    got = _kernel(p, v, crank, w1)
    for k in WALKER_METRICS:
        assert got[k] == pytest.approx(ref[k], rel=1e-9, abs=1e-12), k
    # τ = −(u μ vx_c + vy_c) with u = −1 (the body walks towards −x) and vx_c = R|sin θ| ≥ 0
    theta = 2 * np.pi * np.arange(S) / S
    tau = mu * R * np.abs(np.sin(theta)) + np.where(np.sin(theta) < 0, -R * np.cos(theta), R * np.cos(theta))
    assert got["peak_torque"] == pytest.approx(np.abs(tau).max() / crank, rel=1e-9)
    assert got["peak_torque"] > _kernel(p, v, crank, w0)["peak_torque"]


# -- the Jansen leg --------------------------------------------------------------------------------------
def _jansen_foot(lengths=naive.JANSEN_LENGTHS, crank=naive.JANSEN_CRANK):
    def pos(theta):
        P, ok, _ = naive.jansen_closed_form(lengths, crank, theta)
        return P[:, 6]

    def foot(theta):
        theta = np.asarray(theta, dtype=float)
        return pos(theta), naive.central_difference(pos, theta, 1e-5)
    return foot


@pytest.fixture(scope="module")
def jansen360():
    mech = explorer.load_mechanism("jansen")
    cyc = explorer.simulate(mech, 360, tolerance=1e-12)
    assert cyc.ok
    return mech, cyc.path("7"), cyc.velocity("7")


WALKERS = {
    "default (4 legs, odd mirrored)": None,
    "3 legs": Walker(3),
    "5 legs, drag": Walker(5, drag=0.2),
    "6 legs, odd mirrored": Walker(6, mirrored=(False, True) * 3),
}


@pytest.mark.parametrize("name", list(WALKERS))
def test_jansen_walker_against_closed_form(jansen360, name):
    mech, path, vel = jansen360
    w = WALKERS[name] if WALKERS[name] is not None else mech.walker
    got = compute_metrics(path[None], vel[None], [0], list(WALKER_METRICS), mechanism=mech, walker=WALKERS[name])
    Y, VX, VY = nw.legs_at(_jansen_foot(), 360, w.phases, w.mirrored)
    ref = nw.naive_walker(Y, VX, VY, naive.JANSEN_CRANK, w.drag, w.contact)
    for k in WALKER_METRICS:
        # positions agree to ~1e-10, velocities to the central differences' ~1e-8
        assert float(got[k][0]) == pytest.approx(ref[k], rel=1e-6, abs=1e-8), k


def test_jansen_default_walker_figures(jansen360):
    """The built-in's default walker keeps the body within 1 % of the step height (its documented reason)."""
    mech, path, vel = jansen360
    assert mech.walker.legs == 4 and mech.walker.mirrored == (False, True, False, True)
    m = {k: float(v[0]) for k, v in compute_metrics(path[None], vel[None], [0], mechanism=mech).items()}
    assert m["bob"] < 0.01 * m["height"]
    three = compute_metrics(path[None], vel[None], [0], ["bob"], mechanism=mech, walker=Walker(3))["bob"][0]
    assert three > 0.01 * m["height"]
    # the body travels about three band strides per turn: each leg carries it for a quarter turn at
    # about the stance speed (22 per radian)
    assert 120 < m["travel"] < 160 and m["travel"] == pytest.approx(4 * 22.2 * math.pi / 2, rel=0.1)


def test_off_grid_phases_interpolate(jansen360):
    """Phases between samples are read by cubic Hermite interpolation of the samples and velocities."""
    mech, path, vel = jansen360
    w = Walker(3, phases=tuple(math.radians(x) for x in (0.4, 120.4, 240.4)))
    got = compute_metrics(path[None], vel[None], [0], list(WALKER_METRICS), mechanism=mech, walker=w)
    Y, VX, VY = nw.legs_at(_jansen_foot(), 360, w.phases, w.mirrored)
    ref = nw.naive_walker(Y, VX, VY, naive.JANSEN_CRANK, w.drag, w.contact)
    for k in ("travel", "bob", "body_speed_ripple", "peak_torque", "torque_ripple", "clearance"):
        # Hermite interpolation at h = 1°: position error O(h⁴), velocity O(h³)
        assert float(got[k][0]) == pytest.approx(ref[k], rel=2e-3, abs=1e-3), k


# -- a tied contact -----------------------------------------------------------------------------------------
def test_tied_contact_two_feet_equally_low(jansen360):
    """Two legs at the same phase are two feet equally low at every angle: the contact goes to the
    first, nothing slips, each is in contact exactly when one leg alone would be, and every metric
    equals the walker without the duplicates."""
    mech, path, vel = jansen360
    dup = Walker(4, phases=(0.0, 0.0, math.pi, math.pi))
    single = Walker(2)
    a = compute_metrics(path[None], vel[None], [0], list(WALKER_METRICS), mechanism=mech, walker=dup)
    b = compute_metrics(path[None], vel[None], [0], list(WALKER_METRICS), mechanism=mech, walker=single)
    Y, VX, VY = nw.legs_at(_jansen_foot(), 360, dup.phases, dup.mirrored)
    assert (Y[0] == Y[1]).all()
    ref = nw.naive_walker(Y, VX, VY, naive.JANSEN_CRANK, dup.drag, dup.contact)
    for k in WALKER_METRICS:
        assert float(a[k][0]) == pytest.approx(ref[k], rel=1e-6, abs=1e-8), k
        if k != "slip":
            assert float(a[k][0]) == float(b[k][0]), k
    # the tied feet slide at the same speed: only the handovers between the pairs slip
    assert float(a["slip"][0]) == pytest.approx(float(b["slip"][0]), rel=1e-12, abs=1e-15)


# -- invariance and scaling -------------------------------------------------------------------------------
def _moved(scale=1.0, dx=0.0, dy=0.0):
    d = {"name": "j", "foot": "7",
         "crank": {"center": [dx, dy], "radius": naive.JANSEN_CRANK * scale, "tip": "1"},
         "fixed": {"2": [naive.JANSEN_FIXED2[0] * scale + dx, naive.JANSEN_FIXED2[1] * scale + dy]},
         "guess": {k: [x * scale + dx, y * scale + dy] for k, (x, y) in naive.JANSEN_GUESS.items()},
         "links": [{"a": a, "b": b, "length": L * scale} for (a, b), L in zip(naive.JANSEN_LINKS, naive.JANSEN_LENGTHS)],
         "walker": {"legs": 4, "mirrored": True, "drag": 0.1}}
    return mechanism_from_dict(d, f"jansen x{scale} +({dx}, {dy})")


def _all_metrics(mech):
    c = explorer.simulate(mech, 360, tolerance=1e-12)
    assert c.ok
    out = compute_metrics(c.path("7")[None], c.velocity("7")[None], [0], mechanism=mech)
    return {k: float(v[0]) for k, v in out.items()}


def test_metrics_invariant_under_translation_and_scale_as_lengths():
    base = _all_metrics(_moved())
    moved = _all_metrics(_moved(dx=123.4, dy=-56.7))
    for k, v in base.items():
        assert moved[k] == pytest.approx(v, rel=1e-7, abs=1e-9), k
    k2 = 2.5
    big = _all_metrics(_moved(scale=k2))
    lengths = LENGTHS + ("width", "height", "stride", "stance_rms_line", "stance_speed", "max_speed", "foot_headroom")
    for k, v in base.items():
        want = v * k2 if k in lengths else v
        assert big[k] == pytest.approx(want, rel=1e-7, abs=1e-9), k
    assert set(DIMENSIONLESS) <= set(base)


# -- errors ---------------------------------------------------------------------------------------------
def test_walker_needs_a_crank_and_valid_tables(tmp_path):
    arm = explorer.load_mechanism("arm")
    z = np.zeros((1, 10, 2))
    with pytest.raises(UserError, match="driven along a path"):
        compute_metrics(z, z, [0], ["travel"], mechanism=arm)
    # metrics=True skips what cannot be computed
    assert "travel" not in compute_metrics(z, z, [0], mechanism=arm)
    d = {"name": "j", "foot": "7", "crank": {"center": [0, 0], "radius": 15, "tip": "1"}, "fixed": {"2": [-38, -7.8]},
         "guess": {k: list(v) for k, v in naive.JANSEN_GUESS.items()},
         "links": [{"a": a, "b": b, "length": L} for (a, b), L in zip(naive.JANSEN_LINKS, naive.JANSEN_LENGTHS)]}
    for table, match in [({"legs": 0}, "walker.legs"), ({"legs": 2, "phases": [0]}, "walker.phases"),
                         ({"mirrored": [True]}, "walker.mirrored"), ({"drag": -1}, "walker.drag"),
                         ({"contact": 0}, "walker.contact"), ({"feet": 2}, "walker.feet: unknown key")]:
        with pytest.raises(UserError, match=match):
            mechanism_from_dict({**d, "walker": table}, "m.toml")
    m = mechanism_from_dict({**d, "walker": {"legs": 3, "phases": [0, 100, 250], "mirrored": [False, True, False]}})
    assert m.walker.phases == pytest.approx(tuple(math.radians(x) for x in (0, 100, 250)))


def test_animate_walker_draws_the_legs_the_metrics_describe(tmp_path):
    """`animate --walker`: each drawn leg sits at the sample the walker kernel reads for that leg."""
    from explorer.gait import leg_samples
    from explorer.testing import LinkageAnimation
    for name in ("jansen", "fourbar"):
        mech = explorer.load_mechanism(name)
        anim = LinkageAnimation(mech, cycles=1, frames=12, walker=True)
        w = mech.walker
        assert anim.legs == w.legs and anim._mirrored == list(w.mirrored)
        base, frac, sign = leg_samples(w, anim.S)
        assert (frac == 0).all()  # the animation's grid holds every phase exactly
        for j in range(w.legs):
            for k in (0, 7, anim.S // 3):
                assert anim.leg_index(j, k) == (sign[j] * k + base[j]) % anim.S
    with pytest.raises(UserError, match="needs a crank"):
        LinkageAnimation(explorer.load_mechanism("arm"), walker=True)


# -- clearance converges in the step count (issue 40) --------------------------------------------------------
def _klann_foot(theta):
    from naive_legs import central_difference, klann_positions
    theta = np.asarray(theta, dtype=np.float64)
    return klann_positions(theta)["33"], central_difference(klann_positions, theta)["33"]


def test_klann_clearance_converges_as_steps_grow():
    """Klann's foot comes within the contact band of the ground for about 1.6° near 145° of its swing (a
    tap). Whether a sample landed in it decided the clearance: 2.38 at 184 steps, 0.031 at 180. Now a
    tap between samples counts, so the clearance stays within O(2π/S) of the reference: the plain
    definition on the closed-form leg of tests/naive_legs.py sampled at 14,400 steps (0.025°, where the
    samples see the tap themselves); and explorer agrees with the reference's own tap rule (the closed
    form evaluated inside every interval) at each step count."""
    from naive_legs import KLANN
    mech = explorer.load_mechanism("klann")
    w = mech.walker
    crank = KLANN["crank"]
    s_ref = 14_400
    ref = nw.naive_walker(*nw.legs_at(_klann_foot, s_ref, w.phases, w.mirrored), crank)["clearance"]
    assert 2.2 < ref < 2.5
    for S in (120, 160, 176, 180, 184, 188, 200, 240, 360, 720):
        cyc = explorer.simulate(mech, steps=S)
        got = float(compute_metrics(cyc.path("33")[None], cyc.velocity("33")[None], [0], ["clearance"],
                                    mechanism=mech)["clearance"][0])
        # the swing's ends and its middle half move by up to a sample: an error of |dh/dθ|·2π/S at most
        assert abs(got - ref) <= 6.0 * (2.0 * np.pi / S + 2.0 * np.pi / s_ref), (S, got, ref)
        R = 16  # the closed form inside each interval: the reference's own tap test
        Y, VX, VY = nw.legs_at(_klann_foot, S, w.phases, w.mirrored)
        fine = np.stack([nw.legs_at(lambda t, r=r: _klann_foot(t + 2.0 * np.pi / S * r / R), S, w.phases,
                                    w.mirrored)[0] for r in range(R)], axis=2)
        assert got == pytest.approx(nw.naive_walker(Y, VX, VY, crank, fine=fine)["clearance"], rel=1e-6), S
