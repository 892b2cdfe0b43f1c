"""Seed 004's two-link arm (links 2 and 1, base at the origin) with its tip driven along a line.

References (``naive_mech``, plain numpy): the analytic two-link inverse kinematics for both elbow
signs, the linear and quintic timing laws, and central finite differences of the IK for velocities.
The line from (−1, 1) to (2, 1) touches the inner workspace circle (radius 2 − 1) at (0, 1): the
arm is fully folded there for an instant and both elbow configurations meet; a solver that keeps
the elbow configuration comes out of the fold on the same elbow sign it went in with.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.optimize import brentq

import naive_mech as nm
from explorer import UserError, load_mechanism, simulate, simulate_batch
from explorer.mechanism import mechanism_from_dict

L1, L2 = 2.0, 1.0
START, END = np.array([-1.0, 1.0]), np.array([2.0, 1.0])
DURATION = 10.0
ELBOWS = {+1: [-0.6, 1.9], -1: [-1.9, 0.6]}  # elbow sign of θ2 -> the elbow guess that picks it
STEPS = 101  # t_k = 0.1 k; the fold (x = 0) is at no sample for either timing


def arm(elbow: int, timing: str = "quintic", end=(2.0, 1.0), **driver):
    d = nm.builtin_dict("arm")
    d["guess"]["E"] = ELBOWS[elbow]
    d["driver"].update(timing=timing, end=list(end), **driver)
    return mechanism_from_dict(d, f"arm(elbow={elbow}, {timing})")


def tip_on_line(t, timing, end=END):
    s, ds, dds = nm.timing(timing, DURATION, t)
    g = np.asarray(end) - START
    return START + s[:, None] * g, ds[:, None] * g, dds[:, None] * g


def ik(t, timing, elbow, end=END):
    tip = tip_on_line(t, timing, end)[0]
    return nm.two_link_ik(tip[:, 0], tip[:, 1], L1, L2, elbow)


def elbow_path(t, timing, elbow, end=END):
    q1, _ = ik(t, timing, elbow, end)
    return L1 * np.stack([np.cos(q1), np.sin(q1)], axis=-1)


def angle_error(a, b):
    return np.abs(nm.wrap(np.asarray(a) - np.asarray(b)))


def test_builtin_arm_is_seed_004():
    m = load_mechanism("arm")
    assert m.crank is None and m.driven == "T"
    p = m.path
    assert (p.vertex, p.kind, p.duration, p.timing) == ("T", "line", 10.0, "quintic")
    assert p.points == ((-1.0, 1.0), (2.0, 1.0))
    assert dict(m.fixed) == {"O": (0.0, 0.0)}
    assert {l.name: (l.a, l.b, l.length) for l in m.links} == {"upper": ("O", "E", 2.0), "fore": ("E", "T", 1.0)}
    # the file's guess is the elbow sign +1 (θ2 > 0) of the inverse kinematics at t = 0
    e = {s: nm.two_link_elbow(-1.0, 1.0, L1, L2, s) for s in (+1, -1)}
    assert np.hypot(*(e[+1] - m.guess["E"])) < 0.05 < 1.0 < np.hypot(*(e[-1] - m.guess["E"]))
    # the line touches the inner workspace circle |T| = L1 − L2 exactly once, at (0, 1)
    x = np.linspace(-1.0, 2.0, 30001)
    r = np.hypot(x, 1.0)
    assert r.min() == pytest.approx(L1 - L2) and x[np.argmin(r)] == pytest.approx(0.0, abs=1e-12)


@pytest.mark.parametrize("method", ["block", "closed"])
@pytest.mark.parametrize("timing", ["linear", "quintic"])
@pytest.mark.parametrize("elbow", [+1, -1])
def test_joint_angles_match_inverse_kinematics(elbow, timing, method):
    c = simulate(arm(elbow, timing), STEPS, tolerance=1e-12, method=method, velocities=method != "closed")
    assert c.ok, c.failure
    np.testing.assert_allclose(c.theta, DURATION * np.arange(STEPS) / (STEPS - 1), rtol=0, atol=1e-14)
    assert c.theta[-1] == DURATION
    q1, q2 = ik(c.theta, timing, elbow)
    assert np.isfinite(q1).all()
    # the tip follows the line with the timing law
    np.testing.assert_allclose(c.path("T"), tip_on_line(c.theta, timing)[0], rtol=0, atol=1e-14)
    np.testing.assert_array_equal(c.path("O"), 0.0)
    theta1 = c.link_angle("upper")
    theta2 = nm.wrap(c.link_angle("fore") - theta1)
    assert angle_error(theta1, q1).max() <= 1e-9
    assert angle_error(theta2, q2).max() <= 1e-9
    # the elbow sign is kept all the way, through the fold at (0, 1)
    assert np.all(np.sign(theta2) == elbow)
    np.testing.assert_allclose(c.path("E"), elbow_path(c.theta, timing, elbow), rtol=0, atol=1e-9)


@pytest.mark.parametrize("steps", [360, 1000])
@pytest.mark.parametrize("timing", ["linear", "quintic"])
def test_many_samples_pass_the_fold(timing, steps):
    """The fold at (0, 1) is passed tangentially: the squared distance |T|² stays within the gap check's
    margin of its limit over a stretch of time (3.8 ms with quintic timing) that does not shrink with
    the sample spacing. With 360 or more samples that stretch used to exceed the forced-step budget
    of an eighth of a sample interval, and the arm failed with "no-convergence" at t = 4.09 s."""
    c = simulate(arm(+1, timing), steps, tolerance=1e-12)
    assert c.ok, c.failure
    err = np.max(np.abs(c.path("E") - elbow_path(c.theta, timing, +1)), axis=1)
    # on the fold itself (linear timing at 1000 samples puts one there) the lengths fix the elbow only
    # to about sqrt(rounding) (see test_fold_on_a_sample_keeps_the_elbow); everywhere else, to 1e-9
    at_fold = np.abs(tip_on_line(c.theta, timing)[0][:, 0]) < 1e-6
    assert err[~at_fold].max() <= 1e-9
    assert err[at_fold].max(initial=0.0) <= 1e-7


@pytest.mark.slow
@pytest.mark.parametrize("elbow", [+1, -1])
def test_fold_on_a_sample_keeps_the_elbow(elbow):
    """Linear timing with 31 samples puts a sample on the fold (t = 10/3 s, x = 0): the arm is fully
    folded there and must come out of it on the same elbow sign."""
    c = simulate(arm(elbow, "linear"), 31, tolerance=1e-12, velocities=False)
    assert c.ok, c.failure
    assert c.theta[10] == pytest.approx(10.0 / 3.0)
    ref = elbow_path(c.theta, "linear", elbow)
    # at the fold the elbow is at (0, 2) in both configurations; it is a double root, so only
    # √(tolerance)-accurate there
    np.testing.assert_allclose(c.path("E")[10], [0.0, 2.0], atol=1e-5)
    away = np.abs(c.theta - 10.0 / 3.0) > 0.1
    np.testing.assert_allclose(c.path("E")[away], ref[away], rtol=0, atol=1e-9)
    theta2 = nm.wrap(c.link_angle("fore") - c.link_angle("upper"))
    assert np.all(np.sign(theta2[away]) == elbow)


@pytest.mark.parametrize("elbow", [+1, -1])
def test_dense_keeps_the_elbow_through_the_fold(elbow):
    for timing in ("linear", "quintic"):
        c = simulate(arm(elbow, timing), STEPS, tolerance=1e-12, method="dense")
        assert c.ok, c.failure
        q1, _ = ik(c.theta, timing, elbow)
        assert angle_error(c.link_angle("upper"), q1).max() <= 1e-9


@pytest.mark.parametrize("elbow", [+1, -1])
def test_quintic_rests_at_both_ends(elbow):
    c = simulate(arm(elbow, "quintic"), STEPS, tolerance=1e-12, accelerations=True)
    assert c.ok
    for v in ("T", "E"):
        for k in (0, -1):
            np.testing.assert_allclose(c.velocity(v)[k], 0.0, atol=1e-12)
            np.testing.assert_allclose(c.accelerations[k, c.mechanism.vertex_index(v)], 0.0, atol=1e-12)
    # and not at rest in between: peak tip speed of the quintic is 15/8 · |end − start| / T
    speed = np.hypot(*c.velocity("T").T)
    assert speed.max() == pytest.approx(15.0 / 8.0 * 3.0 / DURATION, rel=1e-12)
    assert speed[STEPS // 2] == pytest.approx(speed.max(), rel=1e-12)


@pytest.mark.parametrize("timing", ["linear", "quintic"])
@pytest.mark.parametrize("elbow", [+1, -1])
def test_velocities_per_second_match_finite_differences(elbow, timing):
    c = simulate(arm(elbow, timing), STEPS, tolerance=1e-12, accelerations=True)
    assert c.ok
    np.testing.assert_allclose(c.velocity("T"), tip_on_line(c.theta, timing)[1], rtol=0, atol=1e-14)
    np.testing.assert_allclose(c.accelerations[:, c.mechanism.vertex_index("T")], tip_on_line(c.theta, timing)[2],
                               rtol=0, atol=1e-14)
    if timing == "linear":
        np.testing.assert_allclose(c.velocity("T"), np.tile([0.3, 0.0], (STEPS, 1)), rtol=0, atol=1e-15)
    f = lambda t: elbow_path(t, timing, elbow)  # noqa: E731
    fd = nm.central_difference(f, c.theta, h=1e-6)
    scale = np.abs(fd).max()
    np.testing.assert_allclose(c.velocity("E"), fd, rtol=0, atol=1e-6 * scale)
    fd2 = (f(c.theta + 1e-4) - 2 * f(c.theta) + f(c.theta - 1e-4)) / 1e-8
    acc = c.accelerations[:, c.mechanism.vertex_index("E")]
    np.testing.assert_allclose(acc, fd2, rtol=0, atol=1e-5 * np.abs(fd2).max())
    # joint rates: dθ1/dt from the elbow velocity equals the FD of the IK angle
    q1 = lambda t: ik(t, timing, elbow)[0]  # noqa: E731
    e, ve = c.path("E"), c.velocity("E")
    dtheta1 = (e[:, 0] * ve[:, 1] - e[:, 1] * ve[:, 0]) / L1 ** 2
    np.testing.assert_allclose(dtheta1, nm.wrap(q1(c.theta + 1e-6) - q1(c.theta - 1e-6)) / 2e-6, rtol=0,
                               atol=1e-6 * np.abs(dtheta1).max())


# -- out of reach: an assembly failure at the time |T| = L1 + L2, never a crash ------------------------------------
def time_out_of_reach(timing, end):
    """First t with |T(t)| = L1 + L2 = 3 on the line y = 1: x = √8, i.e. s = (√8 − x0) / (x1 − x0)."""
    s_star = (math.sqrt((L1 + L2) ** 2 - 1.0) - START[0]) / (end[0] - START[0])
    return brentq(lambda t: nm.timing(timing, DURATION, t)[0] - s_star, 0.0, DURATION, xtol=1e-15)


@pytest.mark.parametrize("timing", ["linear", "quintic"])
@pytest.mark.parametrize("elbow", [+1, -1])
def test_target_out_of_reach_is_an_assembly_failure(elbow, timing):
    end = (3.5, 1.0)
    c = simulate(arm(elbow, timing, end=end), STEPS, tolerance=1e-12)
    t_star = time_out_of_reach(timing, end)
    assert not c.ok
    f = c.failure
    assert f.kind == "assembly" and f.vertex == "E" and f.theta_end is None
    dt = DURATION / (STEPS - 1)
    assert t_star - 1e-9 <= f.theta <= t_star + 2 * dt / 65536
    assert "t = " in f.message and "\n" not in f.message
    before = c.theta < f.theta
    assert before.sum() == int(t_star / dt) + 1
    assert np.isfinite(c.positions[before]).all() and np.isnan(c.positions[~before]).all()
    assert np.isfinite(c.velocities[before]).all() and np.isnan(c.velocities[~before]).all()
    q1, q2 = ik(c.theta[before], timing, elbow, end)
    assert angle_error(c.link_angle("upper")[before], q1).max() <= 1e-9
    assert angle_error(nm.wrap(c.link_angle("fore") - c.link_angle("upper"))[before], q2).max() <= 1e-9
    assert np.isnan(ik(c.theta[~before], timing, elbow, end)[0]).all()  # the IK has no answer there either


def test_target_out_of_reach_from_the_start_fails_at_t0():
    d = nm.builtin_dict("arm")
    d["driver"]["start"] = [3.5, 1.0]
    c = simulate(mechanism_from_dict(d, "arm-far"), 11)
    assert not c.ok and c.failure.kind == "assembly" and c.failure.theta == 0.0
    assert np.isnan(c.positions).all()


@pytest.mark.slow
def test_batch_of_arms_fails_at_the_analytic_times():
    """simulate_batch on the path-driven arm: per-variant link lengths, failure times where the line
    leaves the annulus L1 − L2 ≤ |T| ≤ L1 + L2."""
    mech = arm(+1, "linear")
    rows = np.array([[2.0, 1.0], [1.5, 0.7], [2.0, 0.7], [2.2, 1.0], [1.9, 1.0]])
    b = simulate_batch(mech, rows, None, STEPS, vertices=["E", "T"], tolerance=1e-12)
    assert list(b.status) == [0, 1, 1, 1, 0]
    # where the line y = 1 leaves the annulus: the outer circle (reach 2.2 < |(2, 1)|), the inner one (1.3, 1.2)
    x_fail = {1: math.sqrt(2.2 ** 2 - 1.0), 2: -math.sqrt(1.3 ** 2 - 1.0), 3: -math.sqrt(1.2 ** 2 - 1.0)}
    dt = DURATION / (STEPS - 1)
    for i, (l1, l2) in enumerate(rows):
        tip = tip_on_line(b.theta, "linear")[0]
        ref = nm.two_link_elbow(tip[:, 0], tip[:, 1], l1, l2, +1)
        reach = b.theta < b.fail_theta[i] if i in x_fail else np.ones(STEPS, bool)
        np.testing.assert_allclose(b.paths["E"][i][reach], ref[reach], rtol=0, atol=1e-9)
        assert np.isnan(b.paths["E"][i][~reach]).all()
        if i in x_fail:
            t_star = (x_fail[i] - START[0]) / 3.0 * DURATION
            assert t_star - 1e-9 <= b.fail_theta[i] <= t_star + 2 * dt / 65536
    with pytest.raises(UserError, match="crank"):
        simulate_batch(mech, rows, np.ones(len(rows)), STEPS)
    with pytest.raises(UserError, match="crank"):
        mech.with_lengths(crank=2.0)


@pytest.mark.parametrize("method", ["block", "dense", "auto"])
@pytest.mark.parametrize("steps", [3, 4, 101])
def test_unreachable_hole_between_samples_is_found(steps, method):
    """The line y = 0.9 crosses the inner workspace circle (radius 1) for |x| < √0.19: with 3 or 4
    samples no sample lies in that hole, yet the design is reported to fail where the line enters it."""
    d = nm.builtin_dict("arm")
    d["driver"].update(start=[-1.0, 0.9], end=[2.0, 0.9], timing="linear")
    c = simulate(mechanism_from_dict(d, "arm-hole"), steps, tolerance=1e-12, method=method)
    assert not c.ok and c.failure.kind == "assembly"
    t_star = (1.0 - math.sqrt(1.0 - 0.81)) / 3.0 * DURATION
    dt = DURATION / (steps - 1)
    assert t_star - 1e-9 <= c.failure.theta <= t_star + 2 * dt / 65536
    before = c.theta < c.failure.theta
    assert np.isfinite(c.positions[before]).all() and np.isnan(c.positions[~before]).all()
