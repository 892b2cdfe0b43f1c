"""Prescribed-path drivers: line, arc and points (natural cubic spline), with linear and quintic timing.

The driven vertex must sit exactly on the analytic path (arc: centre + R·(cos φ, sin φ) with
φ = φ0 + s(t)·(φ1 − φ0); points: the natural cubic spline through the points with uniform knots,
scipy's CubicSpline) at the timing law s(t); velocities and accelerations per second follow the
chain rule. The [driver] table is validated with one-line UserErrors naming the file and key.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.interpolate import CubicSpline

import naive_mech as nm
from explorer import UserError, load_mechanism, simulate
from explorer.mechanism import mechanism_from_dict

L1, L2 = 2.0, 1.0


def arm_with(driver: dict, name="arm-driver", elbow=+1, start=None):
    """The two-link arm with its tip on ``driver``; the elbow guess is the IK elbow (sign ``elbow``) at
    the path's start point ``start``."""
    d = nm.builtin_dict("arm")
    d["driver"] = dict(driver)
    if start is not None:
        d["guess"]["E"] = [float(c) for c in nm.two_link_elbow(start[0], start[1], L1, L2, elbow)]
    return mechanism_from_dict(d, name)


def check_elbow(c, elbow):
    tip = c.path("T")
    np.testing.assert_allclose(c.path("E"), nm.two_link_elbow(tip[:, 0], tip[:, 1], L1, L2, elbow), rtol=0,
                               atol=1e-9)


# -- arcs --------------------------------------------------------------------------------------------------------
ARCS = {
    "ccw": dict(center=[2.0, 0.0], radius=0.6, start_angle=30.0, end_angle=250.0, duration=4.0),
    "cw": dict(center=[0.0, 1.8], radius=0.5, start_angle=200.0, end_angle=-60.0, duration=2.5),
}


@pytest.mark.parametrize("method", ["block", "dense", "auto"])
@pytest.mark.parametrize("timing", ["linear", "quintic"])
@pytest.mark.parametrize("arc", sorted(ARCS))
def test_arc_path_matches_analytic_arc(arc, timing, method):
    a = ARCS[arc]
    cx, cy = a["center"]
    R, T = a["radius"], a["duration"]
    phi0, phi1 = math.radians(a["start_angle"]), math.radians(a["end_angle"])
    start = (cx + R * math.cos(phi0), cy + R * math.sin(phi0))
    mech = arm_with(dict(vertex="T", path="arc", timing=timing, **a), start=start)
    c = simulate(mech, 81, tolerance=1e-12, accelerations=True, method=method)
    assert c.ok, c.failure
    np.testing.assert_allclose(c.theta, T * np.arange(81) / 80, rtol=0, atol=1e-15)
    s, ds, dds = nm.timing(timing, T, c.theta)
    phi = phi0 + s * (phi1 - phi0)
    w, al = ds * (phi1 - phi0), dds * (phi1 - phi0)
    u = np.stack([np.cos(phi), np.sin(phi)], axis=-1)
    n = np.stack([-np.sin(phi), np.cos(phi)], axis=-1)
    np.testing.assert_allclose(c.path("T"), [cx, cy] + R * u, rtol=0, atol=1e-13)
    np.testing.assert_allclose(c.velocity("T"), R * w[:, None] * n, rtol=0, atol=1e-13)
    acc = c.accelerations[:, mech.vertex_index("T")]
    np.testing.assert_allclose(acc, R * al[:, None] * n - R * (w ** 2)[:, None] * u, rtol=0, atol=1e-13)
    # the tip really is on the circle, and the arc ends where it should
    np.testing.assert_allclose(np.hypot(*(c.path("T") - [cx, cy]).T), R, rtol=0, atol=1e-13)
    np.testing.assert_allclose(c.path("T")[-1], [cx + R * math.cos(phi1), cy + R * math.sin(phi1)], atol=1e-13)
    check_elbow(c, +1)
    fd = nm.central_difference(lambda t: nm.two_link_elbow(*tip_arc(a, timing, t).T, L1, L2, +1), c.theta, h=1e-6)
    np.testing.assert_allclose(c.velocity("E"), fd, rtol=0, atol=1e-6 * np.abs(fd).max())


