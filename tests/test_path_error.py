"""path_error (explorer.gait._path) against independent references written here: closed-form curves
(circles, a three-harmonic Fourier loop) with exact derivatives, brute force over a million points of
the exact curve, similarity transforms undone, NaN rows; the study-file loader's errors; and the
literature four-bar of benchmarks/_synthesis_problems.py against a plain-numpy four-bar."""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from explorer import UserError, simulate
from explorer.testing import load_target, path_error, path_match, path_residuals
from explorer.mechanism import mechanism_from_dict

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
import _synthesis_problems as problems  # noqa: E402

ALL = ("translation", "rotation", "scale")


# ---------------------------------------------------------------------------------------------
# reference curves, exact positions and derivatives
# ---------------------------------------------------------------------------------------------

def circle(theta, r=2.0, c=(0.0, 0.0)):
    """A circle of radius r about c, and dF/dθ."""
    p = np.stack([c[0] + r * np.cos(theta), c[1] + r * np.sin(theta)], -1)
    v = np.stack([-r * np.sin(theta), r * np.cos(theta)], -1)
    return p, v


#: x = Σ a_k cos kθ + b_k sin kθ, y likewise: a smooth, simple, non-convex closed loop
FX = {1: (2.0, 0.0), 2: (0.5, 0.0), 3: (0.0, 0.1)}
FY = {1: (0.0, 1.2), 2: (0.0, -0.3), 3: (0.15, 0.0)}


def fourier(theta, d=0):
    """d-th derivative of the Fourier loop at theta, shape (..., 2)."""
    out = []
    for coef in (FX, FY):
        s = 0.0
        for k, (a, b) in coef.items():
            # d/dθ of (a cos kθ + b sin kθ), d times
            ph = d * math.pi / 2
            s = s + k ** d * (a * np.cos(k * theta + ph) + b * np.sin(k * theta + ph))
        out.append(s)
    return np.stack(out, -1)


def fourier_bound(d):
    """max over θ of |d-th derivative| (a bound: per coordinate Σ k^d (|a| + |b|))."""
    return math.hypot(*(sum(k ** d * (abs(a) + abs(b)) for k, (a, b) in c.items()) for c in (FX, FY)))


def samples(S, f=fourier):
    th = 2 * np.pi * np.arange(S) / S
    return f(th)[None], f(th, 1)[None]


def similarity(p, s, phi, t):
    R = np.array([[math.cos(phi), -math.sin(phi)], [math.sin(phi), math.cos(phi)]])
    return s * p @ R.T + np.asarray(t)


def hermite_bound(S):
    h = 2 * np.pi / S
    return h ** 4 / 384 * fourier_bound(4)


def chord_bound(S):
    h = 2 * np.pi / S
    return h ** 2 / 8 * fourier_bound(2)


# ---------------------------------------------------------------------------------------------
# closest
# ---------------------------------------------------------------------------------------------

@pytest.mark.slow
def test_closest_concentric_circles_exact():
    S, r1 = 360, 2.0
    th = 2 * np.pi * np.arange(S) / S
    foot, vel = circle(th, r1, c=(1.0, -3.0))
    a = np.linspace(0.05, 6.2, 13)
    for r2 in (3.1, 0.7, 2.0):
        target = np.stack([1.0 + r2 * np.cos(a), -3.0 + r2 * np.sin(a)], -1)
        e = path_error(foot[None], target, velocity=vel[None])
        # the Hermite cubic of a circle is off by at most R·h⁴/384
        assert abs(e[0] - abs(r1 - r2)) <= r1 * (2 * np.pi / S) ** 4 / 384 + 1e-12
        # straight chords lie inside the circle, down to r1·cos(h/2) at their middle
        d = path_residuals(foot[None], target)[0]
        lo = abs(r2 - r1) if r2 >= r1 else r1 * math.cos(np.pi / S) - r2
        hi = r2 - r1 * math.cos(np.pi / S) if r2 >= r1 else r1 - r2
        assert np.all(d >= lo - 1e-12) and np.all(d <= hi + 1e-12)


