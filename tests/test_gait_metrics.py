"""Gait metrics: the Numba batch kernel against plain numpy references and known answers."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import explorer
from explorer.errors import UserError
from explorer.gait import (DESCRIPTIONS, DIRECTIONS, FOOT_METRICS, METRICS, PATH_METRICS, UNITS, VELOCITY_METRICS,
                           compute_metrics, min_transmission_angle)
from explorer.plan import fourbar_loops
from naive_gait import naive_metrics, naive_stance, naive_transmission


def _one(path, vel=None, band=0.01, names=None):
    """compute_metrics on a single path; returns name -> float."""
    if names is None:
        names = FOOT_METRICS if vel is not None else PATH_METRICS
    out = compute_metrics(path[None], None if vel is None else vel[None], np.zeros(1, dtype=np.int8), names, band)
    return {k: float(v[0]) for k, v in out.items()}


def _assert_matches_naive(path, vel=None, band=0.01, rtol=1e-9, atol=1e-12):
    got = _one(path, vel, band)
    ref = naive_metrics(path, vel, band)
    for k, v in got.items():
        assert math.isnan(v) == math.isnan(ref[k]), (k, v, ref[k])
        if not math.isnan(v):
            assert v == pytest.approx(ref[k], rel=rtol, abs=atol), k
    return got


# -- the nominal Jansen leg ----------------------------------------------------------------------------
@pytest.fixture(scope="module")
def jansen():
    mech = explorer.load_mechanism("jansen")
    return mech, explorer.simulate(mech, 360), explorer.simulate(mech, 1440)


def test_nominal_figures(jansen):
    mech, c360, c1440 = jansen
    assert c360.ok and c1440.ok
    m = _one(c360.path(mech.foot), c360.velocity(mech.foot))
    assert m["width"] == pytest.approx(67.908, abs=5e-4)
    assert m["height"] == pytest.approx(22.457, abs=5e-4)
    assert m["stride"] == pytest.approx(43.409, abs=5e-4)
    assert m["duty"] == pytest.approx(0.314, abs=5e-4)
    assert m["flatness"] == pytest.approx(0.00116, abs=5e-6)
    assert m["stance_speed"] == pytest.approx(22.2, abs=0.05)
    assert m["speed_ripple"] == pytest.approx(0.092, abs=1e-3)
    assert m["max_speed"] == pytest.approx(53.6, abs=0.05)
    m4 = _one(c1440.path(mech.foot), c1440.velocity(mech.foot))
    assert m4["duty"] == pytest.approx(0.312, abs=5e-4)
    assert m4["flatness"] == pytest.approx(0.00112, abs=5e-6)


@pytest.mark.parametrize("steps", [360, 1440])
def test_nominal_against_naive(jansen, steps):
    mech, c360, c1440 = jansen
    c = c360 if steps == 360 else c1440
    path, vel = c.path(mech.foot), c.velocity(mech.foot)
    got = _assert_matches_naive(path, vel)
    # the nominal stance wraps past θ = 0
    idx = naive_stance(path[:, 1], 0.01)
    assert 0 in idx and idx[0] > idx[-1]
    assert got["stance_rms_line"] > 0


def test_nominal_transmission_angle(jansen):
    mech, _, c1440 = jansen
    got = compute_metrics(c1440.path(mech.foot)[None], c1440.velocity(mech.foot)[None], [0], mechanism=mech)
    # every metric but path synthesis's, which needs a target path, and the forces effect's, which needs
    # every vertex and an operating point (simulate_batch(..., forces=True))
    from explorer.gait import FORCE_METRICS, PHYSICS_METRICS, ROBUSTNESS_METRICS
    assert list(got) == [m for m in METRICS if m != "path_error" and m not in FORCE_METRICS
                         and m not in ROBUSTNESS_METRICS and m not in PHYSICS_METRICS
                         and m != "quick_return"]  # a slider's metric
    ref = naive_transmission(c1440.positions, mech)
    assert got["min_transmission_angle"][0] == pytest.approx(ref, abs=0.01)
    assert len(fourbar_loops(mech)) == 2


def test_transmission_angle_variants_and_fourbar():
    fb = explorer.load_mechanism("fourbar")
    # by hand: g = 30, r = 10, coupler 30, rocker 25 -> μ(d = 20) = acos(0.75) = 41.41°, 180 - μ(d = 40) = 87.13°
    assert min_transmission_angle(fb)[0] == pytest.approx(math.degrees(math.acos(0.75)), abs=1e-12)
    c = explorer.simulate(fb, 1440)
    assert min_transmission_angle(fb)[0] == pytest.approx(naive_transmission(c.positions, fb), abs=0.01)
    # one varied variant, one failed one, per-variant crank radii
    jm = explorer.load_mechanism("jansen")
    L = np.tile(jm.lengths, (3, 1))
    L[1, jm.link_index("2-6")] *= 1.01
    r = np.array([15.0, 14.5, 15.0])
    got = min_transmission_angle(jm, L, r, status=np.array([0, 0, 3]))
    var = jm.with_lengths({"2-6": L[1, jm.link_index("2-6")]}, crank=14.5)
    cv = explorer.simulate(var, 1440)
    assert cv.ok
    assert got[1] == pytest.approx(naive_transmission(cv.positions, var), abs=0.01)
    assert math.isnan(got[2])
    # a loop that cannot close at an extreme is NaN
    L[0, jm.link_index("1-6")] = 200.0
    assert math.isnan(min_transmission_angle(jm, L[:1], r[:1])[0])


# -- synthetic paths with known answers -------------------------------------------------------------
def _circle(S, R=10.0, shift=0):
    """Foot on a circle, bottom at θ = π (sample S/2), then rolled by ``shift`` samples; speed R per radian."""
    th = 2 * np.pi * np.arange(S) / S
    path = np.stack([3.0 + R * np.sin(th), -50.0 + R * np.cos(th)], axis=1)
    vel = np.stack([R * np.cos(th), -R * np.sin(th)], axis=1)
    return np.roll(path, shift, axis=0), np.roll(vel, shift, axis=0)


@pytest.mark.parametrize("band", [0.01, 0.05, 0.2])
def test_circle_known_answers(band):
    S, R = 3600, 10.0
    path, vel = _circle(S, R)
    m = _assert_matches_naive(path, vel, band)
    alpha = math.acos(1 - 2 * band)  # half the angular extent of the stance
    step = 2 * math.pi / S
    assert m["duty"] == pytest.approx(alpha / math.pi, abs=2 / S)
    assert m["stride"] == pytest.approx(2 * R * math.sin(alpha), abs=2 * R * step)
    assert m["width"] == pytest.approx(2 * R, abs=1e-9)
    assert m["height"] == pytest.approx(2 * R, abs=1e-9)
    e_cos2 = 0.5 + math.sin(2 * alpha) / (4 * alpha)
    std = R * math.sqrt(e_cos2 - (math.sin(alpha) / alpha) ** 2)
    assert m["flatness"] == pytest.approx(std / (2 * R * math.sin(alpha)), rel=2e-2)
    # the arc is symmetric about x = 3: its least-squares line is horizontal, so rms_line = std of y
    assert m["stance_rms_line"] == pytest.approx(m["flatness"] * m["stride"], rel=1e-6)
    assert m["stance_speed"] == pytest.approx(R, rel=1e-12)
    assert m["speed_ripple"] == pytest.approx(0.0, abs=1e-12)
    assert m["max_speed"] == pytest.approx(R, rel=1e-12)


@pytest.mark.parametrize("shift", [1800, 1799, 1801, 1700, 1000])
def test_circle_stance_wrapping_past_zero(shift):
    """Rolling the samples moves the stance across θ = 0; the metrics do not change."""
    S = 3600
    base = _one(*_circle(S))
    path, vel = _circle(S, shift=shift)
    idx = naive_stance(path[:, 1], 0.01)
    if shift >= 1700:  # the bottom lands within 114 samples of θ = 0
        assert 0 in idx and idx[0] > idx[-1]  # the stance really wraps
    m = _assert_matches_naive(path, vel)
    for k in base:
        assert m[k] == pytest.approx(base[k], rel=1e-9, abs=1e-15), k


def _flat_bottom(n_flat=120, n_arc=101, L=40.0):
    """A 'D': a flat segment y = -80 from x = -L/2 to L/2 (n_flat samples, both ends), then a half circle."""
    xf = np.linspace(-L / 2, L / 2, n_flat)
    phi = np.pi * np.arange(1, n_arc + 1) / (n_arc + 1)
    flat = np.stack([xf, np.full(n_flat, -80.0)], axis=1)
    arc = np.stack([(L / 2) * np.cos(phi), -80.0 + (L / 2) * np.sin(phi)], axis=1)
    return np.concatenate([flat, arc])


@pytest.mark.parametrize("shift", [0, -30, -60, -119, 200])
def test_flat_bottom_known_answers(shift):
    path = np.roll(_flat_bottom(), shift, axis=0)
    S = len(path)
    rng = np.random.default_rng(abs(shift))
    vel = rng.normal(size=(S, 2))
    m = _assert_matches_naive(path, vel)
    assert m["duty"] == pytest.approx(120 / S, abs=1e-15)
    assert m["stride"] == pytest.approx(40.0, abs=1e-12)
    assert m["width"] == pytest.approx(40.0, abs=1e-12)
    assert m["height"] == pytest.approx(20.0, rel=1e-6)
    assert m["flatness"] == 0.0
    assert m["stance_rms_line"] == pytest.approx(0.0, abs=1e-12)
    if shift < 0:  # part of the flat lies before θ = 0, part after
        idx = naive_stance(path[:, 1], 0.01)
        assert 0 in idx and idx[0] > idx[-1]


def test_tilted_line_rms_is_perpendicular():
    """Stance points off a sloped line by ±h vertically are h / sqrt(1 + b²) from it."""
    S, b, h = 400, 0.5, 0.01
    xs = np.linspace(0.0, 10.0, 100)
    ys = b * xs + h * (-1.0) ** np.arange(100)
    # the rest of the cycle rises far above, so only the 100 points are in the stance
    back = np.stack([np.linspace(10.0, 0.0, S - 100 + 2)[1:-1], np.full(S - 100, 1000.0)], axis=1)
    path = np.concatenate([np.stack([xs, ys], axis=1), back])
    m = _assert_matches_naive(path, band=0.01)
    assert m["duty"] == 100 / S
    # least squares of alternating ±h over an even count: slope differs from b by O(h/n)
    assert m["stance_rms_line"] == pytest.approx(h / math.sqrt(1 + b * b), rel=1e-2)


def test_ties_go_to_the_smallest_start_and_band_limits():
    y = np.array([0.0, 0.0, 5.0, 0.0, 0.0, 5.0])
    x = np.array([0.0, 1.0, 2.0, 10.0, 13.0, 20.0])
    assert _one(np.stack([x, y], 1))["stride"] == 1.0  # run at 0-1, not 3-4
    y = np.array([0.0, 5.0, 0.0, 0.0, 5.0, 0.0])        # runs {5, 0} (wraps, start 5) and {2, 3}
    x = np.array([0.0, 2.0, 10.0, 13.0, 20.0, 1.5])
    assert _one(np.stack([x, y], 1))["stride"] == 3.0
    path = _flat_bottom()
    assert _one(path, band=1.0)["duty"] == 1.0
    assert _one(path, band=0.0)["duty"] == pytest.approx(120 / len(path))


def test_degenerate_paths():
    S = 50
    const = np.tile([[1.0, 2.0]], (S, 1))
    m = _one(const, np.zeros((S, 2)))
    assert m["width"] == 0 and m["height"] == 0 and m["duty"] == 1.0 and m["stride"] == 0
    assert math.isnan(m["flatness"]) and math.isnan(m["stance_rms_line"])
    assert m["stance_speed"] == 0 and math.isnan(m["speed_ripple"]) and m["max_speed"] == 0
    # a single lowest sample (a sharp V): stride 0, flatness and line undefined
    th = 2 * np.pi * np.arange(S) / S
    v = np.stack([np.cos(th), np.abs(np.sin(th / 2)) * 10], axis=1)
    m = _one(v, band=0.0)
    assert m["duty"] == 1 / S and m["stride"] == 0.0
    assert math.isnan(m["flatness"]) and math.isnan(m["stance_rms_line"])
    # horizontal back-and-forth: perfectly flat
    m = _one(np.stack([np.cos(th), np.zeros(S)], axis=1))
    assert m["duty"] == 1.0 and m["flatness"] == 0.0 and m["stance_rms_line"] == 0.0


@settings(max_examples=150, deadline=None)
@given(st.lists(st.integers(0, 4), min_size=2, max_size=24), st.sampled_from([0.0, 0.01, 0.3, 0.5, 1.0]),
       st.integers(0, 2**32 - 1))
def test_random_paths_match_naive(ys, band, seed):
    rng = np.random.default_rng(seed)
    y = np.array(ys, dtype=float)
    path = np.stack([rng.normal(size=len(y)), y], axis=1)
    vel = rng.normal(size=(len(y), 2))
    _assert_matches_naive(path, vel, band, rtol=1e-7, atol=1e-9)


# -- batches, failures, selection, validation --------------------------------------------------------
def test_batch_failed_variants_get_nan():
    S = 360
    p0, v0 = _circle(S)
    paths = np.stack([p0, p0 * 2, np.full_like(p0, np.nan), p0, p0])
    vel = np.stack([v0, v0 * 2, np.full_like(v0, np.nan), v0, v0])
    paths[3, 17, 0] = np.nan          # status says ok but the path is broken: NaN, no exception
    vel[4, 5, 1] = np.inf             # broken velocity: only the speed metrics are NaN
    status = np.array([0, 0, 1, 0, 0], dtype=np.int8)
    out = compute_metrics(paths, vel, status)
    # without a mechanism: the single-leg metrics and the path's self-crossings (tested in test_screen)
    assert list(out) == list(FOOT_METRICS) + ["self_crossings"]
    del out["self_crossings"]
    for k, v in out.items():
        assert v.shape == (5,) and v.dtype == np.float64
        assert not math.isnan(v[0]) and not math.isnan(v[1])
        assert math.isnan(v[2]) and math.isnan(v[3])
        assert math.isnan(v[4]) == (k in VELOCITY_METRICS)
        assert v[0] == pytest.approx(naive_metrics(p0, v0)[k], rel=1e-9, abs=1e-15)
    assert out["stride"][1] == pytest.approx(2 * out["stride"][0])
    assert out["flatness"][1] == pytest.approx(out["flatness"][0])
    # failed variants never raise, whatever they hold
    bad = np.full((2, S, 2), np.inf)
    out = compute_metrics(bad, bad, [5, 7])
    assert all(np.isnan(v).all() for v in out.values())
    out = compute_metrics(np.zeros((0, S, 2)), np.zeros((0, S, 2)), np.zeros(0, dtype=int))
    assert all(v.shape == (0,) for v in out.values())


def test_names_selection_and_errors():
    p, v = _circle(360)
    P, V = p[None], v[None]
    out = compute_metrics(P, None, None, names=["flatness", "stride"])
    assert list(out) == ["stride", "flatness"]
    assert list(compute_metrics(P, V, names="max_speed")) == ["max_speed"]
    assert compute_metrics(P, V, names=[]) == {}
    with pytest.raises(UserError, match="velocities"):
        compute_metrics(P, None, names=["stride", "speed_ripple"])
    with pytest.raises(UserError, match="velocities"):
        compute_metrics(P, None)  # all metrics need velocities too
    with pytest.raises(UserError, match=r"unknown metric 'stridee'.*known: travel, bob, .*width, height, stride"):
        compute_metrics(P, V, names=["stridee"])
    with pytest.raises(UserError, match="mechanism"):
        compute_metrics(P, V, names=["min_transmission_angle"])
    # without a mechanism, "all" means the foot metrics (and the crossings of the foot path)
    assert list(compute_metrics(P, V, names=True)) == list(FOOT_METRICS) + ["self_crossings"]
    with pytest.raises(UserError, match="travel: needs a crank-driven mechanism"):
        compute_metrics(P, V, names=["travel"])
    with pytest.raises(UserError, match="paths"):
        compute_metrics(p, v)
    with pytest.raises(UserError, match="velocities"):
        compute_metrics(P, V[:, :10])
    with pytest.raises(UserError, match="status"):
        compute_metrics(P, V, [0, 0])
    for band in (-0.1, 1.5, float("nan"), "x", True):
        with pytest.raises(UserError, match="band"):
            compute_metrics(P, V, band=band)
    fb = explorer.load_mechanism("fourbar")
    with pytest.raises(UserError, match="lengths"):
        compute_metrics(P, V, names=["min_transmission_angle"], mechanism=fb, lengths=np.ones((2, 4)))


def test_float32_and_metadata():
    p, v = _circle(360)
    a = compute_metrics(p[None].astype(np.float32), v[None].astype(np.float32))
    b = compute_metrics(p[None], v[None])
    for k in a:
        assert a[k][0] == pytest.approx(b[k][0], rel=1e-4, abs=1e-6)
    assert set(DIRECTIONS) == set(UNITS) == set(DESCRIPTIONS) == set(METRICS)
    assert set(DIRECTIONS.values()) <= {"max", "min"}
    assert DIRECTIONS["stride"] == "max" and DIRECTIONS["flatness"] == "min" and DIRECTIONS["speed_ripple"] == "min"