def tip_arc(a, timing, t):
    s = nm.timing(timing, a["duration"], t)[0]
    phi = math.radians(a["start_angle"]) + s * math.radians(a["end_angle"] - a["start_angle"])
    return np.asarray(a["center"]) + a["radius"] * np.stack([np.cos(phi), np.sin(phi)], axis=-1)


# -- points: natural cubic spline with uniform knots ---------------------------------------------------------------
POINTS = [[-1.0, 1.5], [0.5, 2.0], [1.5, 1.5], [2.0, 0.5]]


@pytest.mark.parametrize("timing", ["linear", "quintic"])
def test_points_path_is_the_natural_spline(timing):
    T = 6.0
    mech = arm_with(dict(vertex="T", path="points", points=POINTS, duration=T, timing=timing), start=POINTS[0])
    S = 61  # t_k = 0.1 k: with linear timing the knots s = 1/3, 2/3 fall on samples 20 and 40
    c = simulate(mech, S, tolerance=1e-12, accelerations=True)
    assert c.ok, c.failure
    spline = CubicSpline(np.linspace(0.0, 1.0, len(POINTS)), np.array(POINTS), bc_type="natural")
    s, ds, dds = nm.timing(timing, T, c.theta)
    np.testing.assert_allclose(c.path("T"), spline(s), rtol=0, atol=1e-13)
    np.testing.assert_allclose(c.velocity("T"), spline(s, 1) * ds[:, None], rtol=0, atol=1e-13)
    acc = c.accelerations[:, mech.vertex_index("T")]
    np.testing.assert_allclose(acc, spline(s, 2) * ds[:, None] ** 2 + spline(s, 1) * dds[:, None], rtol=0,
                               atol=1e-12)
    # through every point, and natural: no curvature at the ends
    np.testing.assert_allclose(c.path("T")[[0, -1]], [POINTS[0], POINTS[-1]], rtol=0, atol=1e-13)
    if timing == "linear":
        np.testing.assert_allclose(c.path("T")[[20, 40]], POINTS[1:3], rtol=0, atol=1e-13)
        np.testing.assert_allclose(acc[[0, -1]], 0.0, atol=1e-12)
    else:  # the quintic rests at both ends
        np.testing.assert_allclose(c.velocity("T")[[0, -1]], 0.0, atol=1e-15)
    check_elbow(c, +1)


def test_two_points_are_a_straight_line():
    mech = arm_with(dict(vertex="T", path="points", points=[[-1.0, 1.0], [2.0, 1.0]], duration=10.0,
                         timing="quintic"))
    line = load_mechanism("arm")
    a, b = simulate(mech, 41, tolerance=1e-12), simulate(line, 41, tolerance=1e-12)
    assert a.ok and b.ok
    np.testing.assert_allclose(a.positions, b.positions, rtol=0, atol=1e-12)
    np.testing.assert_allclose(a.velocities, b.velocities, rtol=0, atol=1e-12)


# -- timing laws -----------------------------------------------------------------------------------------------------
def test_timing_laws_at_known_tau():
    """Tip on the line x = −1 + 3s, y = 1 over 10 s, sampled at τ = 0, ¼, ½, ¾, 1."""
    tau = np.array([0.0, 0.25, 0.5, 0.75, 1.0])
    expected = {
        # s = 10τ³ − 15τ⁴ + 6τ⁵ and ds/dt = 30τ²(1 − τ)²/T, d²s/dt² = 60τ(1 − τ)(1 − 2τ)/T²
        "quintic": ([0.0, 0.103515625, 0.5, 0.896484375, 1.0],
                    [0.0, 0.10546875, 0.1875, 0.10546875, 0.0],
                    [0.0, 0.05625, 0.0, -0.05625, 0.0]),
        "linear": (tau, [0.1] * 5, [0.0] * 5),
    }
    for timing, (s, ds, dds) in expected.items():
        d = nm.builtin_dict("arm")
        d["driver"]["timing"] = timing
        c = simulate(mechanism_from_dict(d, timing), 5, tolerance=1e-12, accelerations=True)
        assert c.ok
        np.testing.assert_allclose(c.theta, 10.0 * tau, rtol=0, atol=1e-15)
        T = c.path("T")
        np.testing.assert_allclose((T[:, 0] + 1.0) / 3.0, s, rtol=0, atol=1e-15)
        np.testing.assert_allclose(T[:, 1], 1.0, rtol=0, atol=0)
        np.testing.assert_allclose(c.velocity("T")[:, 0] / 3.0, ds, rtol=0, atol=1e-15)
        np.testing.assert_allclose(c.accelerations[:, 0, 0] / 3.0, dds, rtol=0, atol=1e-15)
        # the reference module agrees with the same numbers
        np.testing.assert_allclose(np.stack(nm.timing(timing, 10.0, 10.0 * tau)), [s, ds, dds], rtol=0, atol=1e-15)