def test_closest_against_brute_force_on_a_million_points():
    S = 360
    foot, vel = samples(S)
    rng = np.random.default_rng(3)
    target = rng.uniform([-3.0, -2.0], [3.0, 2.0], size=(25, 2))
    dense = fourier(np.linspace(0.0, 2 * np.pi, 1_000_000, endpoint=False))
    brute = np.array([np.sqrt(np.min(np.sum((dense - q) ** 2, axis=1))) for q in target])
    m = path_match(foot, target, velocity=vel)
    # the dense points are 1.6e-5 apart at most: their closest distance exceeds the curve's by far
    # less than 1e-8 unless the point lies on the curve
    assert np.allclose(m.distances[0], brute, rtol=0, atol=hermite_bound(S) + 1e-8)
    # the matched points are on the curve at the matched angles
    assert np.allclose(m.points[0], fourier(m.theta[0]), atol=hermite_bound(S))
    assert np.isclose(m.error[0], np.sqrt(np.mean(brute ** 2)), atol=1e-8)
    # straight segments: never closer than the curve by more than the chord sag
    lin = path_residuals(foot, target)[0]
    assert np.all(np.abs(lin - brute) <= chord_bound(S) + 1e-8)


# ---------------------------------------------------------------------------------------------
# timed
# ---------------------------------------------------------------------------------------------

def test_timed_self_match_within_the_stated_bounds():
    S = 360
    foot, vel = samples(S)
    angles = np.array([0.0123, 1.0, 2.5, 3.14159, 4.2, 6.2])  # off the samples
    target = fourier(angles)
    e = path_residuals(foot, target, velocity=vel, angles=angles, match="timed")[0]
    assert np.all(e <= hermite_bound(S)) and hermite_bound(S) < 1e-8
    e = path_residuals(foot, target, angles=angles, match="timed")[0]
    assert np.all(e <= chord_bound(S))
    # angles beyond one turn wrap
    e2 = path_error(foot, target, velocity=vel, angles=angles + 4 * np.pi, match="timed")
    assert e2[0] <= hermite_bound(S)


def test_timed_similarity_recovered_with_ignore_all_not_without():
    S = 720
    foot, vel = samples(S)
    angles = np.linspace(0.3, 5.9, 9)
    s, phi, t = 1.7, 2.2, (4.0, -1.5)
    target = similarity(fourier(angles), s, phi, t)
    m = path_match(foot, target, velocity=vel, angles=angles, match="timed", ignore=ALL)
    assert m.error[0] <= s * hermite_bound(S) < 1e-9
    assert np.isclose(m.scale[0], s, rtol=1e-9) and np.isclose(m.rotation[0], phi, atol=1e-9)
    assert np.allclose(m.translation[0], t, atol=1e-8)
    assert path_error(foot, target, velocity=vel, angles=angles, match="timed")[0] > 1.0
    # each kind alone
    for kind, tgt, check in (
        ("translation", fourier(angles) + (4.0, -1.5), lambda m: np.allclose(m.translation[0], (4.0, -1.5))),
        ("rotation", similarity(fourier(angles), 1.0, 2.2, (0, 0)), lambda m: np.isclose(m.rotation[0], 2.2)),
        ("scale", 1.7 * fourier(angles), lambda m: np.isclose(m.scale[0], 1.7)),
    ):
        m = path_match(foot, tgt, velocity=vel, angles=angles, match="timed", ignore=(kind,))
        assert m.error[0] < 1e-9 and check(m)
        assert path_error(foot, tgt, velocity=vel, angles=angles, match="timed")[0] > 0.1


def test_timed_angle_offset_per_design():
    S = 360
    foot, vel = samples(S)
    foot, vel = np.repeat(foot, 3, 0), np.repeat(vel, 3, 0)
    angles = np.array([0.5, 1.5, 2.5])
    off = np.array([0.0, 0.3, -1.0])
    target = fourier(angles + 0.3)
    e = path_error(foot, target, velocity=vel, angles=angles, match="timed", angle_offset=off)
    assert e[1] < 1e-8 and e[0] > 0.1 and e[2] > 0.1


# ---------------------------------------------------------------------------------------------
# closest and arc with ignore: the search undoes a similarity
# ---------------------------------------------------------------------------------------------

@pytest.mark.parametrize("s, phi, t", [(1.8, 0.7, (3.0, -2.0)), (0.4, -2.5, (-1.0, 0.5)), (1.0, 0.0, (0.0, 0.0))])
def test_closest_similarity_recovered(s, phi, t):
    S = 720
    foot, vel = samples(S)
    angles = np.sort(np.random.default_rng(1).uniform(0, 2 * np.pi, 12))
    target = similarity(fourier(angles), s, phi, t)
    m = path_match(foot, target, velocity=vel, ignore=ALL)
    assert m.error[0] < 1e-9
    assert np.isclose(m.scale[0], s, rtol=1e-8)
    assert np.isclose(math.remainder(m.rotation[0] - phi, 2 * np.pi), 0, atol=1e-8)
    if (s, phi) != (1.0, 0.0):
        assert path_error(foot, target, velocity=vel)[0] > 0.1


def test_arc_on_a_circle_closed_target():
    """A regular polygon on a concentric circle, closed (its first point repeated): equal chords,
    so equal arcs on the foot circle, starting from the foot point nearest the first vertex."""
    S, r1, r2 = 360, 2.0, 2.6
    th = 2 * np.pi * np.arange(S) / S
    foot, vel = circle(th, r1)
    a = 0.4 + 2 * np.pi * np.arange(8) / 7  # 7 sides, the last point is the first
    target = np.stack([r2 * np.cos(a), r2 * np.sin(a)], -1)
    m = path_match(foot[None], target, velocity=vel[None], match="arc")
    assert np.allclose(m.distances[0], r2 - r1, atol=1e-9)
    assert np.allclose(np.remainder(m.theta[0] - a + np.pi, 2 * np.pi) - np.pi, 0, atol=1e-7)
    # the same polygon traversed against the motion: far from it
    assert path_error(foot[None], target[::-1], velocity=vel[None], match="arc")[0] > 1.0


def stadium(S):
    """A D-shaped loop: the bottom edge y = 0 from x = −1 to 1 over the first half of the samples
    (uniform speed), then a half circle back over the top. Positions only (straight segments)."""
    k = np.arange(S)
    half = S // 2
    x = np.where(k < half, -1 + 2 * k / half, np.cos(np.pi * (k - half) / half))
    y = np.where(k < half, 0.0, np.sin(np.pi * (k - half) / half))
    return np.stack([x, y], -1)[None]


def test_arc_partial_target_on_a_straight_stretch():
    foot = stadium(360)
    xs = np.array([-0.8, -0.71, -0.3, 0.05, 0.2, 0.6])  # uneven, in the direction of motion
    target = np.stack([xs, np.zeros_like(xs)], -1)
    m = path_match(foot, target, match="arc")
    assert m.error[0] < 1e-12 and np.allclose(m.points[0], target, atol=1e-12)
    # shifted off the stretch: the shift; undone by ignoring translation
    assert np.isclose(path_error(foot, target + (0.0, -0.1), match="arc")[0], 0.1, atol=1e-12)
    assert path_error(foot, target + (0.05, -0.1), match="arc", ignore=("translation",))[0] < 1e-9
    # against the motion the span wraps around the loop
    assert path_error(foot, target[::-1], match="arc")[0] > 0.5
    # closest matching does not care about the order
    assert path_error(foot, target[::-1])[0] < 1e-12


# ---------------------------------------------------------------------------------------------
# properties
# ---------------------------------------------------------------------------------------------

transforms = st.tuples(st.floats(0.2, 5.0), st.floats(-math.pi, math.pi), st.floats(-10, 10), st.floats(-10, 10))