def test_quintic_is_seed_004s_polynomial():
    """Seed 004 solves a 6×6 system for X_e(t) = a t⁵ + … + f (rest to rest from −1 to 2 in 10 s);
    the tip of the built-in arm follows that polynomial, and Y_e stays 1."""
    c = simulate(load_mechanism("arm"), 101, tolerance=1e-12)
    xe = nm.quintic_from_seed(10.0, -1.0, 2.0)
    ye = nm.quintic_from_seed(10.0, 1.0, 1.0)
    np.testing.assert_allclose(c.path("T")[:, 0], xe(c.theta), rtol=0, atol=1e-12)
    np.testing.assert_allclose(c.path("T")[:, 1], ye(c.theta), rtol=0, atol=1e-12)


def test_timing_defaults_to_linear():
    d = nm.builtin_dict("arm")
    del d["driver"]["timing"]
    m = mechanism_from_dict(d, "no-timing")
    assert m.path.timing == "linear"
    c = simulate(m, 11)
    np.testing.assert_allclose(c.path("T")[:, 0], np.linspace(-1.0, 2.0, 11), rtol=0, atol=1e-15)


# -- validation of the [driver] table ----------------------------------------------------------------------------------
BODY = """
name = "arm-check"
foot = "T"
{head}
[fixed]
O = [0.0, 0.0]

[guess]
E = [-0.6, 1.9]

[[links]]
name = "upper"
a = "O"
b = "E"
length = 2.0

[[links]]
name = "fore"
a = "E"
b = "T"
length = 1.0
"""
LINE = {"vertex": '"T"', "path": '"line"', "start": "[-1.0, 1.0]", "end": "[2.0, 1.0]", "duration": "10.0",
        "timing": '"quintic"'}
ARC = {"vertex": '"T"', "path": '"arc"', "center": "[2.0, 0.0]", "radius": "0.6", "start_angle": "30.0",
       "end_angle": "250", "duration": "4.0"}
PTS = {"vertex": '"T"', "path": '"points"', "points": "[[-1.0, 1.5], [0.5, 2.0], [2.0, 0.5]]", "duration": "6"}
CRANK = '[crank]\ncenter = [0.0, 0.0]\nradius = 1.0\ntip = "T"\n'


def driver_table(base, drop=(), **changes):
    t = {k: v for k, v in base.items() if k not in drop}
    t.update(changes)
    return "[driver]\n" + "".join(f"{k} = {v}\n" for k, v in t.items())