@settings(max_examples=25, deadline=None)
@given(transforms)
def test_timed_ignore_all_error_is_similarity_invariant(tr):
    """Moving the target by a similarity of scale σ scales the best-fit error by σ exactly."""
    s, phi, tx, ty = tr
    foot, vel = samples(90)
    angles = np.array([0.2, 1.1, 2.0, 3.3, 4.4, 5.5])
    target = fourier(angles) + np.array([[0.3, -0.2], [0.0, 0.4], [-0.5, 0.1], [0.2, 0.2], [0.1, -0.3], [0.0, 0.0]])
    e0 = path_error(foot, target, velocity=vel, angles=angles, match="timed", ignore=ALL)[0]
    moved = similarity(target, s, phi, (tx, ty))
    e1 = path_error(foot, moved, velocity=vel, angles=angles, match="timed", ignore=ALL)[0]
    assert e0 > 0.05 and math.isclose(e1, s * e0, rel_tol=1e-9)


@settings(max_examples=15, deadline=None)
@given(transforms, st.sampled_from(["closest", "arc"]))
def test_moving_foot_and_target_together_scales_the_error(tr, match):
    """Closest and arc matching are geometric: a similarity applied to the foot path (positions and
    velocities) and to the target scales every distance by its scale."""
    s, phi, tx, ty = tr
    foot, vel = samples(120)
    target = np.array([[2.5, 0.3], [1.0, 1.6], [-1.0, 1.0], [-2.0, -0.5], [0.4, -1.5]])
    d0 = path_residuals(foot, target, velocity=vel, match=match)[0]
    R = np.array([[math.cos(phi), -math.sin(phi)], [math.sin(phi), math.cos(phi)]])
    d1 = path_residuals(similarity(foot[0], s, phi, (tx, ty))[None], similarity(target, s, phi, (tx, ty)),
                        velocity=(s * vel[0] @ R.T)[None], match=match)[0]
    assert np.allclose(d1, s * d0, rtol=1e-9, atol=1e-9 * s)


# ---------------------------------------------------------------------------------------------
# NaN rows, shapes
# ---------------------------------------------------------------------------------------------

@pytest.mark.parametrize("match, ignore", [("timed", ()), ("timed", ALL), ("closest", ()), ("closest", ALL),
                                           ("arc", ()), ("arc", ("translation",))])
def test_nan_rows(match, ignore):
    foot, vel = samples(90)
    foot = np.repeat(foot, 4, 0)
    vel = np.repeat(vel, 4, 0)
    foot[1, 17, 0] = np.nan
    vel[2, 3, 1] = np.nan
    angles = np.array([0.1, 1.0, 2.0, 4.0])
    target = fourier(angles) * 1.1
    kw = {"angles": angles} if match == "timed" else {}
    m = path_match(foot, target, velocity=vel, match=match, ignore=ignore, **kw)
    assert np.isnan(m.error[1]) and np.isnan(m.error[2]) and np.all(np.isfinite(m.error[[0, 3]]))
    assert np.isnan(m.distances[1]).all() and np.isnan(m.theta[2]).all()
    assert m.error[0] == m.error[3]
    # a design's result depends on that design only, bit for bit (a resumed run re-batches designs)
    alone = path_match(foot[3:], target, velocity=vel[3:], match=match, ignore=ignore, **kw)
    assert all(np.array_equal(a[3:], b) for a, b in zip(m, alone))
    # without velocities only the foot's NaN counts
    e = path_error(foot, target, match=match, ignore=ignore, **kw)
    assert np.isnan(e[1]) and np.isfinite(e[2])


def test_bad_arguments():
    foot, vel = samples(30)
    with pytest.raises(ValueError, match="angles"):
        path_error(foot, np.zeros((3, 2)), match="timed")
    with pytest.raises(ValueError, match="ignore"):
        path_error(foot, np.zeros((3, 2)), ignore=("shear",))
    with pytest.raises(ValueError, match="match"):
        path_error(foot, np.zeros((3, 2)), match="nearest")
    with pytest.raises(ValueError, match="velocity"):
        path_error(foot, np.zeros((3, 2)), velocity=vel[:, :10])
    assert path_error(foot[:0], np.ones((3, 2))).shape == (0,)


# ---------------------------------------------------------------------------------------------
# the study file's target
# ---------------------------------------------------------------------------------------------