BAD = {
    # what is wrong -> (the [driver]/[crank] head of the file, the key the message must name)
    "missing vertex": (driver_table(LINE, drop=["vertex"]), "driver.vertex"),
    "missing path": (driver_table(LINE, drop=["path"]), "driver.path"),
    "missing duration": (driver_table(LINE, drop=["duration"]), "driver.duration"),
    "line without end": (driver_table(LINE, drop=["end"]), "driver.end"),
    "arc without radius": (driver_table(ARC, drop=["radius"]), "driver.radius"),
    "arc without end_angle": (driver_table(ARC, drop=["end_angle"]), "driver.end_angle"),
    "points without points": (driver_table(PTS, drop=["points"]), "driver.points"),
    "unknown path": (driver_table(LINE, path='"circle"'), "driver.path"),
    "path not a string": (driver_table(LINE, path="3"), "driver.path"),
    "unknown key": (driver_table(LINE, speed="2.0"), "driver.speed"),
    "line with radius": (driver_table(LINE, radius="1.0"), "driver.radius"),
    "line with points": (driver_table(LINE, points="[[0.0, 0.0], [1.0, 1.0]]"), "driver.points"),
    "arc with start": (driver_table(ARC, start="[0.0, 0.0]"), "driver.start"),
    "points with center": (driver_table(PTS, center="[0.0, 0.0]"), "driver.center"),
    "bad timing": (driver_table(LINE, timing='"cubic"'), "driver.timing"),
    "timing not a string": (driver_table(LINE, timing="5"), "driver.timing"),
    "zero duration": (driver_table(LINE, duration="0.0"), "driver.duration"),
    "negative duration": (driver_table(LINE, duration="-1.0"), "driver.duration"),
    "infinite duration": (driver_table(LINE, duration="inf"), "driver.duration"),
    "duration not a number": (driver_table(LINE, duration='"ten"'), "driver.duration"),
    "bad start point": (driver_table(LINE, start="[1.0]"), "driver.start"),
    "non-finite end point": (driver_table(LINE, end="[nan, 1.0]"), "driver.end"),
    "negative radius": (driver_table(ARC, radius="-0.6"), "driver.radius"),
    "angle not a number": (driver_table(ARC, start_angle='"north"'), "driver.start_angle"),
    "boolean angle": (driver_table(ARC, end_angle="true"), "driver.end_angle"),
    "one point": (driver_table(PTS, points="[[0.0, 1.0]]"), "driver.points"),
    "bad point": (driver_table(PTS, points="[[0.0, 1.0], [1.0]]"), "driver.points[1]"),
    "driver not a table": ('driver = "line"\n', "driver"),
    "both crank and driver": (CRANK + driver_table(LINE), "crank"),
    "neither crank nor driver": ("", "crank"),
}


@pytest.mark.parametrize("case", sorted(BAD))
def test_driver_table_errors_name_file_and_key(tmp_path, case):
    head, key = BAD[case]
    path = tmp_path / "bad_driver.toml"
    path.write_text(BODY.format(head=head), encoding="utf-8")
    with pytest.raises(UserError) as err:
        load_mechanism(path)
    msg = str(err.value)
    assert msg.startswith(f"{path}: "), msg
    assert f": {key}" in msg, msg
    assert "\n" not in msg


def test_valid_driver_tables_load(tmp_path):
    """The same file with each good [driver] table loads (so the errors above come from the one change)."""
    for i, table in enumerate((LINE, ARC, PTS)):
        path = tmp_path / f"good_{i}.toml"
        path.write_text(BODY.format(head=driver_table(table)), encoding="utf-8")
        m = load_mechanism(path)
        assert m.crank is None and m.driven == "T" and m.path.kind == table["path"].strip('"')


def test_driven_vertex_cannot_be_fixed(tmp_path):
    path = tmp_path / "fixed_tip.toml"
    path.write_text(BODY.format(head=driver_table(LINE, vertex='"O"')), encoding="utf-8")
    with pytest.raises(UserError) as err:
        load_mechanism(path)
    msg = str(err.value)
    assert msg.startswith(f"{path}: ") and ("driver.vertex" in msg or "fixed.O" in msg), msg


def test_driven_vertex_on_no_link(tmp_path):
    path = tmp_path / "loose_tip.toml"
    body = BODY.format(head=driver_table(LINE, vertex='"Q"')).replace("E = [-0.6, 1.9]", "E = [-0.6, 1.9]\nT = [0.0, 1.0]")
    path.write_text(body, encoding="utf-8")
    with pytest.raises(UserError) as err:
        load_mechanism(path)
    msg = str(err.value)
    assert msg.startswith(f"{path}: driver.vertex") and "Q" in msg, msg