def test_load_target_points_and_csv(tmp_path):
    t = load_target({"points": [[0, 0], [1, 0.5], [2, 1]], "angles_deg": [0, 90, 180]})
    assert t.match == "timed" and np.allclose(t.angles, [0, np.pi / 2, np.pi]) and t.points.shape == (3, 2)
    t = load_target({"points": [[0, 0], [1, 0.5]], "ignore": ["scale", "translation"]})
    assert t.match == "closest" and t.angles is None and t.ignore == ("translation", "scale")
    (tmp_path / "p.csv").write_text("x,y,angle_deg\n0,0,10\n1,2,20\n3,4,30\n")
    t = load_target({"csv": "p.csv", "match": "timed"}, base_dir=tmp_path)
    assert np.allclose(t.points, [[0, 0], [1, 2], [3, 4]]) and np.allclose(np.degrees(t.angles), [10, 20, 30])
    (tmp_path / "q.csv").write_text("y, x\n1, 0\n2, 0\n")
    t = load_target({"csv": str(tmp_path / "q.csv"), "match": "arc", "ignore": ["rotation"]})
    assert np.allclose(t.points, [[0, 1], [0, 2]]) and t.match == "arc"
    foot, vel = samples(60)
    assert t.error(foot, vel).shape == (1,)


@pytest.mark.parametrize("spec, key, words", [
    ({"points": [[0, 0]]}, "target.points", "at least 2 points"),
    ({"points": [[0, 0], [1, float("nan")]]}, "target.points[1]", "finite"),
    ({"points": [[0, 0], [1, float("inf")]]}, "target.points[1]", "finite"),
    ({"points": [[0, 0], [1]]}, "target.points[1]", "[x, y]"),
    ({"points": [[0, 0], [1, True]]}, "target.points[1]", "[x, y]"),
    ({"points": "0,0"}, "target.points", "list"),
    ({"points": [[0, 0], [1, 1]], "match": "nearest"}, "target.match", "'nearest'"),
    ({"points": [[0, 0], [1, 1]], "ignore": ["shear"]}, "target.ignore[0]", "'shear'"),
    ({"points": [[0, 0], [1, 1]], "ignore": ["scale", "scale"]}, "target.ignore", "repeated"),
    ({"points": [[0, 0], [1, 1]], "match": "timed"}, "target.match", "needs crank angles"),
    ({"points": [[0, 0], [1, 1]], "angles_deg": [0]}, "target.angles_deg", "1 angles for 2 points"),
    ({"points": [[0, 0], [1, 1]], "angles_deg": [0, float("nan")]}, "target.angles_deg[1]", "finite"),
    ({"points": [[0, 0], [1, 1]], "angles_deg": [0, 1], "match": "closest"}, "target.angles_deg", "timed"),
    ({"points": [[1, 1], [1, 1]], "match": "arc"}, "target.points", "coincide"),
    ({"points": [[0, 0], [1, 1]], "colour": "red"}, "target.colour", "unknown key"),
    ({"points": [[0, 0], [1, 1]], "csv": "a.csv"}, "target", "exactly one"),
    ({}, "target", "exactly one"),
    ({"csv": "missing.csv"}, "target.csv", "cannot read"),
    ({"csv": "bad_col.csv"}, "target.csv", "unknown column 'z'"),
    ({"csv": "bad_num.csv"}, "target.csv", "row 3"),
    ({"csv": "one.csv"}, "target.csv", "at least 2 points"),
    ({"csv": "ok.csv", "angles_deg": [0, 1]}, "target.angles_deg", "angle_deg column"),
])
def test_load_target_errors(tmp_path, spec, key, words):
    (tmp_path / "bad_col.csv").write_text("x,z\n0,0\n1,1\n")
    (tmp_path / "bad_num.csv").write_text("x,y\n0,0\n1,one\n")
    (tmp_path / "one.csv").write_text("x,y\n0,0\n")
    (tmp_path / "ok.csv").write_text("x,y\n0,0\n1,1\n")
    with pytest.raises(UserError) as err:
        load_target(spec, base_dir=tmp_path, source="study.toml", key="target")
    msg = str(err.value)
    assert msg.startswith(f"study.toml: {key}:") and words in msg and "\n" not in msg


# ---------------------------------------------------------------------------------------------
# the literature's four-bar as an explorer mechanism
# ---------------------------------------------------------------------------------------------

def coupler_closed_form(theta2, r1, r2, r3, r4, rcx, rcy, theta0, x0, y0, branch):
    """Plain numpy: the crank pin on its circle, the rocker pin where the coupler and rocker circles
    meet on side ``branch`` of the line crank pin → rocker pivot (+1: left), the coupler point in the
    coupler's frame (x along crank pin → rocker pin)."""
    O2 = np.array([x0, y0])
    O4 = O2 + r1 * np.array([np.cos(theta0), np.sin(theta0)])
    A = O2 + r2 * np.stack([np.cos(theta0 + theta2), np.sin(theta0 + theta2)], -1)
    g = O4 - A
    d = np.linalg.norm(g, axis=-1)
    a = (r3 ** 2 - r4 ** 2 + d ** 2) / (2 * d)
    hh = np.sqrt(r3 ** 2 - a ** 2)
    u = g / d[:, None]
    left = np.stack([-u[:, 1], u[:, 0]], -1)
    B = A + a[:, None] * u + branch * hh[:, None] * left
    ex = (B - A) / r3
    ey = np.stack([-ex[:, 1], ex[:, 0]], -1)
    return A + rcx * ex + rcy * ey


@pytest.mark.parametrize("branch", [1, -1])
@pytest.mark.parametrize("X", [
    dict(r1=4.0, r2=1.0, r3=3.5, r4=3.0, rcx=1.5, rcy=-2.0, theta0=0.6, x0=1.0, y0=-2.0),
    dict(r1=30.0, r2=8.0, r3=27.0, r4=22.0, rcx=-5.0, rcy=12.0, theta0=4.0, x0=-10.0, y0=7.0),
])
def test_fourbar_mechanism_dict_against_closed_form(X, branch):
    mech = mechanism_from_dict(problems.fourbar_mechanism_dict(**X, branch=branch), "test")
    cyc = simulate(mech, steps=360)
    assert cyc.ok
    theta = cyc.theta  # explorer's crank angle θ = θ0 + θ2
    ref = coupler_closed_form(theta - X["theta0"], branch=branch, **X)
    scale = max(X["r1"], X["r3"])
    assert np.max(np.linalg.norm(cyc.path("P") - ref, axis=-1)) < 1e-9 * scale
    # the literature's helper agrees, and the parameters map both ways
    pts = problems.fourbar_points(**X, theta2=theta[::40] - X["theta0"], branch=branch)
    assert np.allclose(np.array(pts), ref[::40], atol=1e-12 * scale)
    params = mech.parameters()
    for k, v in problems.explorer_parameters(**X).items():
        assert math.isclose(params[k], v, rel_tol=1e-12, abs_tol=1e-12)
    back = problems.source_variables(params)
    for k, v in X.items():
        assert math.isclose(back[k], v % (2 * np.pi) if k == "theta0" else v, rel_tol=1e-12, abs_tol=1e-12)


def test_timed_five_is_met_by_a_four_bar():
    """The timed literature problem run through explorer end to end: the four-bar found for it,
    simulated, matched at the prescribed crank angles (from the ground link: angle_offset θ0)."""
    p = problems.TIMED_FIVE
    X, branch = problems.CONSISTENT_TIMED_FIVE
    cyc = simulate(mechanism_from_dict(problems.fourbar_mechanism_dict(**X, branch=branch), "t"), steps=360)
    assert cyc.ok
    target = load_target(p.target_spec())
    assert target.match == "timed" and np.allclose(target.angles, p.angles)
    e = target.error(cyc.path("P")[None], cyc.velocity("P")[None], angle_offset=X["theta0"])
    # 2.71e-7 is the sum of squares over five points (rounded parameters: 1e-6 slack)
    assert abs(e[0] - math.sqrt(problems.CONSISTENT_TIMED_FIVE_SUMSQ / 5)) < 1e-6
    ref = coupler_closed_form(np.array(p.angles), branch=branch, **X)
    assert np.isclose(e[0], np.sqrt(np.mean(np.sum((ref - np.array(p.points)) ** 2, axis=1))), atol=1e-9)
